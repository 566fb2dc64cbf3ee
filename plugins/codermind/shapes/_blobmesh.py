"""Tessellation of a metaball surface with a measured error bound (numpy + scikit-image).

The one entry point is :func:`build_blob_mesh`; the ``blob`` shape plugin calls it and a
traced Mitsuba shape (Mitsuba 3.10, Python shapes) can replace it without touching callers.

Pipeline for one cell size ``h``:

1. interval culling: boxes of 4x4x4 cells whose exact field range excludes 1 are skipped,
   so the field is evaluated in a narrow band around the surface only;
2. marching cubes (scikit-image, Lewiner) on the band;
3. every vertex is moved onto the true surface by bracketed root finding (Illinois) along the
   field's gradient line;
4. a few rounds of tangential relaxation (each vertex moves towards the mean of its
   neighbours within the tangent plane, then back onto the surface) spread out the
   clusters of vertices that marching cubes makes near grid corners;
5. ``tutorial`` field only: the mesh is cut along its creases (the zone spheres of every
   source, where the field's gradient jumps), new vertices placed exactly on the crease
   curves, so that each triangle lies on one smooth (spherical) piece;
6. the error is measured: for every triangle, distance to the surface at its centroid,
   its circumcentre when inside it (where the deviation of a triangle inscribed in a sphere
   is largest) and its edge midpoints, each an upper bound (distance to a surface point
   found along the gradient line).

:func:`build_blob_mesh` picks ``h`` from ``max_error``: it starts from the bound for a
triangle inscribed in a sphere of radius R and then applies the measured convergence rule
(error proportional to h^2) until the measured error is below ``max_error``.
"""

from __future__ import annotations

import math
import time
from typing import Callable, NamedTuple

import numpy as np
from skimage.measure import marching_cubes

from ._blobfield import FIELDS, BlobField, zone_index

NORMALS = ("exact", "field", "flat")
BLOCK = 4            # culling block size, in cells
RELAX_ROUNDS = 3     # tangential relaxation rounds
SNAP = 0.2           # crease cuts closer than SNAP * edge length to a vertex move the vertex
MIN_ANGLE_DEG = 0.5  # smallest angle we accept before collapsing a triangle's short edge


class BlobMeshError(ValueError):
    """Bad input to :func:`build_blob_mesh`; the message names the parameter."""


class BlobMesh(NamedTuple):
    vertices: np.ndarray    # (V, 3) float64, on the surface
    faces: np.ndarray       # (F, 3) int64, counter-clockwise seen from outside
    normals: np.ndarray     # (V, 3) unit vertex normals, pointing out (or empty for 'flat')
    achieved_error: float   # measured max distance from triangle interiors to the surface
    info: dict              # cell_size, passes, timings, min_angle_deg, ...


# ------------------------------------------------------------------------------------------
# root finding along lines
# ------------------------------------------------------------------------------------------

def _illinois(g: Callable[[np.ndarray, np.ndarray], np.ndarray], lo: np.ndarray, hi: np.ndarray,
              glo: np.ndarray, ghi: np.ndarray, tol: float, ftol: np.ndarray | float = 0.0,
              iters: int = 60) -> np.ndarray:
    """Roots of g(rows, t) = 0 given g(lo) > 0 > g(hi) (vectorized; ``rows`` selects the
    problems still running). Stops where the bracket is shorter than ``tol`` or |g| <= ftol."""
    lo, hi, glo, ghi = lo.copy(), hi.copy(), glo.copy(), ghi.copy()
    ftol = np.broadcast_to(np.asarray(ftol, dtype=np.float64), lo.shape)
    out = 0.5 * (lo + hi)
    side = np.zeros(len(lo), dtype=np.int8)
    rows = np.arange(len(lo))
    for it in range(iters):
        if it == 0:
            rows = slice(None)  # first round on all rows, without gathers
        l, u, gl, gu = lo[rows], hi[rows], glo[rows], ghi[rows]
        t = (l * gu - u * gl) / (gu - gl)
        bad = ~((t > np.minimum(l, u)) & (t < np.maximum(l, u)))
        if it % 8 == 7:  # a bisection now and then bounds the worst case
            bad[:] = True
        t = np.where(bad, 0.5 * (l + u), t)
        gt = g(rows, t)
        pos = gt > 0
        s = side[rows]
        # Illinois: halve the kept end's value when the same end is kept twice in a row.
        glo[rows] = np.where(pos, gt, np.where(s == -1, 0.5 * gl, gl))
        lo[rows] = np.where(pos, t, l)
        ghi[rows] = np.where(pos, np.where(s == 1, 0.5 * gu, gu), gt)
        hi[rows] = np.where(pos, u, t)
        side[rows] = np.where(pos, 1, -1)
        out[rows] = t
        done = (np.abs(gt) <= ftol[rows]) | (np.abs(hi[rows] - lo[rows]) <= tol)
        rows = np.nonzero(~done)[0] if it == 0 else rows[~done]
        if len(rows) == 0:
            break
    out[rows] = 0.5 * (lo[rows] + hi[rows])
    return out


