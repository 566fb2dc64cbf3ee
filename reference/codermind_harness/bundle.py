"""A Mitsuba XML and the files it names, as bytes: what a process without this machine's
files (a Dask worker, a pool process) needs to load the scene. There is no shared
filesystem: the bundle travels with the task and is written once per process into a
private folder.

Only files inside the scene's folder travel (or inside a folder the user allows,
``--allow-files DIR``): a scene that names ``/etc/shadow`` as a cube face is refused in one
line naming its file and line (:class:`OutsideError`), before anything is sent.
"""

from __future__ import annotations

import atexit
import hashlib
import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

from codermind.errors import CodermindError

#: ``<string name="..." value="FILE"/>`` values that name a file next to the XML (cube-map
#: faces, bitmaps, meshes) travel with the bundle.
_STRING = re.compile(r'(<string\s+name="[^"]+"\s+value=")([^"]+)(")')

#: Per process: the folder each bundle (by digest) was written to.
_FOLDERS: dict[str, Path] = {}

ALLOW_OPTION = "--allow-files DIR"


class OutsideError(CodermindError):
    """A file that a scene names lies outside the folders allowed to travel to workers."""


def roots(folder: str | os.PathLike, allow: Iterable[str | os.PathLike] = ()) -> tuple:
    """The resolved folders whose files may travel: the scene's ``folder`` and ``allow``."""
    return tuple(Path(f).resolve() for f in (folder, *allow))


def check_inside(path: str | os.PathLike, allowed: tuple, where: str) -> None:
    """OutsideError unless ``path`` (links resolved) lies inside one of the ``allowed``
    folders; ``where``: the file and line that name it."""
    real = Path(path).resolve()
    if not any(real == r or r in real.parents for r in allowed):
        raise OutsideError(f"{where}: {path} is outside the scene's folder {allowed[0]}; files "
                           f"outside it do not travel to cluster workers ({ALLOW_OPTION} "
                           "allows another folder)")


@dataclass(frozen=True)
class Bundle:
    """A Mitsuba XML and the files it names, as bytes: what a worker needs to load it."""
    name: str                       #: the XML's file name
    text: str                       #: the XML, its file references renamed into ``inputs/``
    files: tuple                    #: ((relative name, bytes), ...)
    digest: str

    @classmethod
    def of(cls, xml: str | os.PathLike, allow: Iterable[str | os.PathLike] = ()) -> "Bundle":
        """``xml`` and the files it names, which must lie inside its folder or ``allow``."""
        xml = Path(xml)
        text = xml.read_text(encoding="utf-8")
        files: dict[Path, str] = {}
        allowed = roots(xml.parent, allow)

        def rename(m: re.Match) -> str:
            path = Path(m[2]) if Path(m[2]).is_absolute() else xml.parent / m[2]
            if not path.is_file():
                return m[0]
            check_inside(path, allowed, f"{xml}:{text.count(chr(10), 0, m.start()) + 1}")
            key = path.resolve()
            if key not in files:
                files[key] = f"inputs/{len(files)}-{path.name}"
            return m[1] + files[key] + m[3]

        text = _STRING.sub(rename, text)
        payload = tuple((name, path.read_bytes()) for path, name in files.items())
        h = hashlib.sha256(text.encode())
        for name, data in payload:
            h.update(name.encode() + b"\0" + data)
        return cls(xml.name, text, payload, h.hexdigest())

    def materialize(self) -> Path:
        """The XML written (once per process) into a private folder of this machine."""
        path = _FOLDERS.get(self.digest)
        if path is None:
            folder = Path(tempfile.mkdtemp(prefix="codermind-cluster-"))
            atexit.register(shutil.rmtree, folder, True)
            for name, data in self.files:
                (folder / name).parent.mkdir(parents=True, exist_ok=True)
                (folder / name).write_bytes(data)
            path = folder / self.name
            path.write_text(self.text, encoding="utf-8")
            _FOLDERS[self.digest] = path
        return path
