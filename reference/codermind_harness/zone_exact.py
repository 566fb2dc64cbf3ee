"""The tutorial's blob field (facts.md F11) solved in 50-digit decimal arithmetic.

The exact answer to the question the port's zone method (``codermind_ref.blob.hit``) answers
in float64: where does a ray first meet ``sum_i f(|p - c_i|^2 / R^2) = 1``, with ``f`` the
piecewise-linear zone function of the code's tables (``RATIO``, ``SLOPE``, ``INTERCEPT`` as
written, e.g. 3.33333, not 10/3)? The inputs are the exact values of the float64 ray and
sources; every step (zone-sphere crossings, sorting, the quadratic of each interval and its
roots) is done with :mod:`decimal` at 50 significant digits, so the result is exact to far
more digits than any float64 result can have. No epsilon or distance limit is applied other
than ``t_min`` (default 0: the first root in front of the origin).

Written independently of the port (its tables are re-stated here from facts.md F11.2), so that the
two agree only if both are right. Slow (about a millisecond per ray): for sweeps, not renders.
"""

from __future__ import annotations

from decimal import Decimal, getcontext, localcontext

PRECISION = 50
# The zone tables of facts.md F11.2, as written in the tutorial's code, by zone depth 0..9 (the
# number of zone spheres containing the point; depth 0 = outside all: f = 0).
RATIO = tuple(Decimal(v) for v in ("10", "5", "3.33333", "2.5", "2", "1.66667", "1.42857",
                                   "1.25", "1.1111", "1"))
SLOPE = tuple(Decimal(v) for v in ("0", "-0.04", "-0.06", "-0.12", "-0.20", "-0.30", "-0.42",
                                   "-0.56", "-0.72", "-0.90"))
INTERCEPT = tuple(Decimal(v) for v in ("0", "0.4", "0.5", "0.7", "0.9", "1.1", "1.3", "1.5",
                                       "1.7", "1.9"))
CROSSING_SPHERES = 9     # zone spheres RATIO[0..8]; inside RATIO[8] the last line continues


def _dec(v) -> Decimal:
    return Decimal(float(v))      # exact value of the float64


def field_at(p, centers, radius) -> Decimal:
    """sum_i f(x_i) at point p (exact for float64 inputs)."""
    with localcontext() as ctx:
        ctx.prec = PRECISION
        r2 = _dec(radius) ** 2
        total = Decimal(0)
        for c in centers:
            x = sum((_dec(a) - _dec(b)) ** 2 for a, b in zip(p, c)) / r2
            total += _f(x)
        return total


def _depth(x: Decimal) -> int:
    return sum(1 for k in range(CROSSING_SPHERES) if x < RATIO[k])


def _f(x: Decimal) -> Decimal:
    d = _depth(x)
    return SLOPE[d] * x + INTERCEPT[d]


def first_hit(o, d, centers, radius, t_min: float = 0.0) -> Decimal | None:
    """The smallest t > t_min with field(o + t d) = 1 (d need not be unit length), or None."""
    with localcontext() as ctx:
        ctx.prec = PRECISION
        o = [_dec(v) for v in o]
        d = [_dec(v) for v in d]
        r2 = _dec(radius) ** 2
        a = sum(v * v for v in d)
        sources = []                       # x_i(t) = (a t^2 - 2 b t + cc) / R^2
        crossings = []
        for c in centers:
            oc = [_dec(ci) - oi for ci, oi in zip(c, o)]
            b = sum(di * v for di, v in zip(d, oc))
            cc = sum(v * v for v in oc)
            sources.append((b, cc))
            for k in range(CROSSING_SPHERES):
                disc = b * b - a * (cc - RATIO[k] * r2)
                if disc < 0:
                    break                  # deeper (smaller) zone spheres are missed too
                root = disc.sqrt()
                crossings += [(b - root) / a, (b + root) / a]
        lo_bound = _dec(t_min)
        times = sorted({t for t in crossings if t > lo_bound})
        bounds = [lo_bound] + times
        for lo, hi in zip(bounds, bounds[1:]):
            mid = (lo + hi) / 2
            qa = qb = Decimal(0)
            qc = Decimal(-1)
            for b, cc in sources:
                x_mid = (a * mid * mid - 2 * b * mid + cc) / r2
                depth = _depth(x_mid)
                s = SLOPE[depth] / r2
                qa += s * a
                qb -= 2 * s * b
                qc += s * cc + INTERCEPT[depth]
            root = _smallest_root(qa, qb, qc, lo, hi)
            if root is not None and root > lo_bound:
                return root
        return None                        # beyond the last crossing the field is 0


def _smallest_root(qa: Decimal, qb: Decimal, qc: Decimal, lo: Decimal, hi: Decimal):
    """Smallest root of qa t^2 + qb t + qc in [lo, hi], or None."""
    if qa == 0:
        if qb == 0:
            return None
        roots = [-qc / qb]
    else:
        disc = qb * qb - 4 * qa * qc
        if disc < 0:
            return None
        sq = disc.sqrt()
        # the numerically stable pair (cancellation does not matter at 50 digits, but costs
        # nothing)
        q = -(qb + sq) / 2 if qb >= 0 else -(qb - sq) / 2
        roots = [q / qa, qc / q] if q != 0 else [Decimal(0)]
    inside = sorted(r for r in roots if lo <= r <= hi)
    return inside[0] if inside else None

