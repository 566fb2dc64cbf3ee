"""Mitsuba for the sweeps: the one-line message of a plugin that refuses its parameters.
(The variant is set with :func:`codermind.variants.set_variant`.)"""

from __future__ import annotations

import re

#: Mitsuba names the plugin's kind in this message ("sensor plugin") only in a process whose
#: plugins were registered again after a variant switch, "unknown plugin" before: the word is
#: dropped so that the message does not depend on what the process (a worker) ran before.
_KIND = re.compile(r"failed to instantiate \w+ plugin of type")


def load_error(mi, spec: dict) -> str | None:
    """The one-line message of the error ``mi.load_dict(spec)`` raises (without the plugin's
    kind, see :data:`_KIND`), or None if it loads."""
    from codermind.errors import one_line
    try:
        mi.load_dict(spec)
    except Exception as e:      # Mitsuba wraps a plugin's ValueError in a RuntimeError
        message = _KIND.sub("failed to instantiate plugin of type", one_line(str(e)))
        return f"{type(e).__name__}: {message}"
    return None
