"""Typed reading of plugin parameters, shared by the plugins: every error is a ValueError
whose message starts with ``<plugin>: '<parameter>'``, so that Mitsuba's one-line error
names the parameter whatever the user passed (a string or a boolean for a number, ...)."""

from __future__ import annotations

#: Largest finite float32 and smallest normal one: the plugins compute in float32, so a
#: parameter beyond (or a positive one below) these would become inf (or 0) in their kernels.
FLOAT32_MAX = 3.4028234663852886e38
FLOAT32_MIN_NORMAL = 1.1754943508222875e-38


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
