"""The analytic intersection of the ``blob``'s zone field (``tessellate`` = ``false``): the
walk along a ray over the intervals between zone-sphere crossings, with one quadratic solved
per interval.

Along a ray o + t d each source's x_i = |o + t d - c_i|^2/R^2 is a parabola in t (closest
approach x0_i at t = tc_i, curvature a = |d|^2/R^2), and within a zone the field f is a
line in x, so between two consecutive zone-sphere crossings (of any source) F - 1 is a
quadratic in t. The functions here take that approach (``tcs``, ``x0s``, ``a``) and know
nothing of the shape: :class:`codermind.shapes._blob_exact.BlobSurface` computes it from a
ray and calls :func:`clean_walk` or :func:`strict_walk`.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np

from ..blobmesh.field import INTERCEPT, SLOPE
from ..masks import logical_not as _not

# zone_lines' closed form of the zone tables beyond the outermost zone
assert all(abs(SLOPE[k] + k * (k + 1) / 100) < 1e-12 and abs(INTERCEPT[k] - (2 * k + 1) / 10)
           < 1e-12 for k in range(2, 10)), "zone tables are no longer the chords of 1/x"

# the strict walk's bound increments of zones 0..8: the float32 differences of the zone bounds
# 0.2, 0.3, ..., 1.0 (facts.md F11.3: they sum to exactly 1 in a lone core)
_BOUND_INC32 = [float(v) for v in np.diff(np.array([0.0] + [0.1 * k for k in range(2, 11)],
                                                   dtype=np.float32))]

#: F units by which the clean walk widens the stretch of a ray where F >= 1 is possible
#: (the float32 rounding of each source's f is ~1e-7)
REACH_SLACK = 1e-4

#: facts.md F11.2's zone radii r^2/R^2 "as written in the code" (zones 0..8)
WRITTEN_RATIO = (10.0, 5.0, 3.33333, 2.5, 2.0, 1.66667, 1.42857, 1.25, 1.1111)


def bound_level(sources: int) -> float:
    """A level L with F < 1 wherever every x_i >= L: f(10/j) = 0.1 j (j >= 2), so
    N sources outside x = 10/j give F <= 0.1 j N < 1 for j < 10/N (L = 10: F = 0)."""
    j = max(1, math.ceil(10.0 / sources) - 1)
    return 10.0 / j


def lines_of(k: mi.Float) -> tuple[mi.Float, mi.Float]:
    """The zone field's line (ds, di) of zone ``k`` (0: beyond x = 10)."""
    ds = dr.select(k == 1.0, float(SLOPE[1]), -0.01 * k * (k + 1.0))
    di = dr.select(k == 1.0, float(INTERCEPT[1]), 0.1 * (2.0 * k + 1.0))
    return dr.select(k == 0.0, 0.0, ds), dr.select(k == 0.0, 0.0, di)


def crossing(tc: mi.Float, x0: mi.Float, inv_a: mi.Float, k: mi.Float, out: mi.Bool
             ) -> mi.Float:
    """A source's next zone-sphere crossing from zone ``k``: on the way in (``out``
    false) where it enters zone k + 1, on the way out where it leaves zone k (inf
    from zone 0)."""
    level = 10.0 / dr.maximum(dr.select(out, k, k + 1.0), 1.0)
    h = dr.safe_sqrt((level - x0) * inv_a)
    return dr.select(out, dr.select(k >= 1.0, tc + h, dr.inf), tc - h)


def zone_lines(x: mi.Float) -> tuple[mi.Float, mi.Float]:
    """The zone field's line f = di + ds x at ``x``: (ds, di), (0, 0) beyond x = 10.
    The depth k = #{j in 1..9: x <= 10/j} = min(9, floor(10/x)) picks the cumulative
    tables' line (blobmesh.field); from k = 2 on they are the chords of 1/x (checked at
    import), so a few operations instead of one select per zone."""
    return lines_of(dr.clip(dr.floor(10.0 / dr.maximum(x, 1e-30)), 0.0, 9.0))


def field_of(x: mi.Float) -> mi.Float:
    """One source's zone field f(x)."""
    ds, di = zone_lines(x)
    return dr.fma(ds, x, di)


def first_root(qa: mi.Float, qb: mi.Float, qg: mi.Float, lo: mi.Float, span: mi.Float
               ) -> mi.Float:
    """The smallest root s of qa s^2 + qb s + qg in [lo, span] (stable form), or inf."""
    disc = qb * qb - 4.0 * qa * qg
    sq = dr.safe_sqrt(disc)
    q = -0.5 * (qb + dr.select(qb >= 0, sq, -sq))
    r1 = dr.select(qa != 0, q / dr.select(qa != 0, qa, 1.0), dr.inf)
    r2 = dr.select(q != 0, qg / dr.select(q != 0, q, 1.0), dr.inf)
    small, large = dr.minimum(r1, r2), dr.maximum(r1, r2)
    return dr.select((disc >= 0) & (small >= lo) & (small <= span), small,
                     dr.select((disc >= 0) & (large >= lo) & (large <= span), large, dr.inf))


