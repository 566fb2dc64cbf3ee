"""Outputs and signals of the commands: names kept whole, bad paths refused before any
rendering, SIGTERM like Ctrl-C, an interrupt at any moment is one line."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from codermind_cli import outputs
from support import ROOT, run_cli

SCENE = """<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0, 0, -4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"/>
        <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/></film>
    </sensor>
    <emitter type="constant"/>
    <shape type="sphere"><bsdf type="diffuse"/></shape>
</scene>
"""


def write_scene(folder, width: int, height: int):
    path = folder / "scene.xml"
    path.write_text(SCENE.format(width=width, height=height))
    return path


def test_render_names_are_kept_whole_and_two_runs_both_survive(tmp_path):
    scene = write_scene(tmp_path, width=12, height=8)
    for name in ("run.v1", "run.v2"):
        out = run_cli("render", scene, "-o", tmp_path / name, "--spp", "2")
        assert out.returncode == 0, out.stderr
    for name in ("run.v1", "run.v2"):
        assert (tmp_path / f"{name}.exr").is_file() and (tmp_path / f"{name}.png").is_file()
        assert outputs.check_set(tmp_path / name) == []


def test_reference_and_convert_keep_names_whole(tmp_path):
    page1 = ROOT / "scenes" / "page1.txt"
    out = run_cli("reference", page1, "-o", tmp_path / "ref.v1")
    assert out.returncode == 0, out.stderr
    assert outputs.check_set(tmp_path / "ref.v1") == []
    assert (tmp_path / "ref.v1.tga").is_file()
    out = run_cli("convert", page1, "-o", tmp_path / "scene.v1", "-q")
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "scene.v1.xml").is_file()


def test_output_folder_means_the_scene_s_name_inside(tmp_path):
    scene = write_scene(tmp_path, width=12, height=8)
    (tmp_path / "outdir").mkdir()
    out = run_cli("render", scene, "-o", f"{tmp_path / 'outdir'}/", "--spp", "1")
    assert out.returncode == 0, out.stderr
    assert outputs.check_set(tmp_path / "outdir" / "scene") == []


@pytest.mark.parametrize("command", ["render", "reference"])
@pytest.mark.parametrize("bad, words", [("missing/out", "no such folder"),
                                        ("taken", "is a folder")])
def test_bad_output_paths_are_refused_before_rendering(tmp_path, command, bad, words):
    (tmp_path / "taken.png").mkdir()
    if command == "render":     # a render of minutes, were it started
        args = [write_scene(tmp_path, width=256, height=256), "--spp", "100000"]
    else:
        args = [ROOT / "scenes" / "page4.txt", "--complexity", "10000"]
    t0 = time.perf_counter()
    out = run_cli(command, *args, "-o", tmp_path / bad)
    lines = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(lines) == 1 and words in lines[0], out.stderr
    assert time.perf_counter() - t0 < 30 and "spp" not in out.stderr


def _render_until_passes(tmp_path, passes: int) -> subprocess.Popen:
    scene = write_scene(tmp_path, width=32, height=24)
    proc = subprocess.Popen(
        [sys.executable, "-m", "codermind_cli", "render", str(scene), "-o",
         str(tmp_path / "part"), "--spp", "4096", "--pass-spp", "1"],
        stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    deadline, seen = time.time() + 120, 0
    for line in proc.stderr:             # progress: one line per pass when not a terminal
        seen += "pass" in line
        if seen >= passes or time.time() > deadline:
            break
    return proc


def test_sigterm_writes_the_finished_passes(tmp_path):
    proc = _render_until_passes(tmp_path, 2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "SIGTERM" in err and "Traceback" not in err
    assert outputs.check_set(tmp_path / "part") == []
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def _wait_for_handlers(proc: subprocess.Popen, timeout: float = 60) -> None:
    """Until the command has installed its signal handlers (SIGTERM caught, which Python
    alone never does): before that an interrupt meets Python's start-up, not our code, and
    a loaded machine can take more than a second to get there."""
    status = Path(f"/proc/{proc.pid}/status")
    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None:
        caught = next((int(line.split()[1], 16) for line in status.read_text().splitlines()
                       if line.startswith("SigCgt:")), 0)
        if caught >> (signal.SIGTERM - 1) & 1:
            return
        time.sleep(0.005)
    pytest.fail("the command never installed its signal handlers")


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux's /proc")
@pytest.mark.parametrize("delay", [0.0, 0.3])
def test_interrupt_at_start_is_one_line(tmp_path, delay):
    # 0 s after the handlers are in: while Python imports codermind and Mitsuba; 0.3 s:
    # importing Mitsuba or loading the scene
    scene = write_scene(tmp_path, width=16, height=16)
    proc = subprocess.Popen([sys.executable, "-m", "codermind_cli", "render", str(scene),
                             "-o", str(tmp_path / "out"), "--spp", "4"],
                            stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    _wait_for_handlers(proc)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    lines = err.strip().splitlines()
    if any("stopping after" in line or "spp, pass" in line for line in lines):
        pytest.skip("the render had started: covered by the pass tests")
    assert (proc.returncode, lines) == (130, ["codermind: interrupted"]), err
    assert not list(tmp_path.glob("out*")) and not list(tmp_path.glob(".out*"))
