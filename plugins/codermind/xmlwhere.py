"""Where in a Mitsuba XML file a load error lies, for the errors whose message names neither
file nor line (Mitsuba's for a property given twice, an invalid version number, or bytes
that are not UTF-8, which even fail to reach Python as text): :func:`locate` scans the file
with expat and returns ``FILE:LINE: message``."""

from __future__ import annotations

import os
import re
import xml.parsers.expat
from pathlib import Path

_LOADING = re.compile(r'^(\[[\w.]+:\d+\]\s*)?(Error while loading XML file "[^"]*":\s*)?')


def _bad_utf8(data: bytes) -> tuple[int, str] | None:
    for number, line in enumerate(data.split(b"\n"), start=1):
        try:
            line.decode("utf-8")
        except UnicodeDecodeError as e:
            return number, (f"not valid UTF-8 (byte 0x{line[e.start]:02x} at column "
                            f"{e.start + 1}); save the file as UTF-8")
    return None


def _scan(data: bytes, message: str) -> tuple[int, str] | None:
    """(line, what) of the first repeated property or of the version attribute."""
    parser = xml.parsers.expat.ParserCreate()
    stack: list[dict[str, int]] = []
    found: list[tuple[int, str]] = []

    def start(tag, attrs):
        line = parser.CurrentLineNumber
        if not stack and "version" in attrs and "version" in message:
            found.append((line, f"version=\"{attrs['version']}\""))
        name = attrs.get("name")
        if stack and name is not None and not found:
            if name in stack[-1]:
                found.append((line, f"'{name}' given again (first at line {stack[-1][name]})"))
            stack[-1].setdefault(name, line)
        stack.append({})

    def end(tag):
        stack.pop()

    parser.StartElementHandler, parser.EndElementHandler = start, end
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as e:
        return e.lineno, xml.parsers.expat.ErrorString(e.code)
    return found[0] if found else None


def locate(path: str | os.PathLike, message: str) -> str:
    """``message`` (Mitsuba's load error, or a decode error) as ``FILE:LINE: message`` when
    it does not say where already; ``FILE: message`` when no line can be found."""
    if "line" in message and str(Path(path).name) in message:
        return message                          # Mitsuba's own "(near line L, col C)"
    text = _LOADING.sub("", message).strip()
    try:
        data = Path(path).read_bytes()
    except OSError:
        return f"{path}: {text}"
    bad = _bad_utf8(data)
    if bad is not None:
        return f"{path}:{bad[0]}: {bad[1]}"
    where = _scan(data, message)
    if where is None:
        return f"{path}: {text}"
    line, what = where
    return f"{path}:{line}: {text} ({what})"
