"""Helpers shared by this package's sensors: where a film sample lies on the film (with
the optional fixed position inside each pixel), the field of view, and checks of the
camera-to-world transform, the clip distances."""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np

from codermind.params import FLOAT32_MAX, number


def read_clip(props: mi.Properties, plugin: str) -> tuple[float, float]:
    """``near_clip`` and ``far_clip`` (defaults 0.01, 10000): 0 <= near < far, near finite
    in float32 (far may be infinite)."""
    near, far = number(props, plugin, "near_clip", 1e-2), number(props, plugin, "far_clip", 1e4)
    if not near <= FLOAT32_MAX:
        raise ValueError(f"{plugin}: 'near_clip' must be finite in float32, got {near:g}")
    if not 0.0 <= near < far:
        raise ValueError(f"{plugin}: need 0 <= 'near_clip' < 'far_clip', got {near:g} and "
                         f"{far:g}")
    return near, far


def read_pixel_offset(props: mi.Properties, plugin: str) -> tuple[float, float] | None:
    """``pixel_offset_x``/``pixel_offset_y``: a fixed position inside each film pixel, in
    pixels from its top-left corner (x right, y down, as film rows), or None (jitter)."""
    given = [k for k in ("pixel_offset_x", "pixel_offset_y") if k in props]
    if not given:
        return None
    if len(given) == 1:
        raise ValueError(f"{plugin}: give both 'pixel_offset_x' and 'pixel_offset_y' "
                         f"(only '{given[0]}' was given)")
    offset = (number(props, plugin, "pixel_offset_x"), number(props, plugin, "pixel_offset_y"))
    for name, value in zip(("pixel_offset_x", "pixel_offset_y"), offset):
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"{plugin}: '{name}' must be in [0, 1] (pixels), got {value:g}")
    return offset


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


def x_fov(props: mi.Properties, aspect: float, plugin: str) -> float:
    """Horizontal field of view in degrees from ``fov``/``fov_axis`` or ``focal_length``,
    with Mitsuba's conventions (``aspect`` = width / height)."""
    if "fov" in props and "focal_length" in props:
        raise ValueError(f"{plugin}: give either 'fov' or 'focal_length', not both")
    if "fov" in props:
        fov = number(props, plugin, "fov")
        axis = str(props.get("fov_axis", "x")).lower()
        if not 0.0 < fov < 180.0:
            raise ValueError(f"{plugin}: 'fov' must be in (0, 180) degrees, got {fov:g}")
        if axis == "smaller":
            axis = "y" if aspect > 1 else "x"
        elif axis == "larger":
            axis = "x" if aspect > 1 else "y"
    else:
        text = str(props.get("focal_length", "50mm"))
        try:
            length = float(text[:-2] if text.endswith("mm") else text)
        except ValueError:
            raise ValueError(f"{plugin}: 'focal_length' must look like '50mm', got "
                             f"{text!r}") from None
        if not length > 0:
            raise ValueError(f"{plugin}: 'focal_length' must be > 0, got {text!r}")
        fov = 2.0 * math.degrees(math.atan(math.hypot(36.0, 24.0) / (2.0 * length)))
        axis = "diagonal"
    half_tan = math.tan(math.radians(0.5 * fov))
    if axis == "x":
        return fov
    if axis == "y":
        return 2.0 * math.degrees(math.atan(half_tan * aspect))
    if axis == "diagonal":
        return 2.0 * math.degrees(math.atan(half_tan / math.sqrt(1.0 + 1.0 / aspect**2)))
    raise ValueError(f"{plugin}: 'fov_axis' must be one of x, y, diagonal, smaller, larger; "
                     f"got {axis!r}")


def to_world_matrix(props: mi.Properties) -> np.ndarray:
    """The scalar 4x4 matrix of ``to_world`` (identity if absent)."""
    if "to_world" not in props:
        return np.eye(4)
    return np.array(props.get("to_world").matrix, dtype=np.float64).reshape(4, 4)


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
