"""The two metaball fields of the ``blob`` shape (numpy only, no Mitsuba).

Both are sums over sources of a decreasing function f of ``x = |p - c|^2 / R^2``; the
surface is where the sum equals 1.

* ``tutorial``: the piecewise-linear zone field of the Codermind tutorial (facts.md
  F11): f is linear in x between the zone boundaries ``x = 10/(k+1)``, through
  (10, 0), (5, 0.2), (10/3, 0.3), ..., (10/9, 0.9), (1, 1), f = 0 for x >= 10, and the
  innermost segment ``1.9 - 0.9 x`` continues for x < 1. (The tutorial's code stores the
  boundaries rounded, 3.33333, 1.1111 and so on, which moves them by at most 1e-5 and makes
  f jump by at most 2e-6 there; we use the exact values, so f is continuous.) Within one
  combination of zones the field is ``a + s |p - m|^2`` with ``s < 0``, so each smooth piece
  of the surface is a piece of a sphere; the pieces meet at creases on the zone spheres
  ``x_i = 10/(k+1)``, where the gradient jumps.
* ``exact``: ``sum R^2 / |p - c|^2``, smooth away from the centres.
"""

from __future__ import annotations

import numpy as np

#: Zone boundaries in x = d^2/R^2 (descending): zone k is 10/(k+2) <= x < 10/(k+1).
ZONE_BOUNDS = 10.0 / np.arange(1, 10)
# Slope and intercept of f in x, indexed by q = min(int(10/x), 9): q = 0 is x >= 10 (f = 0),
# q = k + 1 is zone k. These are the tutorial's cumulative zone tables.
SLOPE = np.array([0.0, -0.04, -0.06, -0.12, -0.20, -0.30, -0.42, -0.56, -0.72, -0.90])
INTERCEPT = np.array([0.0, 0.4, 0.5, 0.7, 0.9, 1.1, 1.3, 1.5, 1.7, 1.9])

FIELDS = ("tutorial", "exact")
_TINY = 1e-30
#: The exact shading normal skips a source within |p - c|^2 <= NORMAL_SKIP R^2 of the point:
#: the tutorial skips |p - c|^2 <= 0.001 in its units (pixels), 1e-7 of the square of its
#: radii of about 100, which no point of its blobs' surfaces comes near. Relative to R, a
#: blob's normals do not depend on its world size (an absolute 0.001 skips every source of
#: a blob of radius below about 0.03, whose normals are then zero).
NORMAL_SKIP = 1e-7


def zone_index(x: np.ndarray) -> np.ndarray:
    """q = min(int(10/x), 9): 0 outside the support (x >= 10), k + 1 in zone k."""
    return np.minimum(10.0 / np.maximum(x, _TINY), 9.5).astype(np.intp)


class BlobField:
    """Sum over ``centers`` (N, 3) of f(|p - c|^2 / R^2); ``kind`` is 'tutorial' or 'exact'.
    Points are (M, 3) float64 arrays."""

    def __init__(self, centers: np.ndarray, radius: float, kind: str):
        self.centers = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
        self.radius = float(radius)
        self.kind = kind
        self.inv_r2 = 1.0 / (self.radius * self.radius)

    # -- per source, as functions of x ------------------------------------------------
    def f(self, x: np.ndarray) -> np.ndarray:
        if self.kind == "exact":
            return 1.0 / np.maximum(x, _TINY)
        q = zone_index(x)
        return INTERCEPT[q] + SLOPE[q] * x

    def df(self, x: np.ndarray, mean_at_bounds: bool = False) -> np.ndarray:
        """df/dx. For the zone field that of the zone of x (one-sided at a boundary), or with
        ``mean_at_bounds`` the mean of both sides within 1e-9 (relative) of a boundary."""
        if self.kind == "exact":
            return -1.0 / np.maximum(x * x, _TINY)
        q = zone_index(x)
        s = SLOPE[q]
        if mean_at_bounds:
            r = 10.0 / np.maximum(x, _TINY)
            k = np.rint(r)
            at = (np.abs(r - k) <= 1e-9 * k) & (k >= 1) & (k <= 9)
            k = k.astype(np.intp)
            s = np.where(at, 0.5 * (SLOPE[np.clip(k - 1, 0, 9)] + SLOPE[np.clip(k, 0, 9)]), s)
        return s

    def support_x(self) -> float:
        """Largest x at which a point can lie on the surface: f(x) >= 1/N is needed."""
        n = len(self.centers)
        if self.kind == "exact":
            return float(n)
        xs = np.concatenate([[0.0], ZONE_BOUNDS[::-1]])
        return float(np.interp(1.0 / n, self.f(xs)[::-1], xs[::-1]))

    # -- at points --------------------------------------------------------------------
    def sqdist(self, p: np.ndarray, i: int) -> np.ndarray:
        """x_i = |p - c_i|^2 / R^2."""
        c = self.centers[i]
        d0, d1, d2 = p[:, 0] - c[0], p[:, 1] - c[1], p[:, 2] - c[2]
        return (d0 * d0 + d1 * d1 + d2 * d2) * self.inv_r2

    def value(self, p: np.ndarray) -> np.ndarray:
        """Field at points p."""
        out = np.zeros(len(p))
        for i in range(len(self.centers)):
            out += self.f(self.sqdist(p, i))
        return out

    def gradient(self, p: np.ndarray, mean_at_bounds: bool = False) -> np.ndarray:
        """Gradient of the field at points p, (M, 3)."""
        out = np.zeros_like(p)
        for i, c in enumerate(self.centers):
            w = (2.0 * self.inv_r2) * self.df(self.sqdist(p, i), mean_at_bounds)
            out += w[:, None] * (p - c)
        return out

    # -- on boxes -----------------------------------------------------------------------
    def box_range(self, lo: list[np.ndarray], hi: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """Exact bounds (min, max) of the field over every box of a grid of boxes.

        ``lo[k]``, ``hi[k]`` are the box edges along axis k; the result has shape
        (len(lo[0]), len(lo[1]), len(lo[2])). Each f is decreasing in x, so its range over a
        box is [f(x_far), f(x_near)] with the exact extreme distances of the box."""
        shape = tuple(len(a) for a in lo)
        fmin = np.zeros(shape)
        fmax = np.zeros(shape)
        for c in self.centers:
            near, far = [], []
            for a0, a1, ci in zip(lo, hi, c):
                e0, e1 = (a0 - ci) ** 2, (a1 - ci) ** 2
                inside = (a0 <= ci) & (ci <= a1)
                near.append(np.where(inside, 0.0, np.minimum(e0, e1)) * self.inv_r2)
                far.append(np.maximum(e0, e1) * self.inv_r2)
            xn = near[0][:, None, None] + near[1][None, :, None] + near[2][None, None, :]
            xf = far[0][:, None, None] + far[1][None, :, None] + far[2][None, None, :]
            fmax += self.f(xn)
            fmin += self.f(xf)
        return fmin, fmax

    # -- shading ------------------------------------------------------------------------
    def inverse_square_gradient(self, p: np.ndarray) -> np.ndarray:
        """The tutorial's shading normal (facts.md F11), unnormalized and pointing out:
        sum R^2/|p-c|^4 (p - c), skipping sources with |p - c|^2 <= NORMAL_SKIP R^2."""
        out = np.zeros_like(p)
        for i, c in enumerate(self.centers):
            x = self.sqdist(p, i)
            d2 = x * self.radius ** 2
            w = np.where(x > NORMAL_SKIP, self.radius ** 2 / np.maximum(d2 * d2, _TINY), 0.0)
            out += w[:, None] * (p - c)
        return out
