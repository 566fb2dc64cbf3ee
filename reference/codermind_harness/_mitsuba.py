"""Mitsuba for the sweeps: the one-line message of a plugin that refuses its parameters.
(The variant is set with :func:`codermind.variants.set_variant`.)"""

from __future__ import annotations


def load_error(mi, spec: dict) -> str | None:
    """The one-line message of the error ``mi.load_dict(spec)`` raises, or None if it loads."""
    from codermind.errors import one_line
    try:
        mi.load_dict(spec)
    except Exception as e:      # Mitsuba wraps a plugin's ValueError in a RuntimeError
        return f"{type(e).__name__}: {one_line(str(e))}"
    return None
