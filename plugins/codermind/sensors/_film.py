"""Helpers shared by this package's sensors: where a film sample lies on the film (with
the optional fixed position inside each pixel), the check of the camera-to-world transform,
the camera's origin. Their parameters are read by :mod:`codermind.params`."""

from __future__ import annotations


import drjit as dr
import mitsuba as mi
import numpy as np


class FilmMap:
    """Maps the sensor's ``sample2`` (position on the crop window, in [0, 1]^2) to the
    position on the whole film, in [0, 1]^2 (x right, y down).

    With a fixed ``pixel_offset`` the sample's pixel is ``floor(sample2 * crop_size)``
    and the position inside it is replaced by the offset, so every sample of a pixel
    goes through the same point of it. The integrator computes ``sample2`` as
    ``(pixel + jitter) / size`` in float32: for a jitter within about one float ulp of 1
    the pixel is ambiguous (``pixel + jitter`` rounds to ``pixel + 1``), so a fraction of
    about 5e-5 of randomly jittered samples goes through the neighbour pixel's point.
    A sampler without jitter (``stratified`` with ``jitter`` false) has none.
    """

    def __init__(self, film: mi.Film, offset: tuple[float, float] | None, plugin: str):
        self.size = mi.ScalarVector2f(film.size())
        self.crop_size = mi.ScalarVector2f(film.crop_size())
        self.crop_offset = mi.ScalarVector2f(film.crop_offset())
        self.offset = offset
        if offset is not None and not film.rfilter().is_box_filter():
            mi.Log(mi.LogLevel.Warn,
                   f"{plugin}: a fixed pixel offset is meant for a box reconstruction "
                   f"filter; other filters splat each sample at its jittered position")

    def __call__(self, sample2: mi.Point2f) -> mi.Point2f:
        p = mi.Point2f(sample2) * self.crop_size
        if self.offset is not None:
            # One ulp down: (pixel + jitter) / size * size tends to round up.
            pixel = dr.clip(dr.floor(p * (1.0 - 2.0**-23)), 0.0, self.crop_size - 1.0)
            p = pixel + mi.Vector2f(self.offset[0], self.offset[1])
        return (p + self.crop_offset) / self.size


def check_rigid(matrix: np.ndarray, plugin: str) -> None:
    """Reject a to_world whose 3x3 part is not orthonormal (rotations and reflections pass;
    a reflection is how the tutorial's left-handed frame is expressed)."""
    linear = matrix[:3, :3]
    if not np.allclose(linear.T @ linear, np.eye(3), atol=1e-4):
        raise ValueError(f"{plugin}: 'to_world' must be a rotation or reflection plus a "
                         f"translation (no scale or shear)")


def origin_of(transform) -> mi.ScalarPoint3f:
    """The scalar world position of a camera-to-world transform's origin."""
    p = transform @ mi.Point3f(0.0)
    return mi.ScalarPoint3f([float(dr.slice(c)) if dr.is_jit_v(c) else float(c) for c in p])
