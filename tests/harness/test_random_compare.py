"""``codermind compare`` on tutorial scenes nobody calibrated it to: random ones
(codermind_harness.randscene) and the scenes of scenes/user/ written as a new user writes
them. Correct plugins must pass; an injected error must fail."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from support import ROOT

USER = ROOT / "scenes" / "user"
#: Tiny random scenes: 40 x 30 pixels (4800 sub-samples), 16 samples per sub-sample.
TINY = dict(width=40, height=30)


def _needs_drawn_diffuse(mi) -> None:
    """Compare's z-test holds on random scenes only when both sides draw the roulette's
    diffuse event (sides.drawn_diffuse_xml): skip where tutorialpath has no draw_diffuse."""
    from codermind_harness import sides
    if not sides.draws_diffuse():
        pytest.skip("tutorialpath has no draw_diffuse option: Mitsuba lights every hit times "
                    "the diffuse probability, the port draws it (sides.drawn_diffuse_xml)")


def _compare(txt: Path, out: Path, spp: int | None = 16, edited: Path | None = None,
             stride: int = 1) -> dict:
    """compare_scene as the command line runs it (default thresholds), the Mitsuba side
    converted from ``edited`` where given."""
    from codermind_harness import sides
    from codermind_harness.compare import Options, compare_scene, prepare
    opt = Options(spp=spp, out_dir=out, progress=False, stride=stride, workers=1)
    case = prepare(txt, opt)
    if edited is not None:
        xml = sides.convert_xml(edited, sides.parse(edited), out, name="edited.xml")
        case = replace(case, xml=xml)
    return compare_scene(case, opt, txt.stem)


def test_random_scene_is_reproducible_and_parses(tmp_path):
    """Evidence: the port's parser (facts.md F1): every drawn scene reads without a warning,
    with the counts the generator promises; the same seed gives the same text."""
    import codermind_ref as ref
    from codermind_harness import randscene
    assert randscene.draw(7).text == randscene.draw(7).text
    assert randscene.draw(7).text != randscene.draw(8).text
    for seed in range(12):
        for page in (2, 4):
            drawn = randscene.draw(seed, page=page)
            path = tmp_path / f"page{page}-{seed}.txt"
            path.write_text(drawn.text, encoding="utf-8")
            scene = ref.parse_scene(path)
            assert scene.page == page and scene.warnings == [], scene.warnings
            assert (scene.width, scene.height) == (160, 120)
            assert 1 <= len(scene.spheres) + len(scene.blobs) <= 5
            assert 1 <= len(scene.lights) <= 3 and len(scene.blobs) <= 1
            assert bool(scene.cubemap.faces) == drawn.cubemap


def test_random_scenes_draw_every_feature():
    """Evidence: the drawn values themselves: over 40 seeds every material kind, a blob, the
    cube map and none, depth of field, a bump, and a glass whose Reflection differs from its
    Refraction all occur."""
    from codermind_harness import randscene
    drawn = [randscene.draw(s) for s in range(40)]
    assert set(randscene.KINDS) <= {k for d in drawn for k in d.kinds}
    for flag in ("blob", "cubemap", "dof"):
        assert {getattr(d, flag) for d in drawn} == {True, False}, flag
    assert any(d.bumped for d in drawn)
    glass = re.findall(r"Density = ([\d.]+);\n  Reflection = ([\d.]+);\n  Refraction = ([\d.]+);",
                       "".join(d.text for d in drawn))
    unequal = [g for g in glass if float(g[2]) > 0 and float(g[0]) > 1 and g[1] != g[2]]
    assert len(unequal) >= 3


def test_inject_scales_exactly_one_value():
    """Evidence: closed form: each error multiplies one value of the page-4 scene by
    1 + fraction and leaves every other line alone."""
    from codermind_harness import randscene
    text = (ROOT / "scenes" / "page4.txt").read_text(encoding="utf-8")
    expect = {"colour": ("Diffuse = 0.35, 0.25, 0.01", "Diffuse = 0.385, 0.275, 0.011"),
              "light": ("Intensity = 5.0, 5.0, 5.0", "Intensity = 5.5, 5.5, 5.5"),
              "density": ("Density = 2.0", "Density = 2.2"),
              "bump": ("Bumplevel = 0.1", "Bumplevel = 0.11"),
              "camera": ("Perspective.FOV = 90.0", "Perspective.FOV = 99")}
    for error, (old, new) in expect.items():
        edited = randscene.inject(text, error, 0.1)
        changed = [(a, b) for a, b in zip(text.splitlines(), edited.splitlines()) if a != b]
        assert len(changed) == (2 if error == "colour" else 1), (error, changed)
        assert old in changed[0][0] and new in changed[0][1], (error, changed)
    assert randscene.inject((ROOT / "scenes" / "page1.txt").read_text(), "density", 0.1) is None


@pytest.mark.parametrize("seed", [1])
def test_compare_passes_tiny_random_scene(llvm, tmp_path, seed):
    """Evidence: our own two sides agreeing: a random scene at 40 x 30 and 16 spp (glass,
    mirrors, a blob, the cube map; see the tags) passes compare at its default thresholds."""
    from codermind_harness import randscene
    _needs_drawn_diffuse(llvm)
    txt, drawn = randscene.write_scene(tmp_path, seed, **TINY)
    rec = _compare(txt, tmp_path / "out")
    assert rec["passed"], (drawn.tags, rec["failures"])


def test_compare_catches_a_brighter_light_on_a_random_scene(llvm, tmp_path):
    """Evidence: an injected error: the Mitsuba side's Light0 20 % brighter than the port's
    on a tiny random scene fails compare."""
    from codermind_harness import randscene
    _needs_drawn_diffuse(llvm)
    txt, _ = randscene.write_scene(tmp_path, 1, **TINY)
    edited = tmp_path / "edited.txt"
    edited.write_text(randscene.inject(txt.read_text(), "light", 0.2), encoding="utf-8")
    rec = _compare(txt, tmp_path / "out", edited=edited)
    assert not rec["passed"]


@pytest.mark.parametrize("name", ["marble-mirror-glass", "glass-garden", "blob-lamp"])
def test_user_scene_passes_compare(llvm, tmp_path, name):
    """Evidence: our own two sides agreeing on a scene written as a user writes one
    (scenes/user/NAME.txt: glass with Reflection != Refraction, bump-mapped mirrors, a glass
    blob without a cube map, a diffuse blob's lit edge), every 3rd pixel, at 16 spp (1 where
    nothing is random), and z's sd that of two 16-sample estimates (about 1.03). Before
    both sides drew the diffuse event (sides.drawn_diffuse_xml), marble-mirror-glass (its
    glass blob's diffuse probability is 0.2) had 139 failing sub-samples over the whole
    frame (the port drew no diffuse event in 16 rays: variance 0, no light) and z sd 2.18;
    before shadow rays left analytic blob points without an offset, blob-lamp's lit edge
    had 232."""
    if name != "blob-lamp":
        _needs_drawn_diffuse(llvm)
    rec = _compare(USER / f"{name}.txt", tmp_path, spp=None if name == "blob-lamp" else 16,
                   stride=3)
    assert rec["passed"], rec["failures"]
    if rec["random"]:
        assert rec["z_test"]["z_sd"] < 1.15, rec["z_test"]


def test_drawn_diffuse_xml_sets_the_option_of_tutorialpath_only(monkeypatch):
    """Evidence: the XML text itself: the option goes into the tutorialpath element (open
    or self-closing), once; other integrators and XML that sets it already are left alone;
    nothing changes where the integrator lacks the option."""
    from codermind_harness import sides
    monkeypatch.setattr(sides, "draws_diffuse", lambda: True)
    option = '<boolean name="draw_diffuse" value="true"/>'
    text = (ROOT / "scenes" / "page4.xml").read_text(encoding="utf-8")
    new = sides.drawn_diffuse_xml(text)
    assert new.count(option) == 1
    assert re.search(r'<integrator type="tutorialpath">' + re.escape(option), new)
    assert sides.drawn_diffuse_xml(new) == new
    bare = '<scene><integrator type="tutorialpath"/><shape type="sphere"/></scene>'
    assert sides.drawn_diffuse_xml(bare) == ('<scene><integrator type="tutorialpath">' + option
                                             + '</integrator><shape type="sphere"/></scene>')
    path = '<scene><integrator type="path"/></scene>'
    assert sides.drawn_diffuse_xml(path) == path
    monkeypatch.setattr(sides, "draws_diffuse", lambda: False)
    assert sides.drawn_diffuse_xml(text) == text



NEGATIVE_TURBULENCE = """Scene
{
  Version.Major = 1; Version.Minor = 3; Image.Width = 40; Image.Height = 30;
  Perspective.Type = conic; Perspective.FOV = 60;
  Tonemap.Midpoint = 0.6; Tonemap.Power = 3.3; Tonemap.Black = 0.1;
  NumberOfMaterials = 1; NumberOfSpheres = 1; NumberOfLights = 1;
}
Material0 { Type = turbulence; Diffuse = 0, 0, 0; Diffuse2 = 0.9, 0.6, 0.3; Density = 1; }
Sphere0 { Center = 20, 15, 200; Size = 80; Material.Id = 0; }
Light0 { Position = -100, 100, 0; Intensity = 3, 3, 3; }
"""


def test_compare_takes_a_tone_curve_that_gives_nan(llvm, tmp_path):
    """Evidence: facts.md F7.2 and F6.2: a turbulence mix T Diffuse + (1 - T) Diffuse2 with
    Diffuse 0 is negative where T > 1, and the tone curve's c^P with Power 3.3 is NaN there on
    both sides (the original's byte for NaN is 0, codermind_ref.tonemap.to_bytes); compare
    shows it black on both sides instead of handing FLIP a NaN (which it refuses), and
    passes."""
    import codermind_ref as ref
    txt = tmp_path / "negative.txt"
    txt.write_text(NEGATIVE_TURBULENCE, encoding="utf-8")
    port = ref.render(ref.parse_scene(txt), "clean", workers=1)
    assert (port.linear < 0).any() and np.isnan(port.encoded).any()
    rec = _compare(txt, tmp_path / "out", spp=None)
    assert not rec["random"] and rec["passed"], rec["failures"]
    assert np.isfinite(rec["flip_mean"])
