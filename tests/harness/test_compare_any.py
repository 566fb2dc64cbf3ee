"""``codermind compare`` on ordinary Mitsuba scenes (no tutorial twin): a scene against
another render of it (``--against OTHER.xml``, ``--reference IMAGE.exr``).

Evidence: Mitsuba's built-ins agreeing with each other (``scenes/default.xml`` through
``path`` and through ``volpath``, which have the same expectation in a scene without media),
and our ``tutorialpath`` agreeing with ``path`` there, must pass, with the per-pixel z spread about 1 (the variances from the pass means are
right); injected errors of our own making (``scenes/default.xml`` with its point light 3 %
brighter, which lights two thirds of the image) must fail; ``scenes/user/room.xml`` (the
project's plugins, Mitsuba's default Gaussian film filter) against itself with another seed
must pass; a reference image of our own render with another seed, with and without its
variance image, must pass, and one of the brighter light must fail; the pooled tests'
correction for the film filter is checked against its closed form. Small films (64 x 48 or less) and few samples: seconds each."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from support.plain_scenes import default_copy, room_copy

#: room.xml at the tests' size (its resx/resy defaults; -D applies to both sides)
ROOM_SMALL = {"resx": "48", "resy": "36"}


def compare(out: Path, scene: Path, **options) -> dict:
    from codermind_harness.compare import Options, compare_scene
    return compare_scene(scene, Options(out_dir=out, progress=False, **options))


def reference(scene: Path, out: Path, spp: int, seed: int, defines: dict | None = None,
              variance: bool = True) -> Path:
    """Our own render of ``scene`` as OUT.exr (and OUT.variance.exr: the variance of each
    pixel's mean, from its passes), as ``codermind render`` writes a film."""
    from codermind.imageio import write_exr
    from codermind_harness import sides
    w, h, _ = sides.plain_film(scene, dict(defines or {}))
    grid = sides.Grid.of(w, h, 1)
    (side,), _, _ = sides.plain_side(scene, grid, spp, (seed,), dict(defines or {}), None, False,
                                  False)
    write_exr(out.with_suffix(".exr"), side.linear.astype(np.float32))
    if variance:
        write_exr(out.with_name(out.name + ".variance.exr"), side.variance.astype(np.float32))
    return out.with_suffix(".exr")


@pytest.mark.parametrize("integrator", ["volpath", "tutorialpath"])
def test_default_scene_through_path_and_another_integrator_passes(llvm, tmp_path, integrator):
    """The same scene through two integrators of the same expectation: Mitsuba's ``path``
    and ``volpath`` (built-ins, no media), and ``path`` and our ``tutorialpath`` (clean:
    path's expectation; it adds the point light at every hit instead of picking a light)."""
    scene = default_copy(tmp_path, "path.xml")
    other = default_copy(tmp_path, f"{integrator}.xml", integrator=integrator)
    rec = compare(tmp_path / "out", scene, against=other, spp=32)
    assert rec["passed"], rec["failures"]
    z = rec["z_test"]
    assert rec["ordinary"] and rec["pixels"] == 64 * 48 and rec["passes"] == 16
    # the noise is real and both sides' variances right: z spread about 1 over many tests
    assert z["noisy_tests"] > 3000 and 0.85 < z["z_sd"] < 1.15
    assert set(rec["pooled"]) == {"tiles", "objects", "image"}
    # 12 tiles of 16 x 16 pixels, some of them all sky (no noise: not pooled)
    assert 6 <= rec["pooled"]["tiles"]["groups"] <= 12 and rec["pooled"]["objects"]["groups"] >= 3
    assert 0 < rec["flip_noise"] and rec["flip_mean"] <= rec["flip_limit"]
    assert (tmp_path / "out" / "path.compare.png").read_bytes()[:4] == b"\x89PNG"


def test_default_scene_with_its_point_light_three_percent_brighter_fails(llvm, tmp_path):
    """An injected error: the point light that lights the floor and both spheres (two thirds
    of the image; the rest is the sky) 3 % brighter on SCENE's side. Per pixel it is noise;
    the whole image's pooled difference sees it."""
    bright = default_copy(tmp_path, "bright.xml", light=1.03)
    scene = default_copy(tmp_path, "scene.xml")
    rec = compare(tmp_path / "out", bright, against=scene, spp=128)
    assert not rec["passed"]
    image = rec["pooled"]["image"]
    assert not image["passed"] and any("pooled z over image" in f for f in rec["failures"])
    # brighter on SCENE's side: every failing pooled Z is positive
    assert all(zz > image["z_critical"] for _, _, zz, _ in image["failing"])
    assert rec["z_test"]["pass_rate"] >= 0.99          # per pixel, 3 % hides in the noise


def test_room_against_itself_with_another_seed_passes(llvm, tmp_path):
    """The false-alarm side of the test above: the same room, OTHER with another seed."""
    room = room_copy(tmp_path, "room.xml")
    again = room_copy(tmp_path, "again.xml")
    rec = compare(tmp_path / "out", room, against=again, spp=16, defines=ROOM_SMALL)
    assert rec["passed"], rec["failures"]
    assert rec["width"] == 48 and rec["height"] == 36     # -D reached both sides


def test_reference_with_its_variance_image_passes(llvm, tmp_path):
    scene = default_copy(tmp_path, "scene.xml", integrator="volpath")
    ref = reference(default_copy(tmp_path / "ref", "ref.xml"), tmp_path / "ref" / "ref", 32, 7)
    rec = compare(tmp_path / "out", scene, reference=ref, spp=32)
    assert rec["passed"], rec["failures"]
    assert rec["reference_variance"] == str(tmp_path / "ref" / "ref.variance.exr")
    assert "variance image ref.variance.exr" in rec["other_noise"]
    assert 0.85 < rec["z_test"]["z_sd"] < 1.15      # both variances right: z spread about 1


def test_reference_without_a_variance_image_passes_and_says_what_it_assumes(llvm, tmp_path):
    scene = default_copy(tmp_path, "scene.xml")
    ref = reference(scene, tmp_path / "ref", 32, 7, variance=False)
    rec = compare(tmp_path / "out", scene, reference=ref, spp=32)
    assert rec["passed"], rec["failures"]
    assert rec["reference_variance"] is None
    assert "assumed as noisy as our side" in rec["other_noise"] and not rec["z_far"]["judged"]
    # our second render's variance stands for the reference's, whose own rare bright
    # samples are in no estimate: z spreads wider than 1 (1.2 here: the gold sphere's
    # highlights; one pixel reaches |z| 21, which is why the far-|z| rule is not judged
    # without a variance image), and the pooled sums (hundreds of pixels) pass
    assert 1.0 < rec["z_test"]["z_sd"] < 1.5 and rec["z_test"]["pass_rate"] >= 0.99
    assert all(p["passed"] for p in rec["pooled"].values())


def test_reference_of_a_brighter_light_fails(llvm, tmp_path):
    scene = default_copy(tmp_path, "scene.xml")
    ref = reference(default_copy(tmp_path / "ref", "bright.xml", light=1.03),
                    tmp_path / "ref" / "bright", 128, 7)
    rec = compare(tmp_path / "out", scene, reference=ref, spp=128)
    assert not rec["passed"] and not rec["pooled"]["image"]["passed"]
    # darker on SCENE's side: the failing pooled Z are negative
    assert all(zz < 0 for _, _, zz, _ in rec["pooled"]["image"]["failing"])


def test_pooled_inflation_of_box_and_gaussian_filters(llvm):
    """Closed form: a one-pixel box shares no samples between pixels (1); Mitsuba's default
    Gaussian (sd 0.5 px, radius 2) gives (sum_d exp(-d^2))^2 = pi (Jacobi's theta function,
    1.7725^2), less a little for its truncation."""
    import mitsuba as mi
    from codermind_harness.sides import pooled_inflation

    def film(rfilter: str):
        return mi.load_dict({"type": "hdrfilm", "width": 8, "height": 8,
                             "rfilter": {"type": rfilter}})
    assert pooled_inflation(film("box")) == pytest.approx(1.0, abs=1e-3)
    assert pooled_inflation(film("gaussian")) == pytest.approx(np.pi, rel=5e-3)
    # every other pixel: the neighbours at distance 1 drop out, exp(-4) remains
    assert pooled_inflation(film("gaussian"), stride=2) == pytest.approx(
        (1 + 2 * np.exp(-4)) ** 2, rel=5e-3)


def test_a_far_z_fails_by_itself():
    """The verdict's own rule: one |z| beyond twice the Sidak bound fails a scene whose pass
    rate, FLIP and pooled tests pass."""
    from codermind_harness import metrics, verdict
    a = np.full((8, 8, 3), 1.0)
    v = np.full((8, 8, 3), 1e-2)
    b = a.copy()
    z = metrics.z_test(a, v, b, v)
    t = verdict.SceneTests(z, 12.0, (3, 4, 1), 0.01, np.zeros((8, 8)), 0.01, 0.0, 0.0, {})
    failures, _ = verdict.scene_failures(t, 64, verdict.Thresholds())
    assert len(failures) == 1 and "|z| 12 at pixel (3, 4) G" in failures[0]
    t.far_z = 1.9 * z.z_critical
    assert verdict.scene_failures(t, 64, verdict.Thresholds())[0] == []


def test_the_record_is_json_with_the_tables_columns(llvm, tmp_path):
    from codermind_harness.report import format_table
    scene = default_copy(tmp_path, "a.xml", width=32, height=24)
    other = default_copy(tmp_path, "b.xml", width=32, height=24)
    rec = compare(tmp_path / "out", scene, against=other, spp=16)
    back = json.loads(json.dumps(rec))
    assert back["seeds"] == {"scene": 0, "other": 1, "noise_floor": 2}
    table = format_table([back])
    assert table.split("\n")[0].split()[:3] == ["scene", "against", "pixels"]
    assert "b.xml" in table and ("pass" if rec["passed"] else "FAIL") in table


def test_a_rect_and_stride_pick_film_pixels(llvm, tmp_path):
    """--rect crops both films (y up, as for tutorial scenes), --stride takes every K-th
    pixel; of a 48 x 36 film, the 16 x 12 pixels x = 8, 10, .., 38 and y = 0, 2, .., 22."""
    scene = default_copy(tmp_path, "path.xml", width=48, height=36)
    other = default_copy(tmp_path, "volpath.xml", width=48, height=36, integrator="volpath")
    rec = compare(tmp_path / "out", scene, against=other, spp=16, rect=(8, 0, 40, 24),
                  stride=2)
    assert rec["passed"], rec["failures"]
    assert rec["pixels"] == 16 * 12 and rec["rect"] == [8, 0, 40, 24] and rec["stride"] == 2
    assert rec["z_test"]["tests"] == 16 * 12 * 3
