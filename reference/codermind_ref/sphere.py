"""Ray-sphere intersection of facts.md F4.1, for rays as (3, N) arrays with unit directions."""

from __future__ import annotations

import numpy as np

from .vec import dot

EPSILON = 0.1  # the same for primary, reflected, refracted and shadow rays; no origin offset


def hit(o: np.ndarray, d: np.ndarray, t: np.ndarray, center: np.ndarray, radius) -> np.ndarray:
    """Nearer root in (EPSILON, t), else the farther one; returns the new t (t where no hit).
    center: (3, 1) column; arithmetic in the arrays' dtype."""
    dist = center - o
    b = dot(d, dist)
    disc = b * b - dot(dist, dist) + radius * radius
    ok = disc >= 0.0
    root = np.sqrt(np.where(ok, disc, 0.0))
    t0, t1 = b - root, b + root
    take0 = ok & (t0 > EPSILON) & (t0 < t)
    take1 = ok & ~take0 & (t1 > EPSILON) & (t1 < t)
    return np.where(take0, t0, np.where(take1, t1, t))


def normal(p: np.ndarray, center: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(p - c)/|p - c| and a mask of the points where |p - c| = 0 (the path stops there)."""
    n = p - center
    length2 = dot(n, n)
    zero = length2 == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        return n * (1.0 / np.sqrt(length2)), zero