def quadratic(tcs: list, x0s: list, a: mi.Float, t0: mi.Float, t1: mi.Float
              ) -> tuple[mi.Float, mi.Float, mi.Float]:
    """F - 1 = A s^2 + B s + G in s = t - t0 on [t0, t1], no zone sphere crossed inside:
    each source's line taken at the midpoint."""
    tm = 0.5 * (t0 + t1)
    return quadratic_of(tcs, x0s, a, t0, [zone_lines(x0 + a * dr.square(tm - tc))
                                          for tc, x0 in zip(tcs, x0s)])


def quadratic_of(tcs: list, x0s: list, a: mi.Float, t0: mi.Float, lines: list
                 ) -> tuple[mi.Float, mi.Float, mi.Float]:
    """F - 1 = A s^2 + B s + G in s = t - t0 with each source on its line (ds, di)."""
    qa, qb, qg = mi.Float(0.0), mi.Float(0.0), mi.Float(-1.0)
    for tc, x0, (ds, di) in zip(tcs, x0s, lines):
        u0 = t0 - tc
        qa += ds * a
        qb += ds * (2.0 * a * u0)
        qg += ds * (x0 + a * u0 * u0) + di
    return qa, qb, qg


@dr.syntax


def strict_walk(tcs: list, x0s: list, a: mi.Float, tmin: float, tmax: mi.Float,
                active: mi.Bool = True) -> mi.Float:
    """The original's intersection (facts.md F11): every zone sphere's entry and exit,
    walked in t order from the first (also behind the origin) with the bound increments
    as a float32 running sum; an interval is solved only where that sum is >= 1, so a
    lone source's core can be skipped where the sum comes out at 0.99999994 (the
    original's holes). The increments are ``_BOUND_INC32``; ``tcs``, ``x0s``, ``a``: the
    ray's approach to each source (``BlobSurface.approach``)."""
    inc = _BOUND_INC32
    events = []                      # (t, crossed, signed bound increment), walked in t order
    total = mi.Float(0.0)            # quick reject: the entry increments, source by source
    for tc, x0 in zip(tcs, x0s):
        for k, level in enumerate(WRITTEN_RATIO):
            crossed = x0 < level
            total += dr.select(crossed, inc[k], 0.0)
            h = dr.safe_sqrt((level - x0) / a)
            events.append((tc - h, crossed, inc[k]))
            events.append((tc + h, crossed, -inc[k]))
    hit_t = mi.Float(dr.inf)
    t0 = mi.Float(-dr.inf)
    i0 = mi.Int32(-1)
    bound = mi.Float(0.0)
    walking = mi.Bool(active) & (total >= 1.0)
    while walking:
        # the next event in (t, index) order
        t1 = mi.Float(dr.inf)
        i1 = mi.Int32(-1)
        step = mi.Float(0.0)
        for e, (te, crossed, de) in enumerate(events):
            later = crossed & ((te > t0) | ((te == t0) & (e > i0)))
            better = later & (te < t1)
            t1 = dr.select(better, te, t1)
            i1 = dr.select(better, e, i1)
            step = dr.select(better, de, step)
        solve = (bound >= 1.0) & (t1 > t0) & (t1 > tmin) & (t0 < tmax) & dr.isfinite(t1)
        if solve:
            qa, qb, qg = quadratic(tcs, x0s, a, t0, t1)
            s = first_root(qa, qb, qg, dr.maximum(tmin - t0, 0.0), t1 - t0)
            t = t0 + s
            hit_t = dr.select(dr.isfinite(s) & (t > tmin) & (t < t1) & (t <= tmax), t,
                              hit_t)
        bound += step
        t0 = t1
        i0 = i1
        walking &= _not(dr.isfinite(hit_t)) & dr.isfinite(t1) & (t0 < tmax)
    return hit_t


