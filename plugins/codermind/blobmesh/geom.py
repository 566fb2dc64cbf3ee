"""Triangle-mesh helpers of the blob shape (numpy only): edges, normals, angles, and the
removal of slivers by edge collapse and edge flip."""

from __future__ import annotations

import numpy as np

from .field import BlobField

MAX_SLIVERS = 5000  # per round of clean_slivers (a Python loop)


def mesh_edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def face_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
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


def on_crease(field: BlobField, v: np.ndarray, rel: float = 1e-9) -> np.ndarray:
    """Vertices on a zone sphere of some source (tutorial field), i.e. on a crease."""
    out = np.zeros(len(v), dtype=bool)
    if field.kind != "tutorial":
        return out
    for i in range(len(field.centers)):
        k = 10.0 / np.maximum(field.sqdist(v, i), 1e-30)
        j = np.rint(k)
        out |= (np.abs(k - j) <= rel * j) & (j >= 1) & (j <= 9)
    return out


def clean_slivers(field: BlobField, v: np.ndarray, f: np.ndarray, min_angle: float, h: float
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
    locked = on_crease(field, v)
    changed = np.zeros(len(f), dtype=bool)
    kept = np.arange(len(f))
    for _ in range(6):
        ang = min_angles_deg(v, f)
        bad = np.nonzero(ang < min_angle)[0]
        if not len(bad):
            break
        bad = bad[np.argsort(ang[bad])][:MAX_SLIVERS]
        inc = np.argsort(f.ravel(), kind="stable")               # vertex -> faces
        vstart = np.searchsorted(f.ravel()[inc], np.arange(len(v) + 1))
        new_f = f.copy()
        alive = np.ones(len(f), dtype=bool)
        busy = np.zeros(len(v), dtype=bool)
        n_round = 0

        def outward_ok(tri: np.ndarray) -> bool:
            if not len(tri):
                return True
            n = face_normals(v, tri)
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
    """Collapse edge a-b (see clean_slivers); False where it is not allowed."""
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
    """Flip the longest edge of face t (see clean_slivers); False where not allowed."""
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
