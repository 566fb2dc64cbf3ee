"""The one exception type for user-facing errors of the Mitsuba side."""

from __future__ import annotations


class CodermindError(Exception):
    """A user error (bad file, bad parameter). The CLI prints it in one line, exit 2."""
