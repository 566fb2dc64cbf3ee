"""The one exception type for user-facing errors of the Mitsuba side, and how a (Mitsuba)
error message is put on one line."""

from __future__ import annotations

import re


class CodermindError(Exception):
    """A user error (bad file, bad parameter). The CLI prints it in one line, exit 2."""


_PREFIX = re.compile(r"^\[[\w.]+:\d+\]\s*")
_UNREFERENCED = re.compile(
    r'While loading (?P<file>.+?) \(line (?P<line>\d+), col (?P<col>\d+)\): Found \d+ unreferenced '
    r'propert(?:y|ies) in (?P<kind>\w+) plugin of type "(?P<type>[^"]+)":\s*-\s*\w+ "(?P<name>[^"]+)"')


# A Python traceback that Mitsuba embeds when a Python plugin's constructor raises: keep
# only the exception line that follows it (e.g. "ValueError: tutorial: 'power' ...").
_TRACEBACK = re.compile(r"Traceback \(most recent call last\):\n(?:[ \t]+.*\n)*")


def raised_inside(error: BaseException) -> BaseException:
    """The error that a plugin raised inside a render. Dr.Jit reports an exception raised
    in a custom differentiable operation (``mi.render``) or a symbolic loop as a
    RuntimeError that says "(see above)" and chains the original as its ``__cause__``."""
    while error.__cause__ is not None and "see above" in str(error):
        error = error.__cause__
    return error


def one_line(message: str) -> str:
    """Condense a (possibly multi-line, Mitsuba-prefixed) error message into one line."""
    message = _TRACEBACK.sub("", str(message).strip())
    m = _UNREFERENCED.search(message)
    if m:
        return (f'{m["file"]}:{m["line"]}:{m["col"]}: unknown parameter "{m["name"]}" '
                f'for {m["kind"]} plugin "{m["type"]}"')
    lines = [_PREFIX.sub("", line).strip() for line in message.splitlines()]
    return "; ".join(line for line in lines if line)
