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
KEEP = 0.1           # ... or, if that vertex is on another crease, closer than KEEP: no cut
MIN_ANGLE_DEG = 2.0  # needles with a smaller angle get their short edge collapsed
TUTORIAL_MARGIN = 0.95
MAX_GRID_POINTS = 2 ** 24  # marching-cubes grid cap (about 250 MB of work arrays)


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
    # already on the surface (e.g. in a crease, where F - 1 may not change sign nearby)
    on = ~ok & (np.abs(g0) <= tol * slope)
    lo[on], hi[on], glo[on], ghi[on] = 0.0, 0.0, 0.0, 0.0
    todo = np.nonzero(~ok & ~on)[0]
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
    ok_all = ok | on
    ok &= ~on
    if ok.all():
        t = _illinois(g, lo, hi, glo, ghi, tol, tol * slope)
    elif ok.any():
        sel = np.nonzero(ok)[0]
        t[sel] = _illinois(lambda i, tt: g(sel[i], tt), lo[sel], hi[sel], glo[sel], ghi[sel],
                           tol, tol * slope[sel])
    return t, ok_all


def _root_along(field: BlobField, p: np.ndarray, n: np.ndarray, slope: np.ndarray, h: float,
                tol: float) -> tuple[np.ndarray, np.ndarray]:
    """t with F(p + t n) = 1 nearest t = 0 along unit directions n (pointing out)."""
    return _root_on_path(field, lambda r, t: p[r] + t[:, None] * n[r], field.value(p) - 1.0,
                         slope, h, tol)


