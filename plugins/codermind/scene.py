"""Loading Mitsuba scenes with errors a user can act on."""

from __future__ import annotations

import os
from pathlib import Path

import mitsuba as mi

from .errors import CodermindError


def load_scene(path: str | os.PathLike, **params) -> mi.Scene:
    """``mi.load_file`` with Mitsuba's exceptions turned into CodermindError.

    The message keeps Mitsuba's file, line and parameter information.
    """
    path = Path(path)
    if not path.is_file():
        raise CodermindError(f"{path}: no such scene file")
    try:
        scene = mi.load_file(str(path), **params)
    except (RuntimeError, ValueError, TypeError) as e:
        message = str(e)
        if "no probability mass" in message:
            message += (" (every emitter has sampling_weight 0, e.g. the only emitter is a "
                        "background-mode cubemap: give it sampling_weight 1)")
        from .xmlwhere import locate
        raise CodermindError(locate(path, message)) from None
    attach_emitters(scene)
    return scene


def attach_emitters(scene: mi.Scene) -> None:
    """Give Python emitters that need it the loaded scene (Mitsuba's ``set_scene`` is not
    forwarded to Python plugins), e.g. the bounding sphere of ``cubemap``."""
    for emitter in scene.emitters():
        attach = getattr(emitter, "attach_scene", None)
        if callable(attach):
            attach(scene)


def non_finite_parameters(scene: mi.Scene) -> list[str]:
    """The scene's parameters (``mi.traverse`` keys) that hold a NaN or an infinity: such a
    value makes every pixel it reaches NaN, so a render would only waste its time."""
    import numpy as np
    params = mi.traverse(scene)
    bad = []
    for key in params.keys():
        try:
            value = np.asarray(params[key], dtype=np.float64)
        except (TypeError, ValueError):         # strings, objects
            continue
        if value.size and not np.isfinite(value).all():
            first = value.ravel()[~np.isfinite(value.ravel())][0]
            owner, _, rest = key.partition(".")
            if owner.startswith("object_") and rest:    # a plugin without an id
                key = f"'{rest}' of a plugin without an id"
            else:
                key = f"'{key}'"
            bad.append(f"{key} ({first:g})")
    return bad
