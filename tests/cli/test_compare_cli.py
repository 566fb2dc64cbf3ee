"""``codermind compare`` end to end on small grids of the bundled scenes: a pass, a
deliberate mismatch that must fail (in the image, and in the auto exposure alone), one-line
errors for bad input; and the pieces the harness relies on (twins, distinct output names,
the film crop)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from support import ROOT, run_cli
from codermind_harness.compare import labels
from codermind_harness.sides import Grid, HarnessError, twin_of

SCENES = ROOT / "scenes"


def record(out: Path) -> dict:
    (scene,) = json.loads((out / "compare.json").read_text())["scenes"]
    return scene


def test_page1_strided_compare_passes(tmp_path):
    r = run_cli("compare", SCENES / "page1.txt", "--stride", "8", "-o", tmp_path, "-q",
                "--noise-floor")
    assert r.returncode == 0, r.stderr
    rec = record(tmp_path)
    assert rec["passed"] and rec["pixels"] == 80 * 60 and rec["spp"] == 1
    # page 1 is deterministic: the port with another seed is the same image
    assert rec["flip_noise"] == 0.0 and rec["z_test_noise"]["pass_rate"] == 1.0
    assert rec["z_test"]["pass_rate"] >= 0.99 and rec["flip_mean"] <= 0.01
    assert rec["random"] is False and rec["z_test"]["noisy_tests"] == 0
    assert "page1" in r.stdout and "pass" in r.stdout        # the table
    assert (tmp_path / "compare.txt").read_text().split("\n")[0] == r.stdout.split("\n")[0]
    assert (tmp_path / "page1.compare.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob(".*.tmp"))                  # atomic writes left nothing


def test_page4_crop_compare_passes(tmp_path):
    """Lens blur over the marble sphere and the floor, 64 samples on both sides (the default)."""
    r = run_cli("compare", SCENES / "page4.txt", "--rect", "392,130,440,170", "-o", tmp_path,
                "-q", "--workers", "1")
    assert r.returncode == 0, r.stdout + r.stderr
    rec = record(tmp_path)
    assert rec["random"] and rec["spp"] == 64 and rec["sub_samples"] == 4 * 48 * 40
    z = rec["z_test"]
    assert z["pass_rate"] >= 0.99 and rec["flip_mean"] <= 0.01
    # the noise is real and the variances right: z spread about 1 over thousands of tests
    assert z["noisy_tests"] > 1000 and 0.9 < z["z_sd"] < 1.1
    # the calibration: t-aware scores of sd and robust sd about 1, p-values flat, nothing
    # near the gross rule; the same for the port against itself; a table in compare.txt
    c = z["calibration"]
    assert c["n"] == z["noisy_tests"] and sum(c["p_hist"]) == c["n"] and len(c["p_hist"]) == 10
    assert 0.9 < c["sd"] < 1.1 and 0.9 < c["sd_robust"] < 1.1
    assert max(c["p_hist"]) < 1.25 * c["p_hist_expected"]
    assert z["gross_channels"] == 0 and z["max_abs_score"] < z["z_gross"]
    assert 0.9 < rec["z_test_noise"]["calibration"]["sd_robust"] < 1.1
    assert rec["pooled"]["tiles"]["calibration"]["n"] == rec["pooled"]["tiles"]["tests"]
    table = (tmp_path / "compare.txt").read_text()
    assert "calibration:" in table and "port vs port" in table
    # the pooled tests: the pooled difference over 29 tiles and over the objects the crop sees
    tiles, objects = rec["pooled"]["tiles"], rec["pooled"]["objects"]
    assert tiles["passed"] and objects["passed"] and tiles["groups"] == 29
    assert 0.7 < tiles["z_sd"] < 1.3 and objects["groups"] >= 1
    # FLIP against its noise floor (the port with seed 1, rendered for every random scene)
    assert rec["flip_noise"] > 0 and rec["flip_mean"] <= rec["flip_limit"]
    assert rec["flip_limit"] == pytest.approx(
        rec["flip_noise"] * (1.15 + 10 / np.sqrt(48 * 40)) + 1e-3)
    # each side's own auto exposure, 8 seeds each, agrees (Welch's t); the image used the
    # port's exposure for seed 0, the first of them
    e = rec["exposure_test"]
    assert e["passed"] and e["method"] == "welch" and e["seeds"] == list(range(8))
    assert rec["exposure"] == e["port"][0] and min(e["sd"]) > 0
    assert abs(e["rel_diff"]) < 0.02


@pytest.mark.parametrize("light1, verdict", [("0.6, 0.7, 1", 0), ("1.8, 2.1, 3", 1)])
def test_an_exposure_error_fails_the_verdict_by_itself(tmp_path, light1, verdict):
    """The page-4 XML with Light1 three times too bright (an edit of the Mitsuba side only)
    moves its auto exposure by about -12 %; in a patch of sky the images do not see the light
    (they are tone-mapped with the port's exposure), so only the exposure test can fail the
    verdict. The unedited copy is the control: same patch, same options, it passes."""
    (tmp_path / "page4.txt").symlink_to(SCENES / "page4.txt")
    (tmp_path / "sky").symlink_to(SCENES / "sky")
    text = (SCENES / "page4.xml").read_text()
    assert text.count('value="0.6, 0.7, 1"') == 1
    (tmp_path / "page4.xml").write_text(text.replace('value="0.6, 0.7, 1"', f'value="{light1}"'))
    out = tmp_path / "out"
    r = run_cli("compare", tmp_path / "page4.xml", "--rect", "300,430,308,436", "--spp", "16",
                "-o", out, "-q", "--workers", "1")
    assert r.returncode == verdict, r.stdout + r.stderr
    rec = record(out)
    assert rec["z_test"]["pass_rate"] >= 0.99 and rec["flip_mean"] <= 0.01   # images agree
    e = rec["exposure_test"]
    assert e["passed"] == (verdict == 0) and len(e["mitsuba"]) == len(e["port"]) == 8
    if verdict:
        assert e["p"] < 1e-3 and e["rel_diff"] < -0.05
        assert rec["failures"] == [rec["failures"][0]]
        assert rec["failures"][0].startswith("auto exposure: Mitsuba ")
        assert "page4: FAIL: auto exposure" in r.stdout
    assert "exposure test: each side's auto exposure over 8 seeds" in r.stdout


def test_page1_crop_on_the_crossing_spheres_passes(tmp_path):
    """The 64 x 48 crop over column x = 320 (false-alarm run 2, which failed: pass rate 0.977,
    FLIP 0.021): the port's two tie rules differ on the column's 48 pixels; tutorialpath,
    which intersects a scene of spheres itself, keeps the first listed sphere there, as the
    original does (through Embree it took the later one), and with the tutorial's
    min_distance the rest agrees."""
    r = run_cli("compare", SCENES / "page1.txt", "--rect", "310,249,374,297", "-o", tmp_path,
                "-q")
    assert r.returncode == 0, r.stdout + r.stderr
    rec = record(tmp_path)
    assert rec["ties"] == {"pixels": 48, "mitsuba_took_last": 0}
    assert rec["z_test"]["pass_rate"] >= 0.999 and rec["flip_mean"] < 0.001


def test_either_tie_keeps_the_first_rule_off_the_ties():
    """At a tie pixel the port takes the rule Mitsuba matches; elsewhere the original's, so an
    error off the ties stays visible."""
    from codermind_harness.sides import SideImage, either_tie

    def side(linear):
        linear = np.asarray(linear, dtype=np.float64).reshape(2, 4, 3)
        return SideImage("x", linear, np.zeros_like(linear), linear[::2, ::2].copy(), 1, 0.0)

    first = side([[0.1] * 12, [0.2] * 12])
    last = side([[0.1] * 12, [0.2] * 6 + [0.9] * 6])        # pixel (0, 1) is a tie
    mits = side([[0.5] * 12, [0.2] * 6 + [0.9] * 6])        # wrong at (0, 0), last at (0, 1)
    merged, ties, took = either_tie(mits, first, last, 2)
    assert (ties, took) == (1, 1)
    assert np.array_equal(merged.linear[:, 2:], last.linear[:, 2:])
    assert np.array_equal(merged.linear[:, :2], first.linear[:, :2])
    merged, ties, took = either_tie(first, first, last, 2)  # Mitsuba took the first
    assert (ties, took) == (1, 0) and np.array_equal(merged.linear, first.linear)


def test_a_mismatched_model_fails(tmp_path):
    """The Mitsuba side with one path segment (no mirror reflections) must fail."""
    r = run_cli("compare", SCENES / "page1.txt", "--stride", "8", "-D", "max_depth=2",
                "-o", tmp_path, "-q")
    assert r.returncode == 1, r.stdout + r.stderr
    rec = record(tmp_path)
    assert not rec["passed"] and rec["z_test"]["pass_rate"] < 0.99   # 0.959: the mirrors
    assert "page1: FAIL: z-test pass rate" in r.stdout


@pytest.mark.parametrize("args, message", [
    (["no/such.txt"], "no/such.txt: no such scene file"),
    ([SCENES / "page1.txt", "--rect", "0,0,700,10"], "--rect 0,0,700,10 is not inside"),
    ([SCENES / "page1.txt", "--exposure", "2"], "page 1 has no exposure"),
    ([SCENES / "page2.txt", "--rect", "0,0,640,10"], "calibration strip"),
    ([SCENES / "page4.txt", "--spp", "1"], "needs --spp >= 2"),
    ([SCENES / "page4.txt", "--exposure-seeds", "1"], "--exposure-seeds: must be >= 2"),
    ([SCENES / "page4.txt", "--exposure-alpha", "0"], "--exposure-alpha: must be in (0, 1)"),
])
def test_bad_input_is_one_line_exit_2(tmp_path, args, message):
    r = run_cli("compare", *args, "-o", tmp_path)
    assert r.returncode == 2
    assert message in r.stderr and "Traceback" not in r.stderr
    assert r.stderr.count("\n") == 1 and not (tmp_path / "compare.json").exists()


def test_twin_of_an_xml_is_the_source_its_header_names(tmp_path):
    assert twin_of(SCENES / "page4.xml") == (SCENES / "page4.txt", SCENES / "page4.xml")
    assert twin_of(SCENES / "page4.txt") == (SCENES / "page4.txt", None)
    orphan = tmp_path / "garden.xml"
    orphan.write_text((SCENES / "garden.xml").read_text())
    with pytest.raises(HarnessError, match="no tutorial twin"):
        twin_of(orphan)


def test_labels_are_distinct():
    assert labels(["a/page1.txt", "a/page2.txt"]) == ["page1", "page2"]
    assert labels(["p1/scene.txt", "p2/scene.txt"]) == ["p1-scene", "p2-scene"]
    assert labels(["s/page1.txt", "s/page1.xml"]) == ["s-page1-txt", "s-page1-xml"]
    assert labels(["s/page1.txt", "s/page1.txt"]) == ["s-page1-txt", "s-page1-txt-2"]


def test_cropped_and_strided_mitsuba_equals_the_full_render(llvm, tmp_path):
    """The film crop and Grid.take pick the same sub-samples as the full film (page 2: 2x2
    sub-samples per pixel, y up; deterministic, so equal to the bit)."""
    from codermind_harness import sides
    txt = SCENES / "page2.txt"
    scene = sides.parse(txt)
    xml = sides.convert_xml(txt, scene, tmp_path)
    full = sides.render_mitsuba(xml, Grid.of(640, 480, 2), 1, 0, 1.0, {"spp": "1"},
                                progress=False)
    grid = Grid.of(640, 480, 2, (101, 37, 180, 90), 3)
    part = sides.render_mitsuba(xml, grid, 1, 0, 1.0, {"spp": "1"}, progress=False)
    rows = (2 * (479 - grid.ys[::-1]))[:, None] + np.arange(2)     # display rows, top first
    cols = (2 * grid.xs)[:, None] + np.arange(2)
    expected = full.linear[rows.ravel()][:, cols.ravel()]
    assert part.linear.shape == (2 * grid.ys.size, 2 * grid.xs.size, 3)
    np.testing.assert_array_equal(part.linear, expected)


def test_unwritable_output_folder_is_one_line_exit_2(tmp_path):
    (tmp_path / "file").write_text("")
    r = run_cli("compare", SCENES / "page1.txt", "--stride", "8", "-o", tmp_path / "file" / "out")
    assert r.returncode == 2
    assert f"{tmp_path / 'file' / 'out'}: " in r.stderr and "Traceback" not in r.stderr