def _along_normals(field: BlobField, p: np.ndarray, h: float, tol: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Root along the field's gradient line through each point; where none is found (near
    a concave crease of the zone field the line can miss the surface), along the smooth
    gradient of sum R^2/d^2 instead. Returns (t, directions, found)."""
    n, slope = _direction(field, p)
    t, found = _root_along(field, p, n, slope, h, tol)
    if not found.all():
        sel = np.nonzero(~found)[0]
        g = field.inverse_square_gradient(p[sel])
        n2 = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300)
        slope2 = np.abs(np.einsum("ij,ij->i", field.gradient(p[sel]), n2))
        t2, found2 = _root_along(field, p[sel], n2, slope2, h, tol)
        n[sel[found2]] = n2[found2]
        t[sel[found2]] = t2[found2]
        found[sel[found2]] = True
    return t, n, found


def _onto_surface(field: BlobField, p: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    t, n, found = _along_normals(field, p, h, 1e-7 * h)
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


def _on_crease(field: BlobField, v: np.ndarray, rel: float = 1e-9) -> np.ndarray:
    """Vertices on a zone sphere of some source (tutorial field), i.e. on a crease."""
    out = np.zeros(len(v), dtype=bool)
    if field.kind != "tutorial":
        return out
    for i in range(len(field.centers)):
        k = 10.0 / np.maximum(field.sqdist(v, i), 1e-30)
        j = np.rint(k)
        out |= (np.abs(k - j) <= rel * j) & (j >= 1) & (j <= 9)
    return out


def _clean_slivers(field: BlobField, v: np.ndarray, f: np.ndarray, min_angle: float, h: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """Remove slivers (a triangle with an angle below ``min_angle`` degrees):

    * needles (one short edge): the short edge is collapsed into one end, the end on a
      crease if one is; two crease vertices only if on one crease or closer than h/20;
    * caps (one angle near 180 degrees): the longest edge is flipped.

    An operation is done only if it keeps the mesh manifold (link condition, no duplicate
    edge), keeps every changed triangle facing out (against the field's gradient) and raises
    the smallest angle among the triangles it changes. Returns vertices, faces, a flag per
    input face for those kept (in order), a flag per output face for those changed (to
    measure again) and the number of operations."""
    done = 0
    locked = _on_crease(field, v)
    changed = np.zeros(len(f), dtype=bool)
    kept = np.arange(len(f))
    for _ in range(6):
        ang = min_angles_deg(v, f)
        bad = np.nonzero(ang < min_angle)[0]
        if not len(bad):
            break
        inc = np.argsort(f.ravel(), kind="stable")               # vertex -> faces
        vstart = np.searchsorted(f.ravel()[inc], np.arange(len(v) + 1))
        new_f = f.copy()
        alive = np.ones(len(f), dtype=bool)
        busy = np.zeros(len(v), dtype=bool)
        n_round = 0

        def outward_ok(tri: np.ndarray) -> bool:
            if not len(tri):
                return True
            n = _face_normals(v, tri)
            g = field.inverse_square_gradient(v[tri].mean(axis=1))  # points out
            return bool((np.einsum("ij,ij->i", n, g) > 0).all())

        for t in bad[np.argsort(ang[bad])]:
            if not alive[t] or busy[new_f[t]].any():
                continue
            tri = new_f[t]
            P = v[tri]
            length = np.linalg.norm(P[[1, 2, 0]] - P, axis=1)  # edge k: corner k -> k+1
            k_short, k_long = int(np.argmin(length)), int(np.argmax(length))
            if length[k_short] < 0.25 * length[k_long] and _collapse(
                    field, v, new_f, alive, busy, changed, locked, inc, vstart, outward_ok, h,
                    int(tri[k_short]), int(tri[(k_short + 1) % 3])):
                pass                                              # needle: collapsed
            elif not _flip(v, new_f, changed, busy, outward_ok, inc, vstart, alive, ang, t,
                           k_long):
                continue                                          # cap: flipped, or nothing
            n_round += 1
        if n_round == 0:
            break
        f, changed, kept = new_f[alive], changed[alive], kept[alive]
        done += n_round
    return v, f, kept, changed, done


def _same_crease(field: BlobField, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether points a and b lie on one zone sphere of one source."""
    for i in range(len(field.centers)):
        ka = 10.0 / max(float(field.sqdist(a[None], i)[0]), 1e-30)
        kb = 10.0 / max(float(field.sqdist(b[None], i)[0]), 1e-30)
        j = round(ka)
        if 1 <= j <= 9 and abs(ka - j) <= 1e-9 * j and abs(kb - j) <= 1e-9 * j:
            return True
    return False


def _collapse(field, v, f, alive, busy, changed, locked, inc, vstart, outward_ok, h, a, b) -> bool:
    """Collapse edge a-b (see _clean_slivers); False where it is not allowed."""
    if locked[a] and locked[b] and np.linalg.norm(v[a] - v[b]) > 0.05 * h \
            and not _same_crease(field, v[a], v[b]):
        return False
    if locked[a]:
        a, b = b, a                                               # remove a, keep b
    fa = inc[vstart[a]:vstart[a + 1]] // 3
    fb = inc[vstart[b]:vstart[b + 1]] // 3
    fa, fb = fa[alive[fa]], fb[alive[fb]]
    shared = np.intersect1d(fa, fb)
    if len(shared) != 2:
        return False
    na = set(f[fa].ravel().tolist()) - {a}
    nb = set(f[fb].ravel().tolist()) - {b}
    if (na & nb) != set(f[shared].ravel().tolist()) - {a, b}:
        return False                                              # link condition
    moved = np.setdiff1d(fa, shared)
    if not len(moved):
        return False
    cand = f[moved].copy()
    cand[cand == a] = b
    before = min_angles_deg(v, f[np.union1d(fa, fb)]).min()
    if not outward_ok(cand) or min_angles_deg(v, cand).min() <= before:
        return False
    f[moved] = cand
    alive[shared] = False
    changed[moved] = True
    busy[list(na | nb | {a, b})] = True
    return True


def _flip(v, f, changed, busy, outward_ok, inc, vstart, alive, ang, t, k_long) -> bool:
    """Flip the longest edge of face t (see _clean_slivers); False where not allowed."""
    tri = f[t]
    a, b, c = int(tri[k_long]), int(tri[(k_long + 1) % 3]), int(tri[(k_long + 2) % 3])

    def faces_of(x):
        fx = inc[vstart[x]:vstart[x + 1]] // 3
        return fx[alive[fx]]

    pair = np.setdiff1d(np.intersect1d(faces_of(a), faces_of(b)), [t])
    if len(pair) != 1:
        return False
    u = int(pair[0])
    if busy[f[u]].any():
        return False
    d = [int(x) for x in f[u] if x != a and x != b]
    if len(d) != 1:
        return False
    d = d[0]
    if (f[faces_of(c)] == d).any():
        return False                                              # edge c-d exists already
    cand = np.array([[c, a, d], [c, d, b]])
    before = min(ang[t], min_angles_deg(v, f[[u]]).min())
    if not outward_ok(cand) or min_angles_deg(v, cand).min() <= before:
        return False
    f[t], f[u] = cand[0], cand[1]
    changed[[t, u]] = True
    busy[[a, b, c, d]] = True
    return True


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

def _marching_cubes(field: BlobField, h: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """Marching cubes on the band of 4x4x4-cell blocks where the surface can be."""
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
    origin = lo + b0 * BLOCK * h
    # Fine cells take their block's class; fine points of active blocks get exact values.
    cells = np.repeat(np.repeat(np.repeat(active, BLOCK, 0), BLOCK, 1), BLOCK, 2)
    cls = np.repeat(np.repeat(np.repeat(np.where(inside, np.float32(1), np.float32(-1)),
                                        BLOCK, 0), BLOCK, 1), BLOCK, 2)
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


def _cut_creases(field: BlobField, v: np.ndarray, f: np.ndarray, h: float,
                 fresh: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Cut the mesh along every zone sphere of every source (tutorial field only), so that
    each triangle lies within one zone of every source. Returns vertices, faces and the
    number of crease points not found (surface tangent to a zone sphere). Only faces with a
    ``fresh`` vertex (default: all) are looked at."""
    lost = 0
    fresh = np.ones(len(v), dtype=bool) if fresh is None else fresh.copy()
    # Vertices on a crease are never snapped onto another one (that would pull them off
    # the first: the cuts would chase each other).
    locked = _on_crease(field, v)
    # A crease point found for one source can fall in another zone of an earlier source
    # (near crossings of creases): repeat until no face crosses a zone boundary.
    for _ in range(6):
        changed = False
        n_round = len(v)
        moved_round = []
        for i, c in enumerate(field.centers):
            q = zone_index(field.sqdist(v, i))
            q0, q1, q2 = q[f[:, 0]], q[f[:, 1]], q[f[:, 2]]
            work = ((q0 != q1) | (q1 != q2)) & (fresh[f[:, 0]] | fresh[f[:, 1]] | fresh[f[:, 2]])
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
                moved_round.append(mv)
                locked = np.concatenate([locked, np.ones(len(v) - n0, dtype=bool)])
                fresh = np.concatenate([fresh, np.ones(len(v) - n0, dtype=bool)])
                locked[mv] = True
            changed |= len(fw) != nf
            f = np.concatenate([rest, fw])
        if not changed:
            break
        # next round: only faces touched by this round's new or moved vertices
        fresh = np.zeros(len(v), dtype=bool)
        fresh[n_round:] = True
        for mv in moved_round:
            fresh[mv] = True
    return v, f, lost


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
    near_a = found & (s < SNAP)
    near_b = found & (s > 1.0 - SNAP)
    # A locked end (on another crease) close to this crease is taken as on it: cutting
    # there would make a sliver. The triangles then cross this crease by a little, which
    # the error measurement sees and refinement reduces.
    keep = np.concatenate([ce[found & (s < KEEP) & locked[ce[:, 0]], 0],
                           ce[found & (s > 1.0 - KEEP) & locked[ce[:, 1]], 1]])
    if len(keep):
        cls[keep] = 0
        still = (cls[ce[:, 0]] * cls[ce[:, 1]]) < 0
        cut[np.nonzero(cut)[0][~still]] = False
        ce, pts, found, s = ce[still], pts[still], found[still], s[still]
        near_a, near_b = near_a[still], near_b[still]
    near_a &= ~locked[ce[:, 0]]
    near_b &= ~locked[ce[:, 1]]
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

def measure_error(field: BlobField, v: np.ndarray, f: np.ndarray, h: float) -> tuple[float, np.ndarray]:
    """Largest sampled distance from the triangles to the surface, and per face.

    Each sample's distance is that to the surface point found along the gradient line
    through it: an upper bound of its distance to the surface. Samples per triangle:

    * the three edge midpoints. The signed deviation of a triangle whose corners lie on a
      smooth surface is, to second order, ``4 (d_ab l_a l_b + d_bc l_b l_c + d_ca l_c l_a)``
      in barycentric coordinates l, with d the deviations at the midpoints;
    * the maximum of that quadratic model inside the triangle (the circumcentre for a
      sphere), or the centroid when the maximum is on the boundary;
    * ``tutorial`` field: five points along each zone boundary crossing the triangle (the
      surface has a crease there, where the largest deviation of such a triangle is).

    A sample with no surface point within 2 h along its line counts as 2 h; the root
    finding tolerance (1e-4 h) is added."""
    if len(f) == 0:
        return 0.0, np.zeros(0)
    A, B, C = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    edges, edge_of = _edges(f)  # each edge midpoint once
    d_mid = _signed_distance(field, 0.5 * (v[edges[:, 0]] + v[edges[:, 1]]), h)[edge_of]
    dab, dbc, dca = d_mid[:, 0], d_mid[:, 1], d_mid[:, 2]
    lam = _quadratic_max(dab, dbc, dca)
    inner = lam[:, :1] * A + lam[:, 1:2] * B + lam[:, 2:] * C
    per_face = np.maximum(np.maximum(np.abs(dab), np.abs(dbc)), np.abs(dca))
    per_face = np.maximum(per_face, np.abs(_signed_distance(field, inner, h)))
    if field.kind == "tutorial":
        pts, face = _crease_samples(field, A, B, C)
        if len(pts):
            np.maximum.at(per_face, face, np.abs(_signed_distance(field, pts, h)))
    return float(per_face.max()), per_face


def _signed_distance(field: BlobField, p: np.ndarray, h: float) -> np.ndarray:
    """Distance along the gradient line to the surface, positive outside, plus tolerance;
    2 h where none was found."""
    tol = 1e-4 * h
    t, _, found = _along_normals(field, p, h, tol)
    return np.where(found, -t + np.sign(-t) * tol, 2.0 * h)


def _quadratic_max(dab: np.ndarray, dbc: np.ndarray, dca: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of the critical point of q = dab la lb + dbc lb lc + dca lc la
    on the plane la + lb + lc = 1 where it lies inside the triangle, else the centroid. (For
    a sphere, d ~ squared edge length and this is the circumcentre's formula.)"""
    lam = np.stack([dbc * (dab + dca - dbc), dca * (dab + dbc - dca), dab * (dbc + dca - dab)],
                   axis=1)
    s = lam.sum(axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = lam / s
    good = np.isfinite(lam).all(axis=1) & (lam >= 0).all(axis=1)
    lam[~good] = 1.0 / 3.0
    return lam


def _crease_samples(field: BlobField, A: np.ndarray, B: np.ndarray, C: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Points along the zone boundaries (creases of the zone field) that cross triangles:
    for each source, the boundary between the lowest zone index of a triangle's corners and
    the next, where it cuts two edges: both cut points and three points between them."""
    pts, faces = [], []
    corners = (A, B, C)
    for i in range(len(field.centers)):
        x = [field.sqdist(P, i) for P in corners]
        q = [zone_index(xk) for xk in x]
        cross = (q[0] != q[1]) | (q[1] != q[2])
        if not cross.any():
            continue
        rows = np.nonzero(cross)[0]
        qlo = np.minimum(np.minimum(q[0], q[1]), q[2])[rows]
        bound = 10.0 / (qlo + 1.0)          # x of the boundary above the lowest zone
        side = [x[k][rows] < bound for k in range(3)]
        cut = []
        for k in range(3):                  # edge k: corner k -> corner k+1
            a, b = corners[k][rows], corners[(k + 1) % 3][rows]
            has = side[k] != side[(k + 1) % 3]
            cut.append((has, _sphere_crossing(a, b, field.centers[i],
                                              field.radius * np.sqrt(bound))))
        # the two cut edges of each triangle
        p = np.zeros((len(rows), 2, 3))
        cnt = np.zeros(len(rows), dtype=np.intp)
        for has, point in cut:
            sel = has & (cnt < 2)
            p[sel, cnt[sel]] = point[sel]
            cnt += sel
        two = cnt == 2
        p0, p1 = p[two, 0], p[two, 1]
        for w in (0.0, 0.25, 0.5, 0.75, 1.0):
            pts.append(p0 + w * (p1 - p0))
            faces.append(rows[two])
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.intp)
    return np.concatenate(pts), np.concatenate(faces)


def _sphere_crossing(a: np.ndarray, b: np.ndarray, c: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Where segments a-b cross the sphere |p - c| = r (one end inside, one outside)."""
    u, w = a - c, b - a
    qa = np.einsum("ij,ij->i", w, w)
    qb = 2.0 * np.einsum("ij,ij->i", u, w)
    qc = np.einsum("ij,ij->i", u, u) - r * r
    disc = np.sqrt(np.maximum(qb * qb - 4.0 * qa * qc, 0.0))
    qa = np.where(qa > 0, qa, 1.0)
    s1 = (-qb - disc) / (2.0 * qa)
    s2 = (-qb + disc) / (2.0 * qa)
    s = np.where((s1 >= 0) & (s1 <= 1), s1, s2)
    return a + np.clip(s, 0.0, 1.0)[:, None] * w


# ------------------------------------------------------------------------------------------
# the builder
# ------------------------------------------------------------------------------------------

def tessellate(field: BlobField, h: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """One pass at cell size h: vertices on the surface, faces, and an info dict."""
    timings = {}
    t0 = time.perf_counter()
    v, f, info = _marching_cubes(field, h)
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
        v, f, info["creases_lost"] = _cut_creases(field, v, f, h)
        v, f, _, _, info["slivers_removed"] = _clean_slivers(field, v, f, MIN_ANGLE_DEG, h)
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
    """Points splitting edges a-b, on the surface: the midpoint moved along the gradient;
    for an edge on a crease, onto the crease curve (radially onto the zone sphere, then
    along it); for an edge crossing a zone boundary in its middle half, the crease point
    on it (so that refinement also cuts along creases)."""
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
    if field.kind != "tutorial":
        return out
    free = src < 0
    for i in range(len(field.centers)):
        xa, xb = field.sqdist(a, i), field.sqdist(b, i)
        qa, qb = zone_index(xa), zone_index(xb)
        rows = np.nonzero(free & (qa != qb))[0]
        if not len(rows):
            continue
        bound = 10.0 / (np.minimum(qa, qb)[rows] + 1.0)
        r = field.radius * np.sqrt(bound)
        cross = _sphere_crossing(a[rows], b[rows], field.centers[i], r)
        w = b[rows] - a[rows]
        t = np.einsum("ij,ij->i", cross - a[rows], w) / np.einsum("ij,ij->i", w, w)
        mid_half = (t > 0.25) & (t < 0.75)
        rows, cross, r = rows[mid_half], cross[mid_half], r[mid_half]
        if len(rows):
            pts, found = _crease_points_from(field, cross, field.centers[i], r, h)
            # where the crease runs along the edge its point can be far off: keep the midpoint
            near = np.linalg.norm(pts - cross, axis=1) < 0.25 * np.sqrt(
                np.einsum("ij,ij->i", w[mid_half], w[mid_half]))
            ok = found & near
            out[rows[ok]] = pts[ok]
            free[rows[ok]] = False
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
    """Cell size whose tessellation of a sphere of radius R has about max_error, at most
    R/6 so that marching cubes sees necks and gaps down to about that size."""
    return min(math.sqrt(max_error * radius / SPHERE_ERROR_C), radius / 6.0)


def build_blob_mesh(centers, radius: float, field: str = "tutorial", max_error: float | None = None,
                    *, normals: str = "exact", cell_size: float | None = None,
                    max_passes: int = 40, max_triangles: int = 5_000_000,
                    log: Callable[[str], None] | None = None) -> BlobMesh:
    """Triangle mesh of the metaball surface ``sum_i f(|p - c_i|^2 / R^2) = 1``.

    ``centers`` (N, 3), ``radius`` R > 0, ``field`` 'tutorial' or 'exact', ``max_error`` > 0
    (same units as the centres): the mesh is refined until the measured distance from its
    triangles to the surface is at most ``max_error`` (or ``max_passes`` refinement passes or
    ``max_triangles`` are reached; then ``achieved_error`` says so). With ``cell_size`` the
    marching-cubes cell is that instead of the one derived from ``max_error``, and
    ``max_error`` may be None: one pass without refinement, error measured (for studies of
    convergence). ``normals``: 'exact' (gradient of sum R^2/d^2, the tutorial's shading),
    'field' (gradient of the chosen field; the mean of both sides on the zone field's
    creases) or 'flat' (no vertex normals). ``log`` receives progress lines.
    Raises :class:`BlobMeshError` naming the bad parameter."""
    centers, radius, max_error = _validate(centers, radius, field, max_error, normals, cell_size)
    fld = BlobField(centers, radius, field)
    t_start = time.perf_counter()
    if cell_size is not None:
        h = cell_size
    else:
        h = initial_cell_size(radius, max_error)
        # keep the marching-cubes grid below MAX_GRID_POINTS; refinement does the rest
        extent = float((centers.max(axis=0) - centers.min(axis=0)).max()) \
            + 2.0 * math.sqrt(fld.support_x()) * radius
        h = max(h, extent / MAX_GRID_POINTS ** (1.0 / 3.0))
    v, f, info = tessellate(fld, h)
    err, per_face = measure_error(fld, v, f, h)
    passes = 0
    # On the zone field the sampled error of a triangle next to creases can be a few per
    # cent low (seen up to 4% in random tests): refine to 95% of max_error there.
    target = max_error * (TUTORIAL_MARGIN if field == "tutorial" else 1.0) \
        if cell_size is None else math.inf
    while err > target and passes < max_passes and len(f) < max_triangles:
        passes += 1
        v, f, kept = refine(fld, v, f, per_face > target, h)
        nk = int(kept.sum())
        per_face = np.concatenate([per_face[kept], measure_error(fld, v, f[nk:], h)[1]])
        err = float(per_face.max())
        if log is not None:
            log(f"refinement pass {passes}: {len(f)} triangles, error {err:.4g}")
    # refinement can leave flat triangles along creases: clean, measure again, refine again
    for _ in range(3):
        v, f, kept, changed, n_ops = _clean_slivers(fld, v, f, MIN_ANGLE_DEG, h)
        if not n_ops:
            break
        info["slivers_removed"] = info.get("slivers_removed", 0) + n_ops
        per_face = per_face[kept]
        per_face[changed] = measure_error(fld, v, f[changed], h)[1]
        err = float(per_face.max())
        while err > target and passes < max_passes and len(f) < max_triangles:
            passes += 1
            v, f, kept = refine(fld, v, f, per_face > target, h)
            nk = int(kept.sum())
            per_face = np.concatenate([per_face[kept], measure_error(fld, v, f[nk:], h)[1]])
            err = float(per_face.max())
    v, f = _compact(v, f)
    nrm = _vertex_normals(fld, v, normals)
    info.update(cell_size=h, refine_passes=passes, triangles=len(f), vertices=len(v),
                min_angle_deg=float(min_angles_deg(v, f).min()) if len(f) else 180.0,
                seconds=time.perf_counter() - t_start)
    return BlobMesh(v, f, nrm, err, info)


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
