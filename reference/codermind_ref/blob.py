"""Blobs (metaballs) with the zone method of facts.md F11, solved exactly per zone.

Each source i adds f(x_i), x_i = |p - c_i|^2 / R^2, f piecewise linear through the zone
boundaries; the surface is sum f = 1. Zone k (k = 0..8) lies between the spheres of squared
radius RATIO[k] R^2 and RATIO[k+1] R^2, where f = SLOPE[k] x + INTERCEPT[k]; inside RATIO[9]
(x < 1) the last piece continues. Along a ray x_i is quadratic in t, so between two
consecutive zone-sphere crossings (of any source) the field is a quadratic in t.

The original accumulates, over the crossings sorted by t, each zone's polynomial increment and
its bound increment (0.2 for zone 0, 0.1 per deeper zone) as float32 running sums. With
``float32_sums`` (strict) this is what is done: the running bound is a float32 sum in sorted
event order and the `< 1` test is decided on it, so a lone source's core can come out at
0.99999994 and be skipped (holes, glass paths escaping from inside; facts.md F11.3). Without it
(clean) the zone depth of each source in each interval is counted instead (entries minus exits),
the bound is in exact tenths (a lone source's core is exactly 1 and kept) and the interval's
polynomial is built from the cumulative SLOPE/INTERCEPT table in float64: the same polynomial up
to rounding. As in the original, the direction is taken as unit length (A = 1 per source) and
roots count if > 0.01, inside their interval [t_i, t_i+1) and <= the current t; the first
interval with a root wins, which is the smallest valid root.

Rays are first culled with an upper bound of the field on the ray (sum of f at each source's
closest approach): where it is < 1 there can be no root; this only saves time.
"""

from __future__ import annotations

import numpy as np

from .vec import dot

EPSILON = 0.01
RATIO = np.array([10, 5, 3.33333, 2.5, 2, 1.66667, 1.42857, 1.25, 1.1111, 1])  # as in the code
SLOPE = np.array([0, -0.04, -0.06, -0.12, -0.20, -0.30, -0.42, -0.56, -0.72, -0.90])  # by depth
INTERCEPT = np.array([0, 0.4, 0.5, 0.7, 0.9, 1.1, 1.3, 1.5, 1.7, 1.9])              # by depth
BOUND_TENTHS = np.array([0, 2, 3, 4, 5, 6, 7, 8, 9, 10], dtype=np.int16)            # by depth
ZONES = 9  # zone spheres 0..8 produce crossings; zone 9 is only the terminator
# float32 increments of one zone crossing (entering zone sphere k: depth k -> k + 1). The bound
# steps are the float32 differences of the zone bounds 0.2, 0.3, ..., 1.0 (so 0.1 only up to
# float32 rounding): with them a lone source's core sums to exactly 1, and to 0.99999994 after
# another source's zone 0 was entered and left in between, as facts.md F11.3 states (plain 0.1f
# steps give 1.0000001 there and no holes).
_BOUND_INC32 = np.diff(np.array([0.0] + [0.1 * k for k in range(2, 11)], dtype=np.float32))
_SLOPE_INC = np.diff(SLOPE)
_INTERCEPT_INC = np.diff(INTERCEPT)


def field(x: np.ndarray) -> np.ndarray:
    """f(x) of one source: piecewise linear, 0 for x >= 10 (used by the cull)."""
    x = np.asarray(x, dtype=float)
    depth = np.searchsorted(-RATIO[:ZONES], -x, side="left")   # zone spheres with x < RATIO[k]
    return SLOPE[depth] * x + INTERCEPT[depth]


def _cull(b, cc, r2, tmax):
    """Indices of the rays that may have a root in (EPSILON, tmax): f decreases with x, so the
    field on the segment is at most sum_i f(min x_i), with min x_i at the closest approach to
    source i on the segment. A sum >= 1 needs some f(min x_i) >= 1/3, i.e. min x_i <= 3.06.
    The margin covers the tiny non-monotone steps of f at the rounded zone radii."""
    xmin = np.empty_like(b)
    for s in range(3):
        t = np.clip(b[s], EPSILON, np.maximum(tmax, EPSILON))
        xmin[s] = np.maximum(t * t - 2.0 * b[s] * t + cc[s], 0.0) / r2
    near = np.flatnonzero(xmin.min(axis=0) < 3.1)
    bound = field(xmin[:, near]).sum(axis=0)
    return near[bound >= 1.0 - 1e-5]


