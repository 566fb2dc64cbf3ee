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
