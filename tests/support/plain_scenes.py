"""Ordinary Mitsuba scenes (no tutorial twin) for ``codermind compare --against`` and an
ordinary scene's ``--reference``: edited copies of the project's own scenes, written into a
test's folder (with the files they name next to them).

* :func:`default_copy`: ``scenes/default.xml`` (built-in plugins only: two spheres and a
  floor under a point light and a constant sky) at a small film size, its integrator or its
  point light's intensity changed;
* :func:`room_copy`: ``scenes/user/room.xml`` (the project's plugins: a closed room lit
  mostly by its ceiling panel), its integrator or its ceiling panel's radiance changed; its
  film size and samples are ``-D resx/resy/spp`` defaults."""

from __future__ import annotations

from pathlib import Path

from . import ROOT

DEFAULT = ROOT / "scenes" / "default.xml"
ROOM = ROOT / "scenes" / "user" / "room.xml"

_POINT = '<rgb name="intensity" value="40, 38, 34"/>'
_PANEL = '<rgb name="radiance" value="12, 11, 9"/>'


def _edit(text: str, old: str, new: str) -> str:
    assert text.count(old) == 1, old
    return text.replace(old, new)


def _scaled(values: tuple, scale: float) -> str:
    return ", ".join(f"{v * scale:.6g}" for v in values)


def default_copy(folder: Path, name: str, width: int = 64, height: int = 48,
                 integrator: str = "path", light: float = 1.0) -> Path:
    """``scenes/default.xml`` as ``folder/name``: ``width`` x ``height``, ``integrator``,
    the point light's intensity times ``light``."""
    text = DEFAULT.read_text(encoding="utf-8")
    text = _edit(text, '<integer name="width" value="320"/>',
                 f'<integer name="width" value="{width}"/>')
    text = _edit(text, '<integer name="height" value="240"/>',
                 f'<integer name="height" value="{height}"/>')
    text = _edit(text, '<integrator type="path">', f'<integrator type="{integrator}">')
    if light != 1.0:
        text = _edit(text, _POINT, f'<rgb name="intensity" value="{_scaled((40, 38, 34), light)}"/>')
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(text, encoding="utf-8")
    return folder / name


def room_copy(folder: Path, name: str, integrator: str = "path", light: float = 1.0) -> Path:
    """``scenes/user/room.xml`` as ``folder/name``: ``integrator``, the ceiling panel's
    radiance times ``light``."""
    text = ROOM.read_text(encoding="utf-8")
    text = _edit(text, '<integrator type="path">', f'<integrator type="{integrator}">')
    if light != 1.0:
        text = _edit(text, _PANEL, f'<rgb name="radiance" value="{_scaled((12, 11, 9), light)}"/>')
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(text, encoding="utf-8")
    return folder / name