# Per event, the change of the combined zone-depth code 100 d0 + 10 d1 + d2 (the depth d_i of
# source i = zone spheres of source i that contain the point, 0..9): event columns are
# source-major, 9 entries (+) then 9 exits (-). A depth never leaves 0..9 (a missed zone has
# neither event), so the cumulative sum of these steps is exactly the code of every interval.
_STEP = np.concatenate([np.repeat([10 ** (2 - s), -10 ** (2 - s)], ZONES) for s in range(3)]
                       ).astype(np.int16)
_DIGITS = np.array([[code // 100, code // 10 % 10, code % 10] for code in range(1000)]).T
_BOUND_OF_CODE = BOUND_TENTHS[_DIGITS].sum(axis=0).astype(np.int16)   # (1000,)


def hit(o: np.ndarray, d: np.ndarray, t: np.ndarray, centers: np.ndarray, radius: float,
        float32_sums: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(new t, hit mask): the blob's first root in (0.01, t] per ray (roots equal to t count),
    t unchanged where there is none. float32_sums: the original's float32 running sums of the
    bound and the polynomial (strict), else exact tenths (clean)."""
    r2 = radius * radius
    oc = [centers[s].reshape(3, 1) - o for s in range(3)]
    b = np.stack([dot(d, v) for v in oc])
    cc = np.stack([dot(v, v) for v in oc])
    out = t.copy()
    hits = np.zeros(t.shape, dtype=bool)
    sel = _cull(b, cc, r2, t)
    if sel.size == 0:
        return out, hits
    b, cc, tmax = b[:, sel], cc[:, sel], t[sel]
    n, width = sel.size, 6 * ZONES
    bt = b.T[:, :, None]                                                   # (n, 3, 1)
    with np.errstate(invalid="ignore"):
        root = np.sqrt(bt * bt - cc.T[:, :, None] + RATIO[:ZONES] * r2)   # (n, 3, 9)
    # NaN for a missed zone sphere: no crossing (NaN sorts last)
    events = np.empty((n, 3, 2, ZONES))
    np.subtract(bt, root, out=events[:, :, 0])
    np.add(bt, root, out=events[:, :, 1])
    events = events.reshape(n, width)
    order = np.argsort(events, axis=1)
    if float32_sums:
        ray, lo, hi, tm, qa, qb, qc = _intervals_float32(events, order, b, cc, r2, tmax, width)
    else:
        ray, lo, hi, tm, qa, qb, qc = _intervals_exact(events, order, b, r2, cc, tmax, width)
    if ray.size == 0:
        return out, hits
    delta = qb * qb - 4.0 * qa * qc
    ok = delta >= 0
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 0.5 / qa
        sq = np.sqrt(np.where(ok, delta, 0.0))
        r0, r1 = inv * (-qb - sq), inv * (-qb + sq)
    best = np.full(ray.size, np.inf)
    for r in (r0, r1):
        good = ok & (r > EPSILON) & (r >= lo) & (r < hi) & (r <= tm)
        best = np.where(good & (r < best), r, best)
    found = np.isfinite(best)
    ray, best = ray[found], best[found]
    # pairs are in interval order per ray: the first valid one holds the first root
    first = np.ones(ray.size, dtype=bool)
    first[1:] = ray[1:] != ray[:-1]
    idx = sel[ray[first]]
    out[idx] = best[first]
    hits[idx] = True
    return out, hits


def _intervals_exact(events, order, b, r2, cc, tmax, width):
    """Candidate intervals with bound >= 1 in exact tenths, and their polynomial A t^2 + B t +
    (C - 1) from the zone depths (float64)."""
    n = events.shape[0]
    # After the last real crossing come the NaN ones, whose steps make the code meaningless
    # (each digit stays within -9..9, so indexing stays in range); their intervals end at NaN
    # and are dropped below. Column k holds the code of the interval from crossing k to k + 1.
    code = np.cumsum(_STEP[order], axis=1, dtype=np.int16)
    valid = _BOUND_OF_CODE[code] >= 10                                    # bound >= 1
    valid[:, -1] = False
    ray, lo, hi, tm, idx = _live(np.flatnonzero(valid), events, order, tmax, width)
    c = code.reshape(-1)[idx]
    # the interval's field A t^2 + B t + C from each source's zone line SLOPE x + INTERCEPT,
    # x = (t^2 - 2 b t + cc) / R^2
    qa = np.zeros(ray.size)
    qb = np.zeros(ray.size)
    qc = np.full(ray.size, -1.0)
    for s in range(3):
        depth = _DIGITS[s][c]
        slope = SLOPE[depth] / r2
        qa += slope
        qb -= 2.0 * b[s][ray] * slope
        qc += cc[s][ray] * slope + INTERCEPT[depth]
    return ray, lo, hi, tm, qa, qb, qc


def _intervals_float32(events, order, b, cc, r2, tmax, width):
    """Candidate intervals as the original finds them: the bound and A, B, C are float32 running
    sums over the crossings in sorted order, and the bound test is decided in float32."""
    n = events.shape[0]
    missed = np.isnan(events).reshape(n, 3, 2, ZONES)
    sign = np.array([1.0, -1.0]).reshape(1, 1, 2, 1)
    bound = np.where(missed, np.float32(0), sign.astype(np.float32) * _BOUND_INC32)
    # quick reject: the total of the entry increments (source by source, outer zone first)
    total = np.cumsum(bound[:, :, 0].reshape(n, -1), axis=1, dtype=np.float32)[:, -1]
    gamma = _SLOPE_INC / r2                                                     # (9,)
    bt, ct = b.T[:, :, None, None], cc.T[:, :, None, None]
    inc_a = np.where(missed, 0.0, sign * gamma).astype(np.float32)
    inc_b = np.where(missed, 0.0, sign * (-2.0 * bt * gamma)).astype(np.float32)
    inc_c = np.where(missed, 0.0, sign * (ct * gamma + _INTERCEPT_INC)).astype(np.float32)
    # np.cumsum accumulates sequentially in the given dtype: the running sums in event order
    sums = [np.cumsum(np.take_along_axis(x.reshape(n, width), order, axis=1), axis=1,
                      dtype=np.float32) for x in (bound, inc_a, inc_b, inc_c)]
    valid = (sums[0] >= np.float32(1.0)) & (total >= np.float32(1.0))[:, None]
    valid[:, -1] = False
    ray, lo, hi, tm, idx = _live(np.flatnonzero(valid), events, order, tmax, width)
    qa, qb, qc = (x.reshape(-1)[idx].astype(np.float64) for x in sums[1:])
    return ray, lo, hi, tm, qa, qb, qc - 1.0


def _live(idx, events, order, tmax, width):
    """The intervals idx (flat (ray, column) indices) that overlap (0.01, current t): ray, start,
    end, current t and the surviving flat indices."""
    ray = idx // width
    order = order.reshape(-1)
    flat = events.reshape(-1)
    lo, hi = flat[ray * width + order[idx]], flat[ray * width + order[idx + 1]]
    tm = tmax[ray]
    live = (lo < tm) & (hi > EPSILON) & (hi < np.inf)     # hi is NaN past the last crossing
    return ray[live], lo[live], hi[live], tm[live], idx[live]


def normal(p: np.ndarray, centers: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Direction of sum_i (R^2/|p-c_i|^4)(p-c_i) over sources with |p-c_i|^2 > 0.001 (the exact
    1/d^2 field's gradient, not the piecewise one's), normalized; and a zero-length mask."""
    n = np.zeros_like(p)
    r2 = radius * radius
    for s in range(3):
        v = p - centers[s].reshape(3, 1)
        d2 = dot(v, v)
        with np.errstate(divide="ignore", invalid="ignore"):
            w = np.where(d2 > 0.001, r2 / (d2 * d2), 0.0)
        n += w * v
    length2 = dot(n, n)
    zero = length2 == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        return n * (1.0 / np.sqrt(length2)), zero
