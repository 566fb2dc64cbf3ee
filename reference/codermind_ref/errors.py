"""The port's one exception type for bad scene files (it never imports ``codermind``)."""

from __future__ import annotations

import os


class SceneError(Exception):
    """A scene file the tutorial programs would reject. ``str(e)`` is ``"file:line: message"``.

    Attributes: ``path`` (as given to :func:`codermind_ref.parse_scene`), ``line`` (1-based)
    and ``message`` (without the location).
    """

    def __init__(self, path: str | os.PathLike, line: int, message: str):
        self.path, self.line, self.message = str(path), int(line), message
        super().__init__(f"{self.path}:{self.line}: {message}")
