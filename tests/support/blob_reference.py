"""Independent exact solvers for the blob surface, for the tests (numpy only).

Nothing here comes from the plugin: the fields are written again from facts.md F11,
and surface points are found exactly along lines:

* ``tutorial`` field: the zone method. Along a line x_i(t) = |o + t d - c_i|^2 / R^2 is
  quadratic in t and f is linear in x between the zone spheres, so between consecutive
  zone-sphere crossings the field is a quadratic in t: solve it per interval.
* ``exact`` field: sum R^2 / q_i(t) = 1 with q_i quadratic, i.e. the polynomial
  prod_j q_j - R^2 sum_i prod_{j != i} q_j = 0 of degree 2N: all its real roots.
"""

from __future__ import annotations

import numpy as np

# f through the knots of facts.md F11.1, x ascending (plus the continued inner segment at x = 0).
SPEC_X = np.array([0.0, 1.0, 10 / 9, 1.25, 10 / 7, 5 / 3, 2.0, 2.5, 10 / 3, 5.0, 10.0])
SPEC_F = np.array([1.9, 1.0, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2, 0.0])


def field(p: np.ndarray, centers: np.ndarray, radius: float, kind: str) -> np.ndarray:
    """The field at points p (M, 3)."""
    x = ((p[:, None, :] - centers[None]) ** 2).sum(-1) / radius**2
    if kind == "exact":
        return (1.0 / x).sum(1)
    return np.interp(x, SPEC_X, SPEC_F, right=0.0).sum(1)


def exact_gradient(p: np.ndarray, centers: np.ndarray, radius: float) -> np.ndarray:
    """Gradient of sum R^2/d^2 (direction used by the tutorial's shading, pointing in)."""
    d = p[:, None, :] - centers[None]
    d2 = (d**2).sum(-1)
    return (-2 * radius**2 / d2[..., None] ** 2 * d).sum(1)


def line_roots(o: np.ndarray, d: np.ndarray, centers: np.ndarray, radius: float, kind: str
               ) -> list[np.ndarray]:
    """All t (sorted) with field(o + t d) = 1, for each line (o, d unit) of (M, 3) arrays."""
    return [(_roots_zone if kind == "tutorial" else _roots_poly)(oi, di, centers, radius)
            for oi, di in zip(o, d)]


def _roots_poly(o, d, centers, radius):
    return radius * _roots_poly_unit(o / radius, d, centers / radius)


def _roots_poly_unit(o, d, centers, radius=1.0):
    # q_i(t) = t^2 + 2 t d.(o - c) + |o - c|^2, in units of R (keeps the coefficients small)
    qs = [np.array([1.0, 2 * d @ (o - c), (o - c) @ (o - c)]) for c in centers]
    prod = np.array([1.0])
    for q in qs:
        prod = np.polymul(prod, q)
    rest = np.zeros(1)
    for i in range(len(qs)):
        term = np.array([radius**2])
        for j, q in enumerate(qs):
            if j != i:
                term = np.polymul(term, q)
        rest = np.polyadd(rest, term)
    r = np.roots(np.polysub(prod, rest))
    r = r[np.abs(r.imag) <= 1e-7 * (1 + np.abs(r.real))].real
    # polish with Newton on g(t) = sum R^2/q - 1 (roots of high degree lose digits)
    for _ in range(3):
        g = sum(radius**2 / np.polyval(q, r) for q in qs) - 1
        dg = sum(-radius**2 * np.polyval(np.polyder(q), r) / np.polyval(q, r) ** 2 for q in qs)
        r = r - g / np.where(dg != 0, dg, 1)
    return np.sort(r)


