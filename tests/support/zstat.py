"""Two-sample per-pixel z-test of renders made with Mitsuba's ``moment`` integrator.

``mitsuba.testing.RenderingRegressionTest`` compares against reference files on disk,
treats the reference as exact and passes with 2.5 % of pixels failing; in 3.9.1 it also
reads the moment integrator's channels 3:6 (the first moment, in XYZ) as the second
moment. Here two independent renders are compared, every pixel and channel must pass,
and the significance level is Sidak-corrected over all of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def render_moments(mi, scene, spp: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel mean and variance of the mean (XYZ) of a scene whose integrator is
    ``moment`` around exactly one integrator."""
    img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
    m1, m2 = img[..., 3:6], img[..., 6:9]
    return m1, np.maximum(m2 - m1 * m1, 0.0) / spp


@dataclass
class ZTest:
    passed: bool
    min_p: float
    alpha: float      #: per-test significance after the Sidak correction
    worst: tuple      #: index of the smallest p-value

    def __str__(self) -> str:
        return (f"min p-value {self.min_p:.3g} at {self.worst} vs Sidak-corrected "
                f"alpha {self.alpha:.3g}")


def two_sample(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
               significance: float = 0.01) -> ZTest:
    """Null hypothesis: both renders have the same expected value in every pixel."""
    (ma, va), (mb, vb) = a, b
    # Float rounding allowance, so that noiseless pixels compare equal to float precision.
    se2 = va + vb + (1e-5 * (np.abs(ma) + np.abs(mb))) ** 2 + 1e-30
    z = np.abs(ma - mb) / np.sqrt(se2)
    p = np.vectorize(lambda x: math.erfc(x / math.sqrt(2.0)))(z)
    alpha = 1.0 - (1.0 - significance) ** (1.0 / p.size)
    worst = np.unravel_index(np.argmin(p), p.shape)
    return ZTest(bool(p.min() > alpha), float(p.min()), alpha, tuple(int(i) for i in worst))


def renders(images) -> tuple[np.ndarray, np.ndarray, int]:
    """Per-pixel mean, variance of that mean and count of K independent renders
    (``images``: K arrays of one shape, each rendered with its own seed)."""
    stack = np.asarray(images, dtype=np.float64)
    k = stack.shape[0]
    return stack.mean(axis=0), stack.var(axis=0, ddof=1) / k, k


def t_test(a: tuple[np.ndarray, np.ndarray, int], b: tuple[np.ndarray, np.ndarray, int],
           significance: float = 1e-3) -> ZTest:
    """Null hypothesis: both sides (each :func:`renders` of K independent renders) have the
    same expected value in every pixel and channel. Per value, the two-sample statistic
    ``(mean_a - mean_b) / sqrt(var_a + var_b)`` with each side's variance estimated from its
    own renders, referred to Student's t with ``min(K_a, K_b) - 1`` degrees of freedom
    (Hsu's rule: conservative for any ratio of the two variances when render means are
    normal; Welch's degrees of freedom reject up to 3x too often at the per-value levels
    used here, measured with K = 8), Sidak-corrected over every value, so that the chance
    of any rejection when both sides agree is at most ``significance``. A float-rounding
    allowance (1e-5 relative, taken as known) keeps noiseless values that agree to float
    precision from failing."""
    from scipy.stats import t as student
    (ma, va, ka), (mb, vb, kb) = a, b
    se2 = va + vb + (1e-5 * (np.abs(ma) + np.abs(mb))) ** 2 + 1e-30
    p = 2.0 * student.sf(np.abs(ma - mb) / np.sqrt(se2), min(ka, kb) - 1)
    alpha = 1.0 - (1.0 - significance) ** (1.0 / p.size)
    worst = np.unravel_index(np.argmin(p), p.shape)
    return ZTest(bool(p.min() > alpha), float(p.min()), alpha, tuple(int(i) for i in worst))
