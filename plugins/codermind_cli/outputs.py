"""Where a command writes: output names, checked before any work starts, and a set of files
replaced as one.

Names (``-o OUT``): OUT is kept whole and each file's extension appended (``-o run.v1``:
``run.v1.exr``, ``run.v1.png``, ...). An OUT that ends in one of the command's own
extensions drops it (``-o x.png``: ``x.exr``, ``x.png``, ...). An OUT that ends in ``/`` or
names an existing folder (``.`` included) means that folder, the files named after the scene.

Sets: the files of one render are written into a hidden staging folder beside them
(``.OUT.codermind-PID-XXXX``), then moved in, the previous files kept as hard links in the
staging folder until the new set is in place. ``OUT.manifest.json`` names the files of the set
with their SHA-256 and the command; it is removed first and moved in last, so a folder with
OUT files but no manifest, or files whose hashes differ from it, holds an incomplete set
(:func:`check_set`). An error or a signal before the manifest is in rolls the previous files
back; a staging folder left by a killed run (SIGKILL) is rolled back and removed, with a
one-line note, by the next command that writes into the same folder.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shlex
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Callable, Iterable, Mapping

from . import signals

MANIFEST = ".manifest.json"
#: Render and reference outputs: what an OUT may end in, dropped from it.
IMAGE_SUFFIXES = (".exr", ".png", ".tga")
#: A staging folder of :func:`write_set` or a temporary file of ``codermind.imageio.atomic_path``.
_LEFTOVER = re.compile(r"^\..+\.codermind-(?P<pid>\d+)-\w+(\.\w+)*$")


def _after_step(step: str) -> None:
    """Called after every file operation of :func:`write_set` (tests inject faults here)."""


def _refuse(message: str):
    from codermind.errors import CodermindError
    raise CodermindError(message)


def output_base(output: str | None, scene: Path, suffixes: Iterable[str] = IMAGE_SUFFIXES) -> Path:
    """OUT of ``-o OUT`` (see the module doc), before any check."""
    if output is None:
        return Path.cwd() / scene.stem
    if output.strip() == "":
        _refuse("-o: the output name is empty")
    path = Path(output)
    if output.endswith(("/", os.sep)) or path.is_dir():
        return path / scene.stem
    for suffix in sorted(suffixes, key=len, reverse=True):
        if output.lower().endswith(suffix) and len(output) > len(suffix):
            return Path(output[:-len(suffix)])
    return path


def check_outputs(base: Path, suffixes: Iterable[str]) -> list[Path]:
    """Refuse (CodermindError, one line) an OUT whose files cannot be written: a missing or
    read-only folder, a file name that is a folder. Runs before any rendering; also removes
    what a killed run left in that folder."""
    if base.name in ("", ".", ".."):
        _refuse(f"{base}: not a file name (give -o FOLDER/NAME)")
    folder = base.parent
    if not folder.is_dir():
        _refuse(f"{folder}: no such folder (for -o {base})")
    paths = [base.with_name(base.name + s) for s in suffixes]
    for path in paths:
        if path.is_dir():
            _refuse(f"{path}: is a folder, not a file (choose another -o)")
    try:        # the real test: os.access says yes to root on a read-only mount
        Path(tempfile.mkdtemp(prefix=f".{base.name}.codermind-{os.getpid()}-",
                              dir=folder)).rmdir()
    except OSError as e:
        _refuse(f"{folder}: cannot write here: {e.strerror or e}")
    for note in recover_leftovers(folder):
        print(f"codermind: note: {note}", file=sys.stderr)
    return paths


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def recover_leftovers(folder: Path) -> list[str]:
    """Roll back and remove the staging folders and temporary files that a killed run left
    in ``folder`` (its process is gone); one note per item."""
    notes = []
    for entry in sorted(folder.iterdir()):
        m = _LEFTOVER.match(entry.name)
        if not m or int(m["pid"]) == os.getpid() or _alive(int(m["pid"])):
            continue
        action = "removed"
        with signals.deferred():
            if entry.is_dir():
                if _rollback(entry, folder):
                    action = "restored the previous files and removed"
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)
        notes.append(f"{action} {entry}, left by an interrupted run (pid {m['pid']})")
    return notes


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _set_names(manifest: Path) -> list[str]:
    """File names a manifest lists (plain names in its folder only); [] if unreadable."""
    try:
        files = json.loads(manifest.read_text(encoding="utf-8"))["files"]
        return [n for n in files if isinstance(n, str) and "/" not in n and os.sep not in n
                and not n.startswith(".")]
    except (OSError, ValueError, KeyError, TypeError):
        return []


def check_set(base: str | os.PathLike) -> list[str]:
    """What is wrong with the set at OUT (``base``): [] when ``OUT.manifest.json`` exists and
    every file it names is there with its hash."""
    base = Path(base)
    manifest = base.with_name(base.name + MANIFEST)
    if not manifest.is_file():
        return [f"{manifest}: missing (the set is incomplete or was never written)"]
    try:
        files = json.loads(manifest.read_text(encoding="utf-8"))["files"]
    except (OSError, ValueError, KeyError) as e:
        return [f"{manifest}: unreadable ({e})"]
    problems = []
    for name, entry in files.items():
        path = base.parent / name
        if not path.is_file():
            problems.append(f"{path}: missing")
        elif _sha256(path) != entry.get("sha256"):
            problems.append(f"{path}: differs from {manifest.name}")
    return problems


Writer = Callable[[Path], None]


def write_set(base: Path, writers: Mapping[str, Writer],
              command: list[str] | None = None) -> list[Path]:
    """Write ``OUT + suffix`` with ``writers[suffix](path)`` for each suffix, and
    ``OUT.manifest.json``, replacing the previous set as one (see the module doc). On an
    error or a signal the previous files stay, and no temporary file remains."""
    folder, name = base.parent, base.name
    staging = Path(tempfile.mkdtemp(prefix=f".{name}.codermind-{os.getpid()}-", dir=folder))
    committed = False
    try:
        new = staging / "new"
        new.mkdir()
        _after_step("staging folder")
        names = [name + suffix for suffix in writers]
        for file_name, write in zip(names, writers.values()):
            write(new / file_name)
            _fsync(new / file_name)
            _after_step(f"wrote {file_name}")
        manifest = name + MANIFEST
        record = {"files": {n: {"sha256": _sha256(new / n), "bytes": (new / n).stat().st_size}
                            for n in names},
                  "command": shlex.join(command if command is not None else
                                        ["codermind", *sys.argv[1:]])}
        (new / manifest).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        _fsync(new / manifest)
        _after_step(f"wrote {manifest}")
        with signals.deferred():     # a signal now waits until the set is in or rolled back
            _commit(staging, folder, [*names, manifest])
            committed = True
    except KeyboardInterrupt:
        if not committed:
            raise signals.Interrupted(f"nothing written, the previous {base}.* kept") from None
        raise
    finally:
        with signals.deferred():
            shutil.rmtree(staging, ignore_errors=True)
    _fsync(folder)
    return [folder / n for n in names]


def _commit(staging: Path, folder: Path, names: list[str]) -> None:
    """Move the staged set (``names``, the manifest last) into ``folder``; roll back on any
    error. Journal first, so that :func:`recover_leftovers` can roll back after SIGKILL."""
    new, old, manifest = staging / "new", staging / "old", names[-1]
    dropped = [n for n in _set_names(folder / manifest) if n not in names]
    (staging / "names.json").write_text(json.dumps({"set": names, "dropped": dropped}),
                                        encoding="utf-8")
    old.mkdir()
    try:
        for n in [*names, *dropped]:        # keep the previous set until the new one is in
            if (folder / n).is_file():
                try:
                    os.link(folder / n, old / n)
                except OSError:             # a file system without hard links
                    shutil.copy2(folder / n, old / n)
                _after_step(f"kept old {n}")
        (folder / manifest).unlink(missing_ok=True)
        _after_step("removed old manifest")
        for n in dropped:                   # files of the previous set that this one lacks
            (folder / n).unlink(missing_ok=True)
            _after_step(f"removed old {n}")
        for n in names:                     # the manifest last: the set is then complete
            os.replace(new / n, folder / n)
            _after_step(f"moved in {n}")
    except BaseException:
        _rollback(staging, folder)
        raise


def _rollback(staging: Path, folder: Path) -> bool:
    """Put the previous set back unless the new manifest is already in; True if done."""
    new, old = staging / "new", staging / "old"
    try:
        journal = json.loads((staging / "names.json").read_text(encoding="utf-8"))
        names, dropped = journal["set"], journal["dropped"]
    except (OSError, ValueError, KeyError):
        return False                        # the commit never started: nothing was touched
    if not (new / names[-1]).exists():
        return False                        # the manifest is in: the new set is complete
    # Every backup is made before anything in the folder changes: a name without one was
    # either not touched yet or (only a name of the new set) moved in with no predecessor.
    for n in [*names, *dropped]:
        if (old / n).exists():
            os.replace(old / n, folder / n)
        elif n in names and not (new / n).exists():
            (folder / n).unlink(missing_ok=True)
    return True
