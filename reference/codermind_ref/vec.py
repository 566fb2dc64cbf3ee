"""Vectors as float64 arrays of shape (3, N): row 0 = x, 1 = y, 2 = z (contiguous rows are
fast in numpy). Dot products add x, y, z in that order, as the tutorial's ``operator*``."""

from __future__ import annotations

import numpy as np


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def normalized(v: np.ndarray) -> np.ndarray:
    """v * (1 / sqrt(v.v)) (the tutorial multiplies by the inverse length)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return v * (1.0 / np.sqrt(dot(v, v)))


def column(t) -> np.ndarray:
    """A 3-tuple as a (3, 1) column that broadcasts against (3, N)."""
    return np.asarray(t, dtype=np.float64).reshape(3, 1)