def clean_walk(tcs: list, x0s: list, a: mi.Float, bound: float, tmin: float, tmax: mi.Float,
               active: mi.Bool = True) -> mi.Float:
    """The first crossing of F = 1 in (``tmin``, ``tmax``), or inf: the intervals between
    consecutive zone-sphere crossings walked one source at a time, one quadratic solved
    per interval, on the stretch of the ray where F >= 1 is possible. ``tcs``, ``x0s``,
    ``a``: the ray's approach to each source (``BlobSurface.approach``); ``bound``: a
    level beyond which no source adds to F = 1 (:func:`bound_level`)."""
    inv_a = 1.0 / a
    t_enter, t_exit = mi.Float(dr.inf), mi.Float(-dr.inf)
    for tc, x0 in zip(tcs, x0s):
        h = dr.safe_sqrt((bound - x0) * inv_a)
        near = x0 < bound
        t_enter = dr.select(near, dr.minimum(t_enter, tc - h), t_enter)
        t_exit = dr.select(near, dr.maximum(t_exit, tc + h), t_exit)
    # where F >= 1 is possible at all: each source contributes at most f(x0), at its
    # closest approach, so with M = sum f(x0_i), F(t) >= 1 needs M >= 1 and every source
    # within M - 1 of its most, f(x_i(t)) >= f(x0_i) - (M - 1): an interval of t per
    # source whose limit is not vacuous. The walk runs on their intersection (on page 4
    # it takes half the walk's steps, and most rays that miss take none)
    f0s = [field_of(x0) for x0 in x0s]
    excess = f0s[0] - 1.0
    for f0 in f0s[1:]:
        excess += f0
    for tc, x0, f0 in zip(tcs, x0s, f0s):
        v = f0 - excess - REACH_SLACK
        ds, di = lines_of(dr.clip(dr.ceil(10.0 * v) - 1.0, 1.0, 9.0))
        h = dr.safe_sqrt(((v - di) / ds - x0) * inv_a)     # f(x) = v: f's inverse
        near = v > 0.0
        t_enter = dr.select(near, dr.maximum(t_enter, tc - h), t_enter)
        t_exit = dr.select(near, dr.minimum(t_exit, tc + h), t_exit)
    t0 = dr.maximum(t_enter, tmin)
    hi = dr.select(excess >= -REACH_SLACK, dr.minimum(t_exit, tmax), -dr.inf)
    # per source: the deepest zone the ray reaches (fixed along it), the zone just past
    # t0 (probed just beyond it), whether the ray is past that deepest zone's entry (on
    # the way out), and the next crossing; the walk then moves one source at a time
    probe = t0 + 1e-3
    deeps, ks, outs, tns = [], [], [], []
    for tc, x0 in zip(tcs, x0s):
        deep = dr.minimum(dr.floor(10.0 / dr.maximum(x0, 1e-30)), 9.0)
        u = probe - tc
        k = dr.minimum(dr.floor(10.0 / dr.maximum(x0 + a * u * u, 1e-30)), deep)
        out = (u >= 0) | (k >= deep)
        deeps.append(deep)
        ks.append(k)
        outs.append(out)
        tns.append(crossing(tc, x0, inv_a, k, out))
    n = len(tcs)

    def body(t0, hit_t, walking, ks, outs, tns):
        t1 = mi.Float(hi)
        for tn in tns:
            t1 = dr.minimum(t1, tn)
        # F - 1 on the interval from each source's current zone
        qa, qb, qg = quadratic_of(tcs, x0s, a, t0, [lines_of(k) for k in ks])
        s = first_root(qa, qb, qg, 0.0, t1 - t0)
        found = dr.isfinite(s)
        hit_t = dr.select(walking & found, t0 + s, hit_t)
        # the source whose crossing ends the interval moves to its next zone
        j = mi.UInt32(n)
        for i in reversed(range(n)):
            j = dr.select(tns[i] == t1, i, j)
        tc_j, x0_j, k_j, out_j, deep_j = tcs[0], x0s[0], ks[0], outs[0], deeps[0]
        for i in range(1, n):
            on = j == i
            tc_j = dr.select(on, tcs[i], tc_j)
            x0_j = dr.select(on, x0s[i], x0_j)
            k_j = dr.select(on, ks[i], k_j)
            out_j = dr.select(on, outs[i], out_j)
            deep_j = dr.select(on, deeps[i], deep_j)
        k_j = dr.select(out_j, k_j - 1.0, k_j + 1.0)
        out_j = out_j | (k_j >= deep_j)
        tn_j = crossing(tc_j, x0_j, inv_a, k_j, out_j)
        ks, outs, tns = list(ks), list(outs), list(tns)
        for i in range(n):
            on = walking & (j == i)
            ks[i] = dr.select(on, k_j, ks[i])
            outs[i] = dr.select(on, out_j, outs[i])
            tns[i] = dr.select(on, tn_j, tns[i])
        t0 = dr.select(walking, t1, t0)
        walking = walking & _not(found) & (t0 < hi)
        return t0, hit_t, walking, ks, outs, tns

    walking = mi.Bool(active) & (t0 < hi)
    state = (t0, mi.Float(dr.inf), walking, ks, outs, tns)
    state = dr.while_loop(state, lambda t0, hit_t, walking, *_: walking, body,
                          labels=("t0", "hit_t", "walking", "ks", "outs", "tns"),
                          label="blob.clean_walk")
    return state[1]