def _roots_zone(o, d, centers, radius):
    b = np.array([(d @ (o - c)) for c in centers])        # x_i = (t^2 + 2 b t + cc)/R^2
    cc = np.array([(o - c) @ (o - c) for c in centers])
    # events: crossings of every zone sphere x = SPEC_X[k] (k >= 1) of every source
    ev = []
    for bi, ci in zip(b, cc):
        for xk in SPEC_X[1:]:
            disc = bi * bi - (ci - xk * radius**2)
            if disc > 0:
                ev += [-bi - np.sqrt(disc), -bi + np.sqrt(disc)]
    ev = np.sort(np.array(ev + [-1e30, 1e30]))
    roots = []
    for t0, t1 in zip(ev[:-1], ev[1:]):
        if t1 - t0 <= 0:
            continue
        tm = 0.5 * (t0 + t1) if np.isfinite(t0 + t1) and abs(t0) < 1e29 and abs(t1) < 1e29 \
            else (t1 - 1.0 if t0 < -1e29 else t0 + 1.0)
        # zone of each source at the interval's middle gives f = a + s x on the interval
        A = B = 0.0
        C = -1.0
        for bi, ci in zip(b, cc):
            xm = (tm * tm + 2 * bi * tm + ci) / radius**2
            k = np.searchsorted(SPEC_X, xm, side="right")  # segment [SPEC_X[k-1], SPEC_X[k])
            if k >= len(SPEC_X):
                continue
            s = (SPEC_F[k] - SPEC_F[k - 1]) / (SPEC_X[k] - SPEC_X[k - 1])
            a = SPEC_F[k - 1] - s * SPEC_X[k - 1]
            A += s / radius**2
            B += s * 2 * bi / radius**2
            C += a + s * ci / radius**2
        for t in _quadratic(A, B, C):
            if t0 - 1e-9 * radius <= t <= t1 + 1e-9 * radius:
                roots.append(t)
    roots = np.sort(np.array(roots))
    # a root on an interval boundary is found by both intervals
    return roots[np.concatenate([[True], np.diff(roots) > 1e-7 * radius])] if len(roots) else roots


def _quadratic(a, b, c):
    if abs(a) < 1e-300:
        return [] if abs(b) < 1e-300 else [-c / b]
    disc = b * b - 4 * a * c
    if disc < 0:
        return []
    sq = np.sqrt(disc)
    q = -0.5 * (b + np.copysign(sq, b))
    r = [q / a]
    if q != 0:
        r.append(c / q)
    return sorted(r)


def first_hit(o, d, centers, radius, kind, tmin=1e-6):
    """First t > tmin with field = 1 along each ray (inf if none)."""
    out = []
    for r in line_roots(o, d, centers, radius, kind):
        r = r[r > tmin]
        out.append(r[0] if len(r) else np.inf)
    return np.array(out)


def distance_to_surface(p, centers, radius, kind):
    """Upper bound of each point's distance to the surface: the nearest root along the line
    through it in the direction of the exact field's gradient."""
    g = exact_gradient(p, centers, radius)
    n = g / np.linalg.norm(g, axis=1, keepdims=True)
    out = []
    for r in line_roots(p, n, centers, radius, kind):
        out.append(np.abs(r).min() if len(r) else np.inf)
    return np.array(out)