def _direction(field: BlobField, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit direction (minus the field's gradient) and the gradient's norm."""
    g = field.gradient(p)
    norm = np.linalg.norm(g, axis=1)
    return -g / np.where(norm > 0, norm, 1.0)[:, None], norm


def _root_on_path(field: BlobField, path: Callable[[np.ndarray, np.ndarray], np.ndarray],
                  g0: np.ndarray, slope: np.ndarray, h: float, tol: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Parameter t (arc length) of the nearest point with F = 1 on paths t -> path(rows, t)
    through the points at t = 0, where F - 1 = g0 and F falls at about ``slope`` per unit t.
    The first bracket is around the Newton estimate; where it holds no sign change, brackets
    [0, +-a] with a = h/4, h/2, h, 2h on the side the sign of g0 points to.
    Returns (t, found); t = 0 where no bracket was found."""
    m = len(g0)
    rows = slice(None)  # all rows, without a gather

    def g(r, t):
        return field.value(path(r, t)) - 1.0

    t0 = np.where(slope > 0, g0 / np.where(slope > 0, slope, 1.0), 0.0)
    d = 0.25 * np.abs(t0) + 4.0 * tol
    lo, hi = t0 - d, t0 + d
    glo, ghi = g(rows, lo), g(rows, hi)
    ok = (glo > 0) & (ghi < 0) & (np.abs(t0) < 2.0 * h)
    todo = np.nonzero(~ok)[0]
    for k in range(4):
        if len(todo) == 0:
            break
        a = 0.25 * h * 2.0 ** k
        end = np.where(g0[todo] > 0, a, -a)
        gend = g(todo, end)
        hit = (np.sign(gend) != np.sign(g0[todo])) | (g0[todo] == 0)
        sel, e, ge, gs = todo[hit], end[hit], gend[hit], g0[todo][hit]
        ins = gs > 0
        lo[sel] = np.where(ins, 0.0, e)
        hi[sel] = np.where(ins, e, 0.0)
        glo[sel] = np.where(ins, gs, ge)
        ghi[sel] = np.where(ins, ge, gs)
        ok[sel] = True
        todo = todo[~hit]
    t = np.zeros(m)
    if ok.all():
        t = _illinois(g, lo, hi, glo, ghi, tol, tol * slope)
    elif ok.any():
        sel = np.nonzero(ok)[0]
        t[sel] = _illinois(lambda i, tt: g(sel[i], tt), lo[sel], hi[sel], glo[sel], ghi[sel],
                           tol, tol * slope[sel])
    return t, ok


def _root_along(field: BlobField, p: np.ndarray, n: np.ndarray, slope: np.ndarray, h: float,
                tol: float) -> tuple[np.ndarray, np.ndarray]:
    """t with F(p + t n) = 1 nearest t = 0 along unit directions n (pointing out)."""
    return _root_on_path(field, lambda r, t: p[r] + t[:, None] * n[r], field.value(p) - 1.0,
                         slope, h, tol)


def _onto_surface(field: BlobField, p: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    n, slope = _direction(field, p)
    t, found = _root_along(field, p, n, slope, h, 1e-7 * h)
    return p + t[:, None] * n, found


# ------------------------------------------------------------------------------------------
# mesh helpers
# ------------------------------------------------------------------------------------------

def _edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges (E, 2) and, per face corner edge (F, 3), the edge index;
    corner k is the edge from vertex k to vertex k+1."""
    e = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.sort(e, axis=1)
    uniq, inv = np.unique(key[:, 0] * (faces.max() + 1 if len(faces) else 1) + key[:, 1],
                          return_inverse=True)
    edges = np.empty((len(uniq), 2), dtype=np.int64)
    edges[inv] = key
    return edges, inv.reshape(-1, 3)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product (np.cross has a large fixed cost)."""
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _face_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    return _cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])


def min_angles_deg(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Smallest interior angle of every triangle, in degrees."""
    p = v[f]
    out = np.full(len(f), 180.0)
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        cross = np.linalg.norm(_cross(a, b), axis=1)
        ang = np.degrees(np.arctan2(cross, np.einsum("ij,ij->i", a, b)))
        out = np.minimum(out, ang)
    return out


def _vertex_neighbours(edges: np.ndarray, nv: int):
    import scipy.sparse as sp
    ones = np.ones(len(edges))
    a = sp.coo_matrix((np.concatenate([ones, ones]),
                       (np.concatenate([edges[:, 0], edges[:, 1]]),
                        np.concatenate([edges[:, 1], edges[:, 0]]))), shape=(nv, nv)).tocsr()
    return a


def _relax(field: BlobField, v: np.ndarray, f: np.ndarray, h: float, rounds: int,
           movable: np.ndarray | None = None) -> np.ndarray:
    """Tangential Laplacian relaxation, each round followed by a projection onto the surface.
    A move is undone where it would flip an incident triangle or not find the surface."""
    edges, _ = _edges(f)
    adj = _vertex_neighbours(edges, len(v))
    deg = np.asarray(adj.sum(axis=1)).ravel()
    fn_ref = _face_normals(v, f)
    for _ in range(rounds):
        mean = (adj @ v) / deg[:, None]
        n, _ = _direction(field, v)
        d = mean - v
        d -= np.einsum("ij,ij->i", d, n)[:, None] * n
        cand = v + 0.5 * d
        cand, found = _onto_surface(field, cand, h)
        ok = found
        if movable is not None:
            ok &= movable
        new = np.where(ok[:, None], cand, v)
        # undo moves that flip a face (vertex-wise: any incident face flipped)
        fn = _face_normals(new, f)
        flipped = np.einsum("ij,ij->i", fn, fn_ref) <= 0
        if flipped.any():
            bad = np.zeros(len(v), dtype=bool)
            bad[f[flipped].ravel()] = True
            new[bad] = v[bad]
        v = new
    return v


# ------------------------------------------------------------------------------------------
# marching cubes in a narrow band
# ------------------------------------------------------------------------------------------

def _marching_cubes(field: BlobField, h: float, max_points: int) -> tuple[np.ndarray, np.ndarray, dict]:
    reach = math.sqrt(field.support_x()) * field.radius
    lo = field.centers.min(axis=0) - reach - 2 * h
    hi = field.centers.max(axis=0) + reach + 2 * h
    nblocks = np.ceil((hi - lo) / (BLOCK * h)).astype(np.int64)
    # Block-level culling: exact range of the field over each block.
    edges = [lo[k] + BLOCK * h * np.arange(nblocks[k] + 1) for k in range(3)]
    fmin, fmax = field.box_range([e[:-1] for e in edges], [e[1:] for e in edges])
    margin = 1e-5
    active = (fmin <= 1.0 + margin) & (fmax >= 1.0 - margin)
    inside = fmin > 1.0 + margin
    if not active.any():
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), {"grid": tuple(nblocks * BLOCK + 1)}
    # Crop to the active blocks (plus one block of margin for the all-outside padding).
    nz = np.nonzero(active)
    b0 = np.array([max(int(a.min()) - 1, 0) for a in nz])
    b1 = np.array([min(int(a.max()) + 2, int(n)) for a, n in zip(nz, nblocks)])
    active = active[b0[0]:b1[0], b0[1]:b1[1], b0[2]:b1[2]]
    inside = inside[b0[0]:b1[0], b0[1]:b1[1], b0[2]:b1[2]]
    shape = tuple(int(x) for x in (b1 - b0) * BLOCK + 1)
    if math.prod(shape) > max_points:
        raise _TooFine(math.prod(shape))
    origin = lo + b0 * BLOCK * h
    # Fine cells take their block's class; fine points of active blocks get exact values.
    cells = np.repeat(np.repeat(np.repeat(active, BLOCK, 0), BLOCK, 1), BLOCK, 2)
    cls = np.repeat(np.repeat(np.repeat(np.where(inside, 1.0, -1.0), BLOCK, 0), BLOCK, 1), BLOCK, 2)
    vol = np.empty(shape, dtype=np.float32)
    vol[:-1, :-1, :-1] = cls
    vol[-1, :, :] = -1.0
    vol[:, -1, :] = -1.0
    vol[:, :, -1] = -1.0
    pts = np.zeros(shape, dtype=bool)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                pts[dx:shape[0] - 1 + dx, dy:shape[1] - 1 + dy, dz:shape[2] - 1 + dz] |= cells
    idx = np.nonzero(pts)
    p = origin + h * np.stack(idx, axis=1)
    val = field.value(p) - 1.0
    # No grid value exactly on the level (marching cubes would then make zero-area triangles).
    eps = 1e-6
    val = np.where(np.abs(val) < eps, np.where(val < 0, -eps, eps), val)
    vol[idx] = val
    # scikit-image visits a cell when its mask is set at all eight corners: ``pts``.
    verts, faces, _, _ = marching_cubes(vol, 0.0, spacing=(h, h, h), mask=pts,
                                        allow_degenerate=False)
    faces = faces[:, ::-1].astype(np.int64)  # scikit-image's 'descent' faces inward: flip
    return verts + origin, faces, {"grid": shape, "band_points": int(len(p))}


class _TooFine(Exception):
    def __init__(self, points: int):
        super().__init__(points)
        self.points = points


# ------------------------------------------------------------------------------------------
# creases of the zone field
# ------------------------------------------------------------------------------------------

def _crease_points(field: BlobField, a: np.ndarray, b: np.ndarray, c: np.ndarray, r: float,
                   h: float) -> tuple[np.ndarray, np.ndarray]:
    """Points where the crease curve (surface meets the sphere |p - c| = r) crosses edges a-b
    whose ends lie on opposite sides of that sphere: first where the straight edge crosses
    the sphere, then along the sphere's great circle in the direction of the field's
    tangential gradient onto the surface. Returns (points, found)."""
    u, w = a - c, b - a
    qa = np.einsum("ij,ij->i", w, w)
    qb = 2.0 * np.einsum("ij,ij->i", u, w)
    qc = np.einsum("ij,ij->i", u, u) - r * r
    disc = np.sqrt(np.maximum(qb * qb - 4 * qa * qc, 0.0))
    s1 = (-qb - disc) / (2 * qa)
    s2 = (-qb + disc) / (2 * qa)
    s = np.where((s1 >= 0) & (s1 <= 1), s1, s2)
    q = a + np.clip(s, 0, 1)[:, None] * w
    return _crease_points_from(field, q, c, r, h)


def _crease_points_from(field: BlobField, q: np.ndarray, c: np.ndarray, r: np.ndarray | float,
                        h: float) -> tuple[np.ndarray, np.ndarray]:
    """From points q on spheres |p - c| = r (c (3,) or (M, 3), r scalar or (M,)), the nearest
    point of the crease curve where the surface meets the sphere, along the great circle
    through q in the direction of the field's tangential gradient. Returns (points, found)."""
    c = np.broadcast_to(c, q.shape)
    r = np.broadcast_to(np.asarray(r, dtype=np.float64), (len(q),))
    e1 = q - c
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    g = -field.gradient(q)
    g -= np.einsum("ij,ij->i", g, e1)[:, None] * e1
    gn = np.linalg.norm(g, axis=1)
    e2 = g / np.where(gn > 0, gn, 1.0)[:, None]

    def on_circle(rows, arc):
        theta = arc / r[rows]
        return c[rows] + r[rows, None] * (np.cos(theta)[:, None] * e1[rows]
                                          + np.sin(theta)[:, None] * e2[rows])

    arc, found = _root_on_path(field, on_circle, field.value(q) - 1.0, gn, h, 1e-12 * h)
    return on_circle(np.arange(len(q)), arc), found & (gn > 0)


def _split_faces(v: np.ndarray, f: np.ndarray, cls: np.ndarray, edge_of: np.ndarray,
                 cut_vertex: np.ndarray) -> np.ndarray:
    """Split faces along a level set: ``cls`` is -1/0/+1 per vertex, ``edge_of`` (F, 3) the
    edge index of each corner edge, ``cut_vertex`` the new vertex of each cut edge (or -1)."""
    c = cls[f]
    nzero = (c == 0).sum(axis=1)
    c0, c1, c2 = c[:, 0], c[:, 1], c[:, 2]
    mixed = (np.minimum(np.minimum(c0, c1), c2) < 0) & (np.maximum(np.maximum(c0, c1), c2) > 0)
    a_case = mixed & (nzero == 0)
    b_case = mixed & (nzero == 1)
    keep = f[~(a_case | b_case)]
    out = [keep]
    rows = np.arange(len(f))
    if a_case.any():
        fa, ca, ea = f[a_case], c[a_case], edge_of[a_case]
        # odd corner: the one whose sign differs from the other two
        odd = np.where(ca[:, 1] == ca[:, 2], 0, np.where(ca[:, 0] == ca[:, 2], 1, 2))
        r = rows[:len(fa)]
        o = fa[r, odd]
        p = fa[r, (odd + 1) % 3]
        q = fa[r, (odd + 2) % 3]
        m_op = cut_vertex[ea[r, odd]]
        m_oq = cut_vertex[ea[r, (odd + 2) % 3]]
        out.append(np.stack([o, m_op, m_oq], axis=1))
        t1 = np.stack([m_op, p, q], axis=1)
        t2 = np.stack([m_op, q, m_oq], axis=1)
        u1 = np.stack([m_op, p, m_oq], axis=1)
        u2 = np.stack([p, q, m_oq], axis=1)
        first = np.minimum(min_angles_deg(v, t1), min_angles_deg(v, t2)) >= \
            np.minimum(min_angles_deg(v, u1), min_angles_deg(v, u2))
        out += [np.where(first[:, None], t1, u1), np.where(first[:, None], t2, u2)]
    if b_case.any():
        fb, cb, eb = f[b_case], c[b_case], edge_of[b_case]
        z = np.argmax(cb == 0, axis=1)
        r = rows[:len(fb)]
        o = fb[r, z]
        p = fb[r, (z + 1) % 3]
        q = fb[r, (z + 2) % 3]
        m = cut_vertex[eb[r, (z + 1) % 3]]
        out += [np.stack([o, p, m], axis=1), np.stack([o, m, q], axis=1)]
    return np.concatenate(out)


def _cut_creases(field: BlobField, v: np.ndarray, f: np.ndarray, h: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Cut the mesh along every zone sphere of every source (tutorial field only), so that
    each triangle lies within one zone of every source. Returns vertices, faces, a flag per
    vertex for the vertices that are new or moved, and the number of crease points not
    found (surface tangent to a zone sphere)."""
    lost = 0
    nv = len(v)
    moved = []
    # Vertices on a crease are never snapped onto another one (that would pull them off
    # the first: the cuts would chase each other).
    locked = np.zeros(len(v), dtype=bool)
    for i in range(len(field.centers)):
        k = 10.0 / np.maximum(field.sqdist(v, i), 1e-30)
        j = np.rint(k)
        locked |= (np.abs(k - j) <= 1e-9 * j) & (j >= 1) & (j <= 9)
    # A crease point found for one source can fall in another zone of an earlier source
    # (near crossings of creases): repeat until no face crosses a zone boundary.
    for _ in range(6):
        changed = False
        for i, c in enumerate(field.centers):
            q = zone_index(field.sqdist(v, i))
            q0, q1, q2 = q[f[:, 0]], q[f[:, 1]], q[f[:, 2]]
            work = (q0 != q1) | (q1 != q2)
            if not work.any():
                continue
            # zone boundary x = 10/(j+1) lies between zone indices j and j+1
            qlo = np.minimum(np.minimum(q0, q1), q2)[work]
            qhi = np.maximum(np.maximum(q0, q1), q2)[work]
            levels = [j for j in range(int(qlo.min()), int(qhi.max()))
                      if ((qlo <= j) & (qhi > j)).any()]
            rest, fw = f[~work], f[work]
            nf = len(fw)
            for j in levels:
                n0 = len(v)
                v, fw, mv, n_lost = _cut_level(field, v, fw, rest, c,
                                               field.radius * math.sqrt(10.0 / (j + 1)), h,
                                               locked)
                lost += n_lost
                moved.append(mv)
                locked = np.concatenate([locked, np.ones(len(v) - n0, dtype=bool)])
                locked[mv] = True
            changed |= len(fw) != nf
            f = np.concatenate([rest, fw])
        if not changed:
            break
    dirty = np.zeros(len(v), dtype=bool)
    dirty[nv:] = True
    for mv in moved:
        dirty[mv] = True
    return v, f, dirty, lost


def _cut_level(field: BlobField, v: np.ndarray, f: np.ndarray, rest: np.ndarray, c: np.ndarray,
               r: float, h: float, locked: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Cut faces f along the sphere |p - c| = r (``rest``: the other faces, which do not
    cross it, checked only for flips when a vertex is snapped onto the crease; ``locked``:
    vertices that must not be snapped). Returns
    vertices, faces, the vertices snapped onto the crease and the crease points not found."""
    r2 = r * r
    d0, d1, d2 = v[:, 0] - c[0], v[:, 1] - c[1], v[:, 2] - c[2]
    phi = d0 * d0 + d1 * d1 + d2 * d2 - r2
    cls = np.sign(phi).astype(np.int8)
    cls[np.abs(phi) <= 1e-9 * r2] = 0
    c0, c1, c2 = cls[f[:, 0]], cls[f[:, 1]], cls[f[:, 2]]
    straddle = (np.minimum(np.minimum(c0, c1), c2) < 0) & (np.maximum(np.maximum(c0, c1), c2) > 0)
    moved = np.zeros(0, dtype=np.int64)
    if not straddle.any():
        return v, f, moved, 0
    fs = f[straddle]
    edges, edge_of = _edges(fs)
    cut = (cls[edges[:, 0]] * cls[edges[:, 1]]) < 0
    ce = edges[cut]
    pts, found = _crease_points(field, v[ce[:, 0]], v[ce[:, 1]], c, r, h)
    lost = int((~found).sum())
    if lost:  # surface tangent to the sphere there: no crease to follow
        pts[~found] = _onto_surface(field, pts[~found], h)[0]
    # Snap: a crease point close to an edge end moves that vertex instead.
    w = v[ce[:, 1]] - v[ce[:, 0]]
    s = np.einsum("ij,ij->i", pts - v[ce[:, 0]], w) / np.einsum("ij,ij->i", w, w)
    near_a = found & (s < SNAP) & ~locked[ce[:, 0]]
    near_b = found & (s > 1.0 - SNAP) & ~locked[ce[:, 1]]
    cand_v = np.concatenate([ce[near_a, 0], ce[near_b, 1]])
    if len(cand_v):
        cand_p = np.concatenate([pts[near_a], pts[near_b]])
        dist = np.linalg.norm(cand_p - v[cand_v], axis=1)
        order = np.lexsort((dist, cand_v))
        cand_v, cand_p = cand_v[order], cand_p[order]
        first = np.ones(len(cand_v), dtype=bool)
        first[1:] = cand_v[1:] != cand_v[:-1]
        mv, mp = cand_v[first], cand_p[first]
        vmask = np.zeros(len(v), dtype=bool)
        vmask[mv] = True
        fi = np.concatenate([f, rest])
        fi = fi[vmask[fi[:, 0]] | vmask[fi[:, 1]] | vmask[fi[:, 2]]]
        before = _face_normals(v, fi)
        v_new = v.copy()
        v_new[mv] = mp
        flipped = np.einsum("ij,ij->i", before, _face_normals(v_new, fi)) <= 0
        bad = np.zeros(len(v), dtype=bool)
        bad[fi[flipped].ravel()] = True
        ok = ~bad[mv]
        v = v.copy()
        v[mv[ok]] = mp[ok]
        cls[mv[ok]] = 0
        moved = mv[ok]
        still = (cls[ce[:, 0]] * cls[ce[:, 1]]) < 0
        cut[np.nonzero(cut)[0][~still]] = False
        pts = pts[still]
    cut_vertex = np.full(len(edges), -1, dtype=np.int64)
    cut_vertex[cut] = len(v) + np.arange(int(cut.sum()))
    v = np.concatenate([v, pts])
    cls = np.concatenate([cls, np.zeros(len(pts), dtype=np.int8)])
    return v, np.concatenate([f[~straddle], _split_faces(v, fs, cls, edge_of, cut_vertex)]), moved, lost


# ------------------------------------------------------------------------------------------
# error measurement
# ------------------------------------------------------------------------------------------

def triangle_samples(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sample points of every triangle where its deviation from a curved surface peaks:
    centroid, circumcentre (if inside; else the midpoint of the longest edge) and the three
    edge midpoints. Returns points (S, 3) and the face of each sample (S,)."""
    A, B, C = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    a2 = np.einsum("ij,ij->i", B - C, B - C)
    b2 = np.einsum("ij,ij->i", C - A, C - A)
    c2 = np.einsum("ij,ij->i", A - B, A - B)
    w = np.stack([a2 * (b2 + c2 - a2), b2 * (c2 + a2 - b2), c2 * (a2 + b2 - c2)], axis=1)
    acute = (w > 0).all(axis=1)
    ws = w.sum(axis=1, keepdims=True)
    circ = (w[:, :1] * A + w[:, 1:2] * B + w[:, 2:] * C) / np.where(ws > 0, ws, 1.0)
    longest = np.argmax(np.stack([a2, b2, c2], axis=1), axis=1)
    mids = np.stack([(B + C) / 2, (C + A) / 2, (A + B) / 2], axis=1)
    circ = np.where(acute[:, None], circ, mids[np.arange(len(f)), longest])
    pts = np.concatenate([(A + B + C) / 3, circ, mids.reshape(-1, 3)])
    face = np.concatenate([np.arange(len(f))] * 2 + [np.repeat(np.arange(len(f)), 3)])
    return pts, face


def measure_error(field: BlobField, v: np.ndarray, f: np.ndarray, h: float) -> tuple[float, np.ndarray]:
    """Largest sampled distance from the triangles to the surface, and per face.

    Each sample's distance is the distance to the surface point found along the gradient
    line through it, an upper bound of its true distance to the surface. A sample with no
    surface point within 2 h along that line counts as 2 h."""
    if len(f) == 0:
        return 0.0, np.zeros(0)
    pts, face = triangle_samples(v, f)
    return _sample_error(field, pts, face, len(f), h)


def _sample_error(field: BlobField, pts: np.ndarray, face: np.ndarray, nf: int, h: float
                  ) -> tuple[float, np.ndarray]:
    n, slope = _direction(field, pts)
    tol = 1e-4 * h
    t, found = _root_along(field, pts, n, slope, h, tol)
    dist = np.where(found, np.abs(t) + tol, 2.0 * h)
    per_face = np.zeros(nf)
    np.maximum.at(per_face, face, dist)
    return float(per_face.max()), per_face


# ------------------------------------------------------------------------------------------
# the builder
# ------------------------------------------------------------------------------------------

def tessellate(field: BlobField, h: float, max_points: int = 60_000_000) -> tuple[np.ndarray, np.ndarray, dict]:
    """One pass at cell size h: vertices on the surface, faces, and an info dict."""
    timings = {}
    t0 = time.perf_counter()
    v, f, info = _marching_cubes(field, h, max_points)
    timings["marching_cubes"] = time.perf_counter() - t0
    if len(f) == 0:
        info.update(timings=timings, unprojected=0, creases_lost=0)
        return v, f, info
    t0 = time.perf_counter()
    v, found = _onto_surface(field, v, h)
    info["unprojected"] = int((~found).sum())
    timings["project"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    v = _relax(field, v, f, h, RELAX_ROUNDS)
    timings["relax"] = time.perf_counter() - t0
    info["creases_lost"] = 0
    if field.kind == "tutorial":
        t0 = time.perf_counter()
        v, f, _, info["creases_lost"] = _cut_creases(field, v, f, h)
        timings["creases"] = time.perf_counter() - t0
    info["timings"] = timings
    return v, f, info


# ------------------------------------------------------------------------------------------
# local refinement: longest-edge bisection
# ------------------------------------------------------------------------------------------

def _crease_of_edges(field: BlobField, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For edges a-b: the source and zone-boundary radius of a crease both ends lie on
    (source -1 if none)."""
    src = np.full(len(a), -1, dtype=np.intp)
    rad = np.zeros(len(a))
    if field.kind != "tutorial":
        return src, rad
    for i in range(len(field.centers)):
        ra = 10.0 / np.maximum(field.sqdist(a, i), 1e-30)
        rb = 10.0 / np.maximum(field.sqdist(b, i), 1e-30)
        k = np.rint(ra)
        on = (np.abs(ra - k) <= 1e-7 * k) & (np.abs(rb - k) <= 1e-7 * k) & (k >= 1) & (k <= 9) \
            & (src < 0)
        src[on] = i
        rad[on] = field.radius * np.sqrt(10.0 / k[on])
    return src, rad


def _midpoints_on_surface(field: BlobField, a: np.ndarray, b: np.ndarray, h: float) -> np.ndarray:
    """Midpoints of edges a-b moved onto the surface: along the gradient, or for an edge on
    a crease, onto the crease curve (radially onto the zone sphere, then along it)."""
    mid = 0.5 * (a + b)
    out, _ = _onto_surface(field, mid, h)
    src, rad = _crease_of_edges(field, a, b)
    sel = np.nonzero(src >= 0)[0]
    if len(sel):
        c = field.centers[src[sel]]
        u = mid[sel] - c
        q = c + rad[sel, None] * u / np.linalg.norm(u, axis=1, keepdims=True)
        pts, found = _crease_points_from(field, q, c, rad[sel], h)
        out[sel[found]] = pts[found]
    return out


def refine(field: BlobField, v: np.ndarray, f: np.ndarray, bad: np.ndarray, h: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split the faces flagged ``bad`` by longest-edge bisection, conformingly (faces next
    to a split edge are split too, always through their own longest edge, which keeps the
    smallest angle above half of what it was). Returns vertices, faces (the kept old faces
    first, in order, then the new ones) and the flag of the old faces that were kept."""
    edges, edge_of = _edges(f)
    ev = v[edges[:, 1]] - v[edges[:, 0]]
    length = np.einsum("ij,ij->i", ev, ev)
    corner_len = length[edge_of]
    lc = np.argmax(corner_len, axis=1)
    rows = np.arange(len(f))
    longest = edge_of[rows, lc]
    marked = np.zeros(len(edges), dtype=bool)
    marked[longest[bad]] = True
    while True:
        touched = marked[edge_of[:, 0]] | marked[edge_of[:, 1]] | marked[edge_of[:, 2]]
        add = touched & ~marked[longest]
        if not add.any():
            break
        marked[longest[add]] = True
    new_idx = np.full(len(edges), -1, dtype=np.int64)
    me = np.nonzero(marked)[0]
    new_idx[me] = len(v) + np.arange(len(me))
    mids = _midpoints_on_surface(field, v[edges[me, 0]], v[edges[me, 1]], h)
    v = np.concatenate([v, mids])
    touched = marked[edge_of[:, 0]] | marked[edge_of[:, 1]] | marked[edge_of[:, 2]]
    ft, et, lt = f[touched], edge_of[touched], lc[touched]
    r = np.arange(len(ft))
    v0, v1, v2 = ft[r, lt], ft[r, (lt + 1) % 3], ft[r, (lt + 2) % 3]
    m01 = new_idx[et[r, lt]]
    m12 = new_idx[et[r, (lt + 1) % 3]]
    m20 = new_idx[et[r, (lt + 2) % 3]]
    has12, has20 = m12 >= 0, m20 >= 0
    out = []
    # half (v0, m01, v2), split at m20 if marked
    out.append(np.stack([v0, m01, v2], axis=1)[~has20])
    out.append(np.stack([v0, m01, m20], axis=1)[has20])
    out.append(np.stack([m01, v2, m20], axis=1)[has20])
    # half (m01, v1, v2), split at m12 if marked
    out.append(np.stack([m01, v1, v2], axis=1)[~has12])
    out.append(np.stack([m01, v1, m12], axis=1)[has12])
    out.append(np.stack([m01, m12, v2], axis=1)[has12])
    new_faces = np.concatenate(out)
    return v, np.concatenate([f[~touched], new_faces]), ~touched


# ------------------------------------------------------------------------------------------
# the builder
# ------------------------------------------------------------------------------------------

#: Measured constant of the largest deviation of this tessellation from a sphere of radius
#: rho: error ~ C h^2 / rho (marching cubes + relaxation; see initial_cell_size).
SPHERE_ERROR_C = 0.12


def initial_cell_size(radius: float, max_error: float) -> float:
    """Cell size whose tessellation of a sphere of radius R has about max_error."""
    return min(math.sqrt(max_error * radius / SPHERE_ERROR_C), 0.5 * radius)


def build_blob_mesh(centers, radius: float, field: str = "tutorial", max_error: float | None = None,
                    *, normals: str = "exact", cell_size: float | None = None,
                    max_passes: int = 8, max_points: int = 60_000_000,
                    log: Callable[[str], None] | None = None) -> BlobMesh:
    """Triangle mesh of the metaball surface ``sum_i f(|p - c_i|^2 / R^2) = 1``.

    ``centers`` (N, 3), ``radius`` R > 0, ``field`` 'tutorial' or 'exact'. Give ``max_error``
    (world units, > 0): the mesh is refined until the measured distance from its triangles to
    the surface is below it. Or give ``cell_size`` alone for one unrefined pass (``max_error``
    then only bounds nothing and the achieved error is still measured). ``normals``:
    'exact' (gradient of sum R^2/d^2, the tutorial's shading), 'field' (gradient of the chosen
    field; mean of both sides on the zone field's creases) or 'flat' (no vertex normals).
    Raises :class:`BlobMeshError` naming the bad parameter."""
    centers, radius, max_error = _validate(centers, radius, field, max_error, normals, cell_size)
    fld = BlobField(centers, radius, field)
    h = cell_size if cell_size is not None else initial_cell_size(radius, max_error)
    t_start = time.perf_counter()
    v, f, info = tessellate(fld, h, max_points)
    err, per_face = measure_error(fld, v, f, h)
    passes = 0
    target = max_error if cell_size is None else math.inf
    while err > target and passes < max_passes:
        passes += 1
        v, f, kept = refine(fld, v, f, per_face > target, h)
        per_face = np.concatenate([per_face[kept], np.full(len(f) - int(kept.sum()), np.nan)])
        if fld.kind == "tutorial":
            # midpoints moved onto the surface can cross a crease: cut again
            before, errors = _face_keys(f), per_face
            v, f, dirty, lost = _cut_creases(fld, v, f, h)
            info["creases_lost"] += lost
            per_face = _lookup(_face_keys(f), before, errors)
            per_face[dirty[f[:, 0]] | dirty[f[:, 1]] | dirty[f[:, 2]]] = np.nan
        todo = np.isnan(per_face)
        per_face[todo] = measure_error(fld, v, f[todo], h)[1]
        err = float(per_face.max())
        if log is not None:
            log(f"blob: refinement pass {passes}: {len(f)} triangles, error {err:.4g}")
    v, f = _compact(v, f)
    nrm = _vertex_normals(fld, v, normals)
    info.update(cell_size=h, refine_passes=passes, triangles=len(f), vertices=len(v),
                min_angle_deg=float(min_angles_deg(v, f).min()) if len(f) else 180.0,
                seconds=time.perf_counter() - t_start)
    return BlobMesh(v, f, nrm, err, info)


def _face_keys(f: np.ndarray) -> np.ndarray:
    """A key per face, the same for the same three vertices in any order."""
    s = np.sort(f, axis=1).astype(np.int64)
    n = int(f.max()) + 1 if len(f) else 1
    return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]


def _lookup(keys: np.ndarray, known: np.ndarray, values: np.ndarray) -> np.ndarray:
    """values of the faces with ``keys`` among ``known`` keys; NaN for the unknown."""
    order = np.argsort(known)
    pos = np.clip(np.searchsorted(known[order], keys), 0, max(len(known) - 1, 0))
    out = np.full(len(keys), np.nan)
    if len(known):
        hit = known[order][pos] == keys
        out[hit] = values[order][pos[hit]]
    return out


def _compact(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop vertices no face uses."""
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    if used.all():
        return v, f
    remap = np.cumsum(used) - 1
    return v[used], remap[f]


def _vertex_normals(field: BlobField, v: np.ndarray, normals: str) -> np.ndarray:
    if normals == "flat" or len(v) == 0:
        return np.zeros((0, 3))
    if normals == "exact":
        g = field.inverse_square_gradient(v)
    else:
        g = -field.gradient(v, mean_at_bounds=True)
    return g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300)


def _validate(centers, radius, field, max_error, normals, cell_size):
    try:
        c = np.asarray(centers, dtype=np.float64)
    except (TypeError, ValueError):
        raise BlobMeshError("'centers' must be an (N, 3) array of numbers") from None
    if c.size == 0:
        raise BlobMeshError("no source centre given (center0, center1, ...)")
    if c.ndim != 2 or c.shape[1] != 3:
        raise BlobMeshError(f"'centers' must have shape (N, 3), got {c.shape}")
    bad = np.nonzero(~np.isfinite(c).all(axis=1))[0]
    if len(bad):
        raise BlobMeshError(f"'center{bad[0]}' must be finite, got {c[bad[0]].tolist()}")
    try:
        radius = float(radius)
    except (TypeError, ValueError):
        raise BlobMeshError(f"'radius' must be a number, got {radius!r}") from None
    if not (math.isfinite(radius) and radius > 0):
        raise BlobMeshError(f"'radius' must be finite and > 0, got {radius}")
    if field not in FIELDS:
        raise BlobMeshError(f"'field' must be one of {', '.join(FIELDS)}, got {field!r}")
    if normals not in NORMALS:
        raise BlobMeshError(f"'normals' must be one of {', '.join(NORMALS)}, got {normals!r}")
    if max_error is None and cell_size is None:
        raise BlobMeshError("'max_error' is required (world units, > 0)")
    if max_error is not None:
        max_error = float(max_error)
        if not (math.isfinite(max_error) and max_error > 0):
            raise BlobMeshError(f"'max_error' must be finite and > 0, got {max_error}")
    if cell_size is not None and not (math.isfinite(cell_size) and cell_size > 0):
        raise BlobMeshError(f"'cell_size' must be finite and > 0, got {cell_size}")
    return c, radius, max_error
