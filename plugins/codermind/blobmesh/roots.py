"""Root finding on the blob surface (numpy only): along lines and along the great circles of
zone spheres (crease curves of the zone field), vectorized, always bracketed."""

from __future__ import annotations

from typing import Callable

import numpy as np

from .field import BlobField


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


def gradient_direction(field: BlobField, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def along_normals(field: BlobField, p: np.ndarray, h: float, tol: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Root along the field's gradient line through each point; where none is found (near
    a concave crease of the zone field the line can miss the surface), along the smooth
    gradient of sum R^2/d^2 instead. Returns (t, directions, found)."""
    n, slope = gradient_direction(field, p)
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


def onto_surface(field: BlobField, p: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    t, n, found = along_normals(field, p, h, 1e-7 * h)
    return p + t[:, None] * n, found


def crease_points(field: BlobField, a: np.ndarray, b: np.ndarray, c: np.ndarray, r: float,
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
    return crease_points_from(field, q, c, r, h)


def crease_points_from(field: BlobField, q: np.ndarray, c: np.ndarray, r: np.ndarray | float,
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


def sphere_crossing(a: np.ndarray, b: np.ndarray, c: np.ndarray, r: np.ndarray) -> np.ndarray:
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
