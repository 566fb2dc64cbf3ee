"""codermind_cli.outputs: output names, checks before rendering, and a set of files replaced
as one (fault injected after every file operation; SIGKILL leftovers recovered)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from codermind.errors import CodermindError
from codermind_cli import outputs, signals


def writers(version: str, extra: bool = False) -> dict:
    files = {".exr": lambda p: p.write_bytes(f"exr {version}".encode()),
             ".png": lambda p: p.write_bytes(f"png {version}".encode())}
    if extra:
        files[".variance.exr"] = lambda p: p.write_bytes(f"var {version}".encode())
    return files


def contents(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def test_output_name_is_kept_whole(tmp_path):
    scene = Path("scenes/garden.xml")
    assert outputs.output_base(str(tmp_path / "run.v1"), scene) == tmp_path / "run.v1"
    assert outputs.output_base(str(tmp_path / "x.png"), scene) == tmp_path / "x"
    assert outputs.output_base(str(tmp_path) + "/", scene) == tmp_path / "garden"
    assert outputs.output_base(None, scene) == Path.cwd() / "garden"


@pytest.mark.parametrize("name, words", [("missing/x", "no such folder"),
                                         ("taken", "is a folder"), ("", "empty")])
def test_bad_output_paths_are_refused_in_one_line(tmp_path, name, words):
    (tmp_path / "taken.png").mkdir()
    with pytest.raises(CodermindError, match=words):
        base = outputs.output_base(str(tmp_path / name) if name else "", Path("s.xml"))
        outputs.check_outputs(base, (".exr", ".png"))


def test_two_names_keep_two_sets(tmp_path):
    outputs.write_set(tmp_path / "run.v1", writers("1"))
    outputs.write_set(tmp_path / "run.v2", writers("2"))
    assert outputs.check_set(tmp_path / "run.v1") == []
    assert outputs.check_set(tmp_path / "run.v2") == []
    assert (tmp_path / "run.v1.exr").read_bytes() == b"exr 1"


def test_manifest_names_files_hashes_and_command(tmp_path):
    outputs.write_set(tmp_path / "out", writers("1"), command=["codermind", "render", "s.xml"])
    record = json.loads((tmp_path / "out.manifest.json").read_text())
    assert sorted(record["files"]) == ["out.exr", "out.png"]
    assert record["command"] == "codermind render s.xml"
    (tmp_path / "out.png").write_bytes(b"changed")
    assert outputs.check_set(tmp_path / "out") == [f"{tmp_path / 'out.png'}: differs from "
                                                   "out.manifest.json"]


def test_files_of_the_previous_set_that_the_new_one_lacks_go(tmp_path):
    outputs.write_set(tmp_path / "out", writers("1", extra=True))
    outputs.write_set(tmp_path / "out", writers("2"))
    assert sorted(contents(tmp_path)) == ["out.exr", "out.manifest.json", "out.png"]


class Fault(Exception):
    pass


def _steps(tmp_path: Path) -> int:
    """How many file operations the replacement of a set by a smaller one makes."""
    count = []
    outputs.write_set(tmp_path / "out", writers("0", extra=True))
    original = outputs._after_step
    outputs._after_step = lambda step: count.append(step)
    try:
        outputs.write_set(tmp_path / "out", writers("0"))
    finally:
        outputs._after_step = original
    return len(count)


@pytest.mark.parametrize("fault", [Fault, KeyboardInterrupt])
def test_a_fault_after_any_step_leaves_the_old_or_the_new_set_whole(tmp_path, monkeypatch, fault):
    (tmp_path / "count").mkdir()
    steps = _steps(tmp_path / "count")
    assert steps >= 10
    for k in range(steps):
        folder = tmp_path / f"k{k}"
        folder.mkdir()
        outputs.write_set(folder / "out", writers("old", extra=True))
        old = contents(folder)
        calls = []

        def after(step, k=k):
            calls.append(step)
            if len(calls) == k + 1:
                raise fault(step)
        monkeypatch.setattr(outputs, "_after_step", after)
        with pytest.raises((Fault, KeyboardInterrupt)):
            outputs.write_set(folder / "out", writers("new"))
        monkeypatch.undo()
        now = contents(folder)
        assert outputs.check_set(folder / "out") == [], (k, calls[-1], sorted(now))
        new = now["out.exr"] == b"exr new"
        assert now == old or (new and sorted(now) == ["out.exr", "out.manifest.json",
                                                      "out.png"]), (k, calls[-1], sorted(now))


def test_a_signal_during_the_commit_waits_until_the_set_is_in(tmp_path, monkeypatch):
    outputs.write_set(tmp_path / "out", writers("old"))

    def after(step):
        if step.startswith("moved in out.exr"):
            os.kill(os.getpid(), signal.SIGTERM)
    monkeypatch.setattr(outputs, "_after_step", after)
    with signals.installed(), pytest.raises(KeyboardInterrupt):
        outputs.write_set(tmp_path / "out", writers("new"))
    assert outputs.check_set(tmp_path / "out") == []
    assert (tmp_path / "out.png").read_bytes() == b"png new"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


KILLED_WRITER = """
import os, sys
from pathlib import Path
from codermind_cli import outputs
out = Path(sys.argv[1])
def after(step):
    if step == sys.argv[2]:
        os.kill(os.getpid(), 9)
outputs._after_step = after
outputs.write_set(out, {".exr": lambda p: p.write_bytes(b"exr new"),
                        ".png": lambda p: p.write_bytes(b"png new")})
"""


@pytest.mark.parametrize("step", ["wrote out.exr", "moved in out.exr", "moved in out.manifest.json"])
def test_leftovers_of_a_killed_run_are_rolled_back_and_named_at_the_next(tmp_path, step):
    outputs.write_set(tmp_path / "out", writers("old"))
    old = contents(tmp_path)
    killed = subprocess.run([sys.executable, "-c", KILLED_WRITER, str(tmp_path / "out"), step])
    assert killed.returncode == -9
    assert [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    notes = outputs.recover_leftovers(tmp_path)
    assert len(notes) == 1 and "interrupted run" in notes[0]
    now = contents(tmp_path)
    assert outputs.check_set(tmp_path / "out") == []
    assert now == old or now["out.png"] == b"png new"
    assert (now == old) == (step != "moved in out.manifest.json")


def test_a_killed_run_s_temporary_file_is_removed_and_a_live_one_s_kept(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    (tmp_path / f".x.xml.codermind-{dead}-abc123.tmp").write_text("partial")
    live = tmp_path / f".y.xml.codermind-{os.getppid()}-abc123.tmp"
    live.write_text("being written")
    notes = outputs.recover_leftovers(tmp_path)
    assert len(notes) == 1 and f"pid {dead}" in notes[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == [live.name]
