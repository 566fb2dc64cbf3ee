"""Exposure, tone curve, sRGB, bytes and the calibration strip (facts.md F2, F6).

Page 1: byte = min(255 c, 255) truncated. Page 2: 1 - exp(-E c) per sub-sample (E = 1), mean of
the 4, sRGB, bytes. Page 4: E c per sub-sample with the auto exposure E, the tone curve, mean of
the 4, sRGB, bytes. Byte conversion truncates toward zero and, as an x86 float-to-unsigned-char
cast does, keeps the low 8 bits of the integer (negative values, not met in the tutorial's
scenes, wrap; NaN gives 0).
"""

from __future__ import annotations

import math

import numpy as np

from .scene import Tonemap

LUMINANCE = (0.2126, 0.715160, 0.072169)


def curve(c: np.ndarray, tm: Tonemap) -> np.ndarray:
    """Page-4 tone curve of exposed radiance c (maps n = -ln(1 - Midpoint) to Midpoint).

    Where c^P overflows (c >= 1e103 for P = 3, 1e31 for P = 10, and c = inf) the formula's
    inf / inf would give NaN, a black pixel; there the same quotient is evaluated as
    S c / (1 + Black / c^(P-1)), which tends to the curve's limit 1 (white). facts.md F6.2 does
    not say in which precision the original computed the curve, so where it overflowed is unknown;
    no tutorial scene comes near.
    """
    if tm.black > 0:
        p = tm.power
        n = -math.log(1.0 - tm.midpoint)
        s = -(1.0 + tm.black / n ** (p - 1.0))
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            out = 1.0 - np.exp(s * c ** p / (tm.black + c ** (p - 1.0)))
            overflow = np.isnan(out) & (c > 0)
            if np.any(overflow):
                big = np.where(overflow, c, 1.0)
                out = np.where(overflow, 1.0 - np.exp(s * big / (1.0 + tm.black / big ** (p - 1.0))),
                               out)
        return out
    return 1.0 - np.exp(-c)


def exposure_from_probes(luminance: np.ndarray, midpoint: float) -> float:
    """E = -ln(1 - Midpoint) / sqrt(mean L^2); -1 if that mean is 0 (as the original)."""
    m = math.sqrt(float(np.mean(np.asarray(luminance, dtype=np.float64) ** 2)))
    return -math.log(1.0 - midpoint) / m if m > 0 else -1.0


def luminance(c: np.ndarray) -> np.ndarray:
    """0.2126 R + 0.715160 G + 0.072169 B of colours (3, ...)."""
    return LUMINANCE[0] * c[0] + LUMINANCE[1] * c[1] + LUMINANCE[2] * c[2]


def srgb(v: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(np.maximum(v, 0.0031308),
                                                                    1.0 / 2.4) - 0.055)


def to_bytes(v: np.ndarray) -> np.ndarray:
    """(unsigned char) min(v * 255, 255)."""
    scaled = np.minimum(v * 255.0, 255.0)   # NaN stays NaN, as std::min(NaN, 255) does
    # outside the int32 range (and NaN) the x86 conversion gives 0x80000000: low byte 0
    ints = np.trunc(np.where(scaled >= -2.0 ** 31, scaled, 0.0)).astype(np.int64)
    return (ints & 0xFF).astype(np.uint8)


def strip(ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """Calibration pattern (len(ys), len(xs)) bytes for rows y < 10: grey 186 where floor(x/10)
    is odd, else 255 on odd rows and 0 on even rows."""
    y, x = np.meshgrid(ys, xs, indexing="ij")
    return np.where((x // 10) % 2 == 1, 186, np.where(y % 2 == 1, 255, 0)).astype(np.uint8)
