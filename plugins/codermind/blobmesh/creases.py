"""Cutting a mesh of the zone field along its creases (numpy only).

The zone field's gradient jumps on every source's zone spheres x = 10/(k+1); the surface has
a crease where it meets them. Cutting the mesh there, with new vertices exactly on the
crease curves, keeps every triangle on one smooth (spherical) piece of the surface."""

from __future__ import annotations

import math

import numpy as np

from .field import BlobField, zone_index
from .geom import mesh_edges, face_normals, on_crease, min_angles_deg
from .roots import crease_points

SNAP = 0.2           # crease cuts closer than SNAP * edge length to a vertex move the vertex
KEEP = 0.1           # ... or, if that vertex is on another crease, closer than KEEP: no cut


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


def cut_creases(field: BlobField, v: np.ndarray, f: np.ndarray, h: float,
                 fresh: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Cut the mesh along every zone sphere of every source (tutorial field only), so that
    each triangle lies within one zone of every source. Returns vertices, faces and the
    number of crease points not found (surface tangent to a zone sphere). Only faces with a
    ``fresh`` vertex (default: all) are looked at."""
    lost = 0
    fresh = np.ones(len(v), dtype=bool) if fresh is None else fresh.copy()
    # Vertices on a crease are never snapped onto another one (that would pull them off
    # the first: the cuts would chase each other).
    locked = on_crease(field, v)
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
    edges, edge_of = mesh_edges(fs)
    cut = (cls[edges[:, 0]] * cls[edges[:, 1]]) < 0
    ce = edges[cut]
    pts, found = crease_points(field, v[ce[:, 0]], v[ce[:, 1]], c, r, h)
    lost = int((~found).sum())
    # Snap: a crease point close to an edge end moves that vertex instead.
    w = v[ce[:, 1]] - v[ce[:, 0]]
    s = np.einsum("ij,ij->i", pts - v[ce[:, 0]], w) / np.einsum("ij,ij->i", w, w)
    near_a = found & (s < SNAP)
    near_b = found & (s > 1.0 - SNAP)
    # A locked end (on another crease) close to this crease is taken as on it: cutting
    # there would make a sliver. So is the nearer end of an edge whose crease point was not
    # found (where the surface runs along the zone sphere, or several creases meet). The
    # triangles then cross this crease by a little, which the error measurement sees and
    # refinement reduces.
    keep = np.concatenate([ce[found & (s < KEEP) & locked[ce[:, 0]], 0],
                           ce[found & (s > 1.0 - KEEP) & locked[ce[:, 1]], 1],
                           np.where(s < 0.5, ce[:, 0], ce[:, 1])[~found]])
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
        before = face_normals(v, fi)
        v_new = v.copy()
        v_new[mv] = mp
        flipped = np.einsum("ij,ij->i", before, face_normals(v_new, fi)) <= 0
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