def surface_samples(centers, radius, kind, n_lines, rng):
    """Points on the surface: every crossing of random lines through the blob's bounding
    box (a sampling that reaches every part of the surface)."""
    lo = centers.min(0) - 1.2 * radius
    hi = centers.max(0) + 1.2 * radius
    p = lo + (hi - lo) * rng.random((n_lines, 3))
    d = rng.normal(size=(n_lines, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pts = [pi + r[:, None] * di for pi, di, r in zip(p, d, line_roots(p, d, centers, radius, kind))
           if len(r)]
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def point_triangle_distance(p, a, b, c):
    """Exact distance from points p to triangles (a, b, c), row-wise (Ericson, 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = p - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = p - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    denom = va + vb + vc
    denom = np.where(denom == 0, 1e-300, denom)
    v = vb / denom
    w = vc / denom
    q = a + v[:, None] * ab + w[:, None] * ac  # interior
    # edges and vertices
    def sel(mask, val):
        nonlocal q
        q = np.where(mask[:, None], val, q)
    with np.errstate(divide="ignore", invalid="ignore"):
        e_bc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
        wbc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        # Ericson tests these in the order A, B, AB, C, AC, BC; the last write wins here.
        sel(e_bc, b + wbc[:, None] * (c - b))
        sel((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + (d2 / (d2 - d6))[:, None] * ac)
        sel((d6 >= 0) & (d5 <= d6), c)
        sel((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + (d1 / (d1 - d3))[:, None] * ab)
        sel((d3 >= 0) & (d4 <= d3), b)
        sel((d1 <= 0) & (d2 <= 0), a)
    return np.linalg.norm(p - q, axis=1)


def distance_to_mesh(p, vertices, faces, k=24):
    """Upper bound of each point's distance to the mesh (exact distance to the k triangles
    with the nearest centroids; exact whenever the nearest triangle is among them)."""
    from scipy.spatial import cKDTree
    tri = vertices[faces]
    tree = cKDTree(tri.mean(1))
    _, idx = tree.query(p, k=min(k, len(faces)))
    idx = idx.reshape(len(p), -1)
    best = np.full(len(p), np.inf)
    for j in range(idx.shape[1]):
        t = tri[idx[:, j]]
        best = np.minimum(best, point_triangle_distance(p, t[:, 0], t[:, 1], t[:, 2]))
    return best


def distance_to_surface_local(p, centers, radius, kind, reach):
    """Upper bound of each point's distance to the surface, vectorized: bisection for a
    surface point within ``reach`` along the line through p in the direction of the exact
    field's gradient, on each side; inf where neither side changes sign."""
    g = exact_gradient(p, centers, radius)
    return _distance_along(p, g / np.linalg.norm(g, axis=1, keepdims=True), centers, radius,
                           kind, reach)


def sample_triangles(vertices, faces, per_face, rng):
    """Uniform random points on every triangle (per_face each), and their faces."""
    u = rng.random((len(faces), per_face, 2))
    flip = u.sum(-1) > 1
    u[flip] = 1 - u[flip]
    a, b, c = (vertices[faces[:, k]][:, None, :] for k in range(3))
    p = a + u[..., :1] * (b - a) + u[..., 1:] * (c - a)
    return p.reshape(-1, 3), np.repeat(np.arange(len(faces)), per_face)


def distance_to_surface_cone(p, centers, radius, kind, reach, rng, n_dirs=256, cone_deg=85.0):
    """Tighter upper bound for a few points: the nearest surface point along any of
    ``n_dirs`` lines in a cone around the exact field's gradient (at a crease of the zone
    field the nearest surface point is not along the gradient)."""
    g = exact_gradient(p, centers, radius)
    n = g / np.linalg.norm(g, axis=1, keepdims=True)
    best = distance_to_surface_local(p, centers, radius, kind, reach)
    for _ in range(n_dirs):
        d = n + np.tan(np.radians(cone_deg)) * rng.random((len(p), 1)) * _perpendicular(n, rng)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        best = np.minimum(best, _distance_along(p, d, centers, radius, kind, reach))
    return best


def _perpendicular(n, rng):
    r = rng.normal(size=n.shape)
    r -= (r * n).sum(1, keepdims=True) * n
    return r / np.linalg.norm(r, axis=1, keepdims=True)


def _distance_along(p, n, centers, radius, kind, reach, iters=50):
    g0 = field(p, centers, radius, kind) - 1
    best = np.where(g0 == 0, 0.0, np.inf)
    for side in (1.0, -1.0):
        ga = field(p + side * reach * n, centers, radius, kind) - 1
        ok = np.sign(ga) != np.sign(g0)
        lo, hi = np.zeros(len(p)), np.full(len(p), side * reach)
        for _ in range(iters):
            mid = 0.5 * (lo + hi)
            gm = field(p + mid[:, None] * n, centers, radius, kind) - 1
            same = np.sign(gm) == np.sign(g0)
            lo = np.where(same, mid, lo)
            hi = np.where(same, hi, mid)
        best = np.where(ok, np.minimum(best, np.abs(hi)), best)
    return best


def mesh_to_surface(vertices, faces, centers, radius, kind, max_error, per_face, rng):
    """Sampled distance from the mesh to the surface (upper bounds): ``per_face`` random
    points per triangle and the vertices; points above 0.9 max_error along the gradient
    line are checked again along a cone of lines."""
    p, _ = sample_triangles(vertices, faces, per_face, rng)
    p = np.concatenate([p, vertices])
    d = distance_to_surface_local(p, centers, radius, kind, 4 * max_error)
    again = d > 0.9 * max_error
    if again.any():
        d[again] = distance_to_surface_cone(p[again], centers, radius, kind, 4 * max_error, rng)
    return d
