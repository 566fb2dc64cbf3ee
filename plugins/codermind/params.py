"""Typed reading of plugin parameters, the one home of the parameter readers of every plugin:
each error is a ValueError whose message starts with ``<plugin>: '<parameter>'``, so that
Mitsuba's one-line error names the parameter whatever the user passed (a string or a boolean
for a number, ...). Nothing here is variant-specific: ``mi.*`` types are looked up at call
time, in the variant that is active."""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np

#: Largest finite float32 and smallest normal one: the plugins compute in float32, so a
#: parameter beyond (or a positive one below) these would become inf (or 0) in their kernels.
FLOAT32_MAX = 3.4028234663852886e38
FLOAT32_MIN_NORMAL = 1.1754943508222875e-38


def float32(value: float) -> float:
    """``value`` rounded to float32 (what ``mi.traverse`` hands out for a parameter), as a
    Python float; beyond the float32 range, +-inf. A plugin that keeps a parameter in
    this form computes the same from the scene's value as from the one written back."""
    with np.errstate(over="ignore"):
        return float(np.float32(value))


def number(props, plugin: str, name: str, default: float | None = None) -> float:
    """A number (int or float, not bool); ``default`` when absent (None: required)."""
    if name not in props:
        if default is None:
            raise ValueError(f"{plugin}: '{name}' is required")
        return float(default)
    value = props.get(name)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{plugin}: '{name}' must be a number, got {value!r}")
    return float(value)


def flag(props, plugin: str, name: str, default: bool) -> bool:
    """A boolean (``<boolean>`` in XML)."""
    value = props.get(name, default)
    if not isinstance(value, bool):
        raise ValueError(f"{plugin}: '{name}' must be a boolean (true or false), got {value!r}")
    return value


def loose_number(props: mi.Properties, plugin: str, name: str, default=None):
    """What ``float()`` reads (a number, or a string or boolean that reads as one);
    ``default`` when absent. The ``blob`` shape's reader, looser than :func:`number`."""
    if name not in props:
        return default
    try:
        return float(props.get(name))
    except (TypeError, ValueError):
        raise ValueError(f"{plugin}: '{name}' must be a number") from None


# -- bounded numbers, textures, colours (BSDFs, textures) ------------------------------------

def bounds_text(lo: float | None = None, hi: float | None = None,
                open_lo: bool = False) -> str:
    """The bounds of :func:`check_float` in words: ``in [0, 1]``, ``> 0``, ``>= 0``, ..."""
    if lo is not None and hi is not None:
        return f"in {'(' if open_lo else '['}{lo:g}, {hi:g}]"
    if lo is not None:
        return f"{'>' if open_lo else '>='} {lo:g}"
    return "" if hi is None else f"<= {hi:g}"


def check_float(plugin: str, name: str, value: float, lo: float | None = None,
                hi: float | None = None, open_lo: bool = False) -> float:
    """The one bounds check of a float parameter, whether it comes from the scene
    (:func:`read_float`, :func:`positive_float`) or from ``mi.traverse``
    (:func:`codermind.exposed.take_float`): finite in float32 (the plugins compute in
    float32) and in [lo, hi] ((lo, hi] with ``open_lo``; either bound optional). Else a
    ValueError, one line: ``<plugin>: '<name>' must be finite in float32 and in [0, 1],
    got 2``."""
    value = float(value)
    ok = math.isfinite(value) and abs(value) <= FLOAT32_MAX and \
        (lo is None or (value > lo if open_lo else value >= lo)) and \
        (hi is None or value <= hi)
    if not ok:
        bounds = bounds_text(lo, hi, open_lo)
        raise ValueError(f"{plugin}: '{name}' must be finite in float32"
                         f"{' and ' + bounds if bounds else ''}, got {value:g}")
    return value


def read_float(props: mi.Properties, plugin: str, name: str, default: float,
               lo: float | None = None, hi: float | None = None,
               open_lo: bool = False) -> float:
    """A number checked by :func:`check_float`; ``default`` when absent."""
    return check_float(plugin, name, number(props, plugin, name, default), lo, hi, open_lo)


def uniform_rgb(texture: mi.Texture) -> list[float] | None:
    """The RGB value of a texture that does not vary over space, else None."""
    if texture.is_spatially_varying():
        return None
    si = mi.SurfaceInteraction3f() if not dr.is_jit_v(mi.Float) else \
        dr.zeros(mi.SurfaceInteraction3f)
    try:
        value = texture.eval_3(si)
    except Exception:  # a texture without eval_3: nothing to check
        return None
    return [float(dr.slice(c)) if dr.is_jit_v(mi.Float) else float(c) for c in value]


def read_texture(props: mi.Properties, plugin: str, name: str, default: float,
                 unbounded: bool = False) -> mi.Texture:
    """A texture parameter; a uniform one must be finite and >= 0 in every channel. ``unbounded``
    accepts RGB values above 1 (Mitsuba rejects them for reflectances otherwise)."""
    try:
        texture = props.get_unbounded_texture(name, default) if unbounded else \
            props.get_texture(name, default)
    except RuntimeError as e:       # e.g. Mitsuba's "Invalid RGB reflectance value ..."
        lines = str(e).strip().splitlines()
        raise ValueError(f"{plugin}: '{name}': {lines[-1] if lines else e}") from None
    value = uniform_rgb(texture)
    if value is not None and not all(math.isfinite(v) and v >= 0 for v in value):
        raise ValueError(f"{plugin}: '{name}' must be finite and >= 0 in every channel, "
                         f"got {value}")
    return texture


def positive_float(props: mi.Properties, plugin: str, name: str, default: float) -> float:
    """A number > 0, finite in float32 (:func:`check_float`)."""
    return read_float(props, plugin, name, default, lo=0.0, open_lo=True)


def finite_color(props: mi.Properties, plugin: str, name: str, default: float) -> mi.Texture:
    """An unbounded colour texture; a uniform one must be finite in every channel."""
    texture = props.get_unbounded_texture(name, default)
    value = uniform_rgb(texture)
    if value is not None and not all(math.isfinite(v) for v in value):
        raise ValueError(f"{plugin}: '{name}' must be finite, got {value}")
    return texture


def octave_count(props: mi.Properties, plugin: str, default: int = 9) -> int:
    value = props.get("octaves", default)
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 64:
        raise ValueError(f"{plugin}: 'octaves' must be an integer in [1, 64], got {value!r}")
    return value


# -- clip distances, pixel offset, field of view, placement (sensors) -------------------------

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
