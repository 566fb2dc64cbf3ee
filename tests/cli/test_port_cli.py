"""``codermind reference``: the command-line front of the port."""

from __future__ import annotations

import numpy as np

from codermind_ref import png
from support import run_cli


def test_reference_writes_tga_png_exr(tutorial_dir, tmp_path):
    out = run_cli("reference", tutorial_dir / "page1" / "scene.txt", "-o", tmp_path / "p1")
    assert out.returncode == 0, out.stderr
    for suffix in (".tga", ".png", ".exr", ".variance.exr"):
        assert (tmp_path / f"p1{suffix}").stat().st_size > 0
    expected = png.decode((tutorial_dir / "page1" / "expected.png").read_bytes())
    assert np.array_equal(png.decode((tmp_path / "p1.png").read_bytes()), expected)
    tga_bytes = (tmp_path / "p1.tga").read_bytes()
    assert tga_bytes[18:] == expected[::-1, :, ::-1].tobytes()
    assert "100%" in out.stderr and "p1.tga" in out.stdout


def test_reference_bad_scene_is_one_line_exit_2(tmp_path):
    scene = tmp_path / "bad.txt"
    scene.write_text("Scene {\n Version.Major = 1;\n Version.Minor = 1;\n NumberOfLights = 1;\n}\n")
    out = run_cli("reference", scene, "-o", tmp_path / "x")
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        f"codermind: error: {scene}:4: NumberOfLights = 1 but there is no section 'Light0'"]
    assert not list(tmp_path.glob("x*"))


def test_reference_rejects_bad_options(tmp_path, tutorial_dir):
    out = run_cli("reference", tutorial_dir / "page1" / "scene.txt", "--complexity", "0")
    assert out.returncode == 2 and "--complexity" in out.stderr


def test_reference_prints_warnings_found_while_rendering(tmp_path):
    scene = tmp_path / "black.txt"
    scene.write_text("Scene {\n Version.Major = 1;\n Version.Minor = 3;\n Image.Width = 16;\n"
                     " Image.Height = 16;\n Perspective.Type = conic;\n}\n")
    out = run_cli("reference", scene, "-o", tmp_path / "x")
    assert out.returncode == 0, out.stderr
    assert f"codermind: warning: {scene}:1: auto exposure: all 256 probe rays are black, so " \
           f"E = -1" in out.stderr
