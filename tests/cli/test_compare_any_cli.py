"""``codermind compare`` on ordinary Mitsuba scenes from the command line: a run that passes
with its files and table, and one-line refusals (exit status 2, nothing written) of what
cannot be compared. Evidence: Mitsuba built-ins (``scenes/default.xml`` through ``path`` and
``volpath``); the refusals are our own rules."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from support import ROOT, run_cli
from support.plain_scenes import default_copy


def test_against_another_integrator_passes_with_its_files(tmp_path):
    scene = default_copy(tmp_path, "scene.xml", width=48, height=36)
    other = default_copy(tmp_path, "volpath.xml", width=48, height=36, integrator="volpath")
    out = tmp_path / "out"
    r = run_cli("compare", scene, "--against", other, "--spp", "16", "--seed", "3", "-o", out,
                "-q")
    assert r.returncode == 0, r.stdout + r.stderr
    (rec,) = json.loads((out / "compare.json").read_text())["scenes"]
    assert rec["passed"] and rec["ordinary"] and rec["spp"] == 16 and rec["seed"] == 3
    assert rec["against"] == str(other) and rec["pixels"] == 48 * 36
    assert (out / "scene.compare.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "compare.txt").read_text().split("\n")[0] == r.stdout.split("\n")[0]
    assert "volpath.xml" in r.stdout and "pass" in r.stdout


def test_an_ordinary_scene_defaults_to_its_own_sample_count_at_least_32(tmp_path):
    """default.xml's sampler asks for 64: the default --spp is 64 (at 16 x 12, about a
    second)."""
    scene = default_copy(tmp_path, "scene.xml", width=16, height=12)
    r = run_cli("compare", scene, "--against", scene, "-o", tmp_path / "out", "-q")
    assert r.returncode == 0, r.stdout + r.stderr
    (rec,) = json.loads((tmp_path / "out" / "compare.json").read_text())["scenes"]
    assert rec["spp"] == 64 and rec["scene_spp"] == 64


@pytest.fixture
def scenes(tmp_path) -> dict:
    small = default_copy(tmp_path, "small.xml", width=16, height=12)
    return {"small": small,
            "wide": default_copy(tmp_path, "wide.xml", width=20, height=12),
            "tiny_ref": tmp_path / "tiny.exr", "missing": tmp_path / "none.xml"}


@pytest.mark.parametrize("args, message", [
    (["{small}", "--against", "{wide}"], "wide.xml: its film is 20x12, but small.xml's is 16x12"),
    (["{missing}", "--against", "{small}"], "none.xml: no such scene file"),
    (["{small}", "--against", "{missing}"], "none.xml: no such scene file (--against)"),
    (["{small}"], "small.xml: not a tutorial scene"),
    (["{small}", "--reference", "{missing_exr}"], "none.exr: no such reference image"),
    (["{small}", "--reference", "{tiny_ref}"], "tiny.exr: 8x6, but the scene's linear film"),
    (["{small}", "--reference", "{png}"], "not a .png or .tga"),
    (["{small}", "--reference", "{small_ref}", "--reference-variance", "{missing_exr}"],
     "none.exr: no such variance image"),
    (["{small}", "--reference-variance", "{small_ref}"], "give it with --reference"),
    (["{small}", "{small}", "--against", "{small}"], "give one SCENE, got 2"),
    (["{small}", "--against", "{small}", "--reference", "{small_ref}"], "give one other side"),
    (["{small}", "--against", "{small}", "--exposure", "2"], "--exposure applies to tutorial"),
    (["{small}", "--against", "{small}", "--spp", "1"], "--spp must be >= 2"),
    ([ROOT / "scenes" / "page1.txt", "--against", "{small}"], "compares Mitsuba XML scenes"),
])
def test_bad_input_is_one_line_exit_2(llvm, tmp_path, scenes, args, message):
    import numpy as np
    from codermind.imageio import write_exr
    write_exr(scenes["tiny_ref"], np.zeros((6, 8, 3), np.float32))
    small_ref = tmp_path / "small_ref.exr"
    write_exr(small_ref, np.zeros((12, 16, 3), np.float32))
    png = tmp_path / "ref.png"
    png.write_bytes(b"")
    names = {**{k: str(v) for k, v in scenes.items()}, "missing_exr": str(tmp_path / "none.exr"),
             "small_ref": str(small_ref), "png": str(png)}
    out = tmp_path / "out"
    r = run_cli("compare", *[str(a).format(**names) for a in args], "-o", out)
    assert r.returncode == 2, r.stdout + r.stderr
    assert message in r.stderr and "Traceback" not in r.stderr
    assert r.stderr.count("\n") == 1 and not (out / "compare.json").exists()


def test_a_render_with_its_variance_is_a_reference_compare_reads(tmp_path):
    """``codermind render --variance`` writes OUT.variance.exr next to OUT.exr for an
    ordinary scene; ``compare --reference OUT.exr`` takes it up by itself."""
    scene = default_copy(tmp_path, "scene.xml", width=24, height=18)
    (tmp_path / "ref").mkdir()
    r = run_cli("render", scene, "--spp", "32", "--seed", "5", "--variance", "-o",
                tmp_path / "ref" / "ref")
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "ref" / "ref.variance.exr").is_file() and "ref.variance.exr" in r.stdout
    out = tmp_path / "out"
    r = run_cli("compare", scene, "--reference", tmp_path / "ref" / "ref.exr", "--spp", "32",
                "-o", out, "-q")
    assert r.returncode == 0, r.stdout + r.stderr
    (rec,) = json.loads((out / "compare.json").read_text())["scenes"]
    assert rec["reference_variance"] == str(tmp_path / "ref" / "ref.variance.exr")
    assert rec["passed"] and rec["z_test"]["noisy_tests"] > 500     # of 1296: the sky has none
