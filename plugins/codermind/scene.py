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
        return mi.load_file(str(path), **params)
    except (RuntimeError, ValueError, TypeError) as e:
        raise CodermindError(str(e)) from None
