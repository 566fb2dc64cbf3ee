"""The tutorial scene syntax (facts.md F1.1): ``Name { Key = value; ... }`` with ``//`` comments.

Every line is cut at its first ``//``, then spaces, tabs, CR and LF are removed everywhere and
the file becomes one string; a map from each remaining character to its source line is kept
so that errors and warnings can name the line. The result is a dict of :class:`Section`, each
holding its :class:`Entry` items (the first of a repeated key wins, as in the original).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

from .errors import SceneError

_WHITESPACE = str.maketrans("", "", " \t\r\n")


@dataclass
class Entry:
    """``key = value;`` as written (whitespace removed), with the line where the key starts."""
    key: str
    value: str
    line: int


@dataclass
class Section:
    """``name { ... }``: its entries by key (first occurrence) and the line of its name."""
    name: str
    line: int
    entries: dict[str, Entry] = field(default_factory=dict)

    def line_of(self, key: str) -> int:
        """Line of ``key`` if present, else the section's own line."""
        entry = self.entries.get(key)
        return entry.line if entry else self.line


def strip(text: str) -> tuple[str, list[int]]:
    """Remove comments and whitespace; return the string and each character's line (1-based)."""
    chars: list[str] = []
    lines: list[int] = []
    for number, line in enumerate(text.split("\n"), start=1):
        cut = line.find("//")
        kept = (line if cut < 0 else line[:cut]).translate(_WHITESPACE)
        chars.append(kept)
        lines.extend([number] * len(kept))
    return "".join(chars), lines


class _Reader:
    def __init__(self, path: str | os.PathLike, text: str):
        self.path = str(path)
        self.s, self.lines = strip(text)
        self.last_line = max(1, text.count("\n") + (0 if text.endswith("\n") else 1))
        self.warnings: list[str] = []

    def line(self, pos: int) -> int:
        return self.lines[pos] if pos < len(self.lines) else self.last_line

    def error(self, pos_or_line: int, message: str, *, is_line: bool = False) -> SceneError:
        line = pos_or_line if is_line else self.line(pos_or_line)
        return SceneError(self.path, line, message)

    def warn(self, line: int, message: str) -> None:
        self.warnings.append(f"{self.path}:{line}: {message}")

    def sections(self) -> dict[str, Section]:
        s, pos, out = self.s, 0, {}
        while pos < len(s):
            brace = s.find("{", pos)
            stop = min((i for i in (s.find(c, pos) for c in ";=}") if i >= 0), default=-1)
            if brace < 0 or (0 <= stop < brace):
                bad = s[pos:(stop + 1 if stop >= 0 else len(s))]
                raise self.error(pos, f"expected 'Name {{ ... }}' at top level, found '{bad[:40]}'")
            name = s[pos:brace]
            if not name:
                raise self.error(brace, "'{' without a section name")
            section = Section(name, self.line(pos))
            pos = self._body(section, brace + 1)
            if name in out:
                raise self.error(section.line, f"duplicate section '{name}' (first at line "
                                 f"{out[name].line}); the whole file is rejected", is_line=True)
            out[name] = section
        return out

    def _next(self, pos: int, chars: str) -> int:
        found = [i for i in (self.s.find(c, pos) for c in chars) if i >= 0]
        return min(found) if found else -1

    def _body(self, section: Section, pos: int) -> int:
        s = self.s
        while True:
            if pos >= len(s):
                raise self.error(section.line, f"section '{section.name}' is not closed "
                                 "(missing '}')", is_line=True)
            if s[pos] == "}":
                return pos + 1
            k = self._next(pos, "={};")
            if k < 0:
                raise self.error(pos, f"section '{section.name}' is not closed (missing '}}')")
            c = s[k]
            if c == "{":
                pos = self._skip_nested(section, pos, k)
                continue
            if c != "=":
                raise self.error(pos, f"expected 'Key = value;' in section '{section.name}', "
                                 f"found '{s[pos:k + 1]}'")
            key = s[pos:k]
            if not key:
                raise self.error(k, f"empty key before '=' in section '{section.name}'")
            end = self._next(k + 1, ";={}")
            if end < 0 or s[end] != ";":
                value = s[k + 1:end if end >= 0 else len(s)]
                raise self.error(pos, f"missing ';' after '{key} = {value}' in section "
                                 f"'{section.name}'")
            value = s[k + 1:end]
            if not value:
                raise self.error(pos, f"empty value for '{key}' in section '{section.name}'")
            entry = Entry(key, value, self.line(pos))
            first = section.entries.setdefault(key, entry)
            if first is not entry:
                self.warn(entry.line, f"'{key}' repeated in section '{section.name}'; the "
                          f"first value (line {first.line}) is used")
            pos = end + 1

    def _skip_nested(self, section: Section, start: int, brace: int) -> int:
        depth, pos = 1, brace + 1
        while depth:
            nxt = self._next(pos, "{}")
            if nxt < 0:
                raise self.error(start, f"block '{self.s[start:brace]}' in section "
                                 f"'{section.name}' is not closed (missing '}}')")
            depth += 1 if self.s[nxt] == "{" else -1
            pos = nxt + 1
        self.warn(self.line(start), f"nested block '{self.s[start:brace]}' in section "
                  f"'{section.name}' is not supported (the original mangles its keys); ignored")
        return pos


def read_sections(path: str | os.PathLike, text: str) -> tuple[dict[str, Section], list[str]]:
    """Parse ``text`` (the contents of ``path``) into sections; returns (sections, warnings).

    Raises :class:`SceneError` for syntax errors: text outside a section, a missing ``;`` or
    ``}``, an empty key or value, or a duplicate section name.
    """
    reader = _Reader(path, text)
    return reader.sections(), reader.warnings
