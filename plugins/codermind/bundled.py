"""Where the bundled scenes (``scenes/`` of the repository) are: in a checkout or an
editable install, the repository's folder; after ``pip install`` of the wheel, the copy
installed as data files under ``<prefix>/share/codermind/scenes``. The environment
variable ``CODERMIND_SCENES`` (or ``codermind chart --scenes``) overrides both."""

from __future__ import annotations

import os
import sys
import sysconfig
from pathlib import Path

from .errors import CodermindError

#: A file every copy of the bundled scenes has.
_MARKER = "page1.xml"


def _candidates() -> list[Path]:
    env = os.environ.get("CODERMIND_SCENES")
    if env:
        return [Path(env)]
    here = Path(__file__).resolve()
    found = [here.parents[2] / "scenes"]            # repository: plugins/codermind/...
    for prefix in (sysconfig.get_path("data"), sys.prefix, sys.base_prefix):
        found.append(Path(prefix) / "share" / "codermind" / "scenes")
    return found


def scenes_dir() -> Path:
    """The folder of the bundled scenes; CodermindError if there is none."""
    candidates = _candidates()
    for path in candidates:
        if (path / _MARKER).is_file():
            return path
    raise CodermindError(
        "the bundled scenes were not found (looked in "
        + ", ".join(str(p) for p in dict.fromkeys(candidates))
        + "): set CODERMIND_SCENES to the repository's scenes/ folder")


def bundled_scene(name: str) -> Path | None:
    """``page4`` or ``page4.xml`` as a bundled scene file, or None."""
    if os.sep in name or (os.altsep and os.altsep in name):
        return None
    try:
        folder = scenes_dir()
    except CodermindError:
        return None
    for candidate in (folder / name, folder / f"{name}.xml"):
        if candidate.is_file():
            return candidate
    return None
