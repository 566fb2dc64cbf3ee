"""Parameter reading and checking shared by this package's BSDFs. Every check raises a
ValueError whose message starts with ``<plugin>: '<parameter>'``."""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi

from ..params import FLOAT32_MAX, number


def read_float(props: mi.Properties, plugin: str, name: str, default: float,
               lo: float | None = None, hi: float | None = None) -> float:
    """A float in [lo, hi], finite in float32 (either bound optional)."""
    value = number(props, plugin, name, default)
    if not math.isfinite(value) or (lo is not None and value < lo) or \
            (hi is not None and value > hi):
        bounds = (f"in [{lo:g}, {hi:g}]" if hi is not None else f">= {lo:g}") \
            if lo is not None else f"<= {hi:g}"
        raise ValueError(f"{plugin}: '{name}' must be finite and {bounds}, got {value:g}")
    if abs(value) > FLOAT32_MAX:
        raise ValueError(f"{plugin}: '{name}' must be finite in float32 (at most "
                         f"{FLOAT32_MAX:.4g}), got {value:g}")
    return value


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
