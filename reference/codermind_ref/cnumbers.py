"""C library number reading as the tutorial programs do it (``atof``, ``atol``, ``sscanf``).

``atof``/``atol`` read the longest numeric prefix and give 0 for garbage, so ``90.0f`` is 90.
Each ``read_*`` function returns the value the original program gets, plus a warning text
(or ``None``) when the text is not a clean number, so the parser can report it.
"""

from __future__ import annotations

import re

_DEC = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_HEX = re.compile(r"[+-]?0[xX](?:[0-9a-fA-F]+\.?[0-9a-fA-F]*|\.[0-9a-fA-F]+)(?:[pP][+-]?\d+)?")
_SPECIAL = re.compile(r"[+-]?(?:inf(?:inity)?|nan(?:\([0-9A-Za-z_]*\))?)", re.IGNORECASE)
_INT = re.compile(r"[+-]?\d+")
_LONG_MAX = 2**63 - 1


def strtod(text: str, pos: int = 0) -> tuple[float, int]:
    """``strtod`` on ``text[pos:]``: (value, end position); end == pos when nothing was read."""
    for pattern in (_HEX, _SPECIAL, _DEC):
        m = pattern.match(text, pos)
        if m:
            s = m.group()
            if pattern is _HEX:
                sign = -1.0 if s[0] == "-" else 1.0
                body = s.lstrip("+-")
                if "p" not in body.lower():
                    body += "p0"
                return sign * float.fromhex(body), m.end()
            if pattern is _SPECIAL:
                s = s.split("(")[0]
            return float(s), m.end()
    return 0.0, pos


def atof(text: str) -> tuple[float, str]:
    """``atof``: (value, unread rest)."""
    value, end = strtod(text)
    return value, text[end:]


def atol(text: str) -> tuple[int, str]:
    """``atol`` (glibc ``strtol``: saturates at the ``long`` range): (value, unread rest)."""
    m = _INT.match(text)
    if not m:
        return 0, text
    return max(-_LONG_MAX - 1, min(_LONG_MAX, int(m.group()))), text[m.end():]


def _clean_float_rest(text: str, rest: str) -> bool:
    # A C float suffix ("90.0f") is what scene authors write; accept it silently.
    return rest == "" or (rest in ("f", "F") and len(rest) < len(text))


def read_float(text: str) -> tuple[float, str | None]:
    value, rest = atof(text)
    if len(rest) == len(text):
        return 0.0, f"'{text}' is not a number; read as 0"
    if not _clean_float_rest(text, rest):
        return value, f"'{text}' is not a clean number; read as {value:g}"
    return value, None


def read_int(text: str) -> tuple[int, str | None]:
    value, rest = atol(text)
    if len(rest) == len(text):
        return 0, f"'{text}' is not an integer; read as 0"
    if rest:
        return value, f"'{text}' is not an integer; read as {value}"
    return value, None


def read_bool(text: str) -> tuple[bool, str | None]:
    if text == "true":
        return True, None
    if text == "false":
        return False, None
    return False, f"'{text}' is not 'true' (booleans are true only for exactly 'true'); read as false"


def _scan_triple(text: str) -> tuple[tuple[float, float, float] | None, str]:
    """``sscanf(text, "%f,%f,%f")``: the triple if all three were read, and the unread rest."""
    values, pos = [], 0
    for i in range(3):
        value, end = strtod(text, pos)
        if end == pos:
            return None, text[pos:]
        values.append(value)
        pos = end
        if i < 2:
            if pos >= len(text) or text[pos] != ",":
                return None, text[pos:]
            pos += 1
    return (values[0], values[1], values[2]), text[pos:]


def read_point(text: str) -> tuple[tuple[float, float, float], str | None]:
    """A point or vector: exactly three numbers, else the origin."""
    triple, rest = _scan_triple(text)
    if triple is None:
        return (0.0, 0.0, 0.0), f"'{text}' is not three numbers 'x,y,z'; read as the origin 0,0,0"
    if rest:
        return triple, f"'{text}': ignored '{rest}' after three numbers"
    return triple, None


def read_colour(text: str) -> tuple[tuple[float, float, float], str | None]:
    """A colour: a scalar s (meaning s,s,s) or an r,g,b triple; other text falls back to
    (atof(text),) * 3 as the original does."""
    scalar, rest = atof(text)
    triple, trest = _scan_triple(text)
    if triple is not None:
        if trest:
            return triple, f"'{text}': ignored '{trest}' after three numbers"
        return triple, None
    value = (scalar, scalar, scalar)
    if len(rest) == len(text):
        return (0.0, 0.0, 0.0), f"'{text}' is not a colour; read as 0"
    if not _clean_float_rest(text, rest):
        return value, f"'{text}' is neither a number nor 'r,g,b'; read as {scalar:g}"
    return value, None
