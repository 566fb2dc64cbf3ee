"""Mitsuba for the sweeps: a variant with this package's plugins registered."""

from __future__ import annotations


def variant(name: str = "llvm_ad_rgb"):
    """Set ``name`` (raising CodermindError with the reason if it cannot run), register the
    plugins and return the ``mitsuba`` module."""
    from codermind.variants import set_variant
    set_variant(name)
    import codermind  # noqa: F401  (registers the plugins)
    import mitsuba as mi
    return mi


def load_error(mi, spec: dict) -> str | None:
    """The one-line message of the error ``mi.load_dict(spec)`` raises, or None if it loads."""
    from codermind.errors import one_line
    try:
        mi.load_dict(spec)
    except Exception as e:      # Mitsuba wraps a plugin's ValueError in a RuntimeError
        return f"{type(e).__name__}: {one_line(str(e))}"
    return None
