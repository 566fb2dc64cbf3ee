"""The model chooser (codermind.tutorial.model, run by `codermind convert`): depth, samples,
blob tessellation, overrides; and that the chosen depth keeps its error promise."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import codermind_ref as ref
from codermind.tutorial import model as tm
from support import ROOT, run_cli

SCENES = ROOT / "scenes"


def variant(tmp_path: Path, source: Path, *replacements: tuple[str, str]) -> Path:
    text = source.read_text()
    for old, new in replacements:
        assert old in text, old
        text = text.replace(old, new)
    out = tmp_path / source.name
    out.write_text(text)
    if (source.parent / "sky").is_dir() and not (tmp_path / "sky").exists():
        (tmp_path / "sky").symlink_to(source.parent / "sky")
    return out


def defaults(xml: Path) -> dict[str, str]:
    return dict(re.findall(r'<default name="(\w+)" value="([^"]+)"/>', xml.read_text()))


def test_depth_1_without_reflection_or_refraction(tmp_path):
    scene = ref.parse_scene(variant(tmp_path, SCENES / "page2.txt",
                                    *[(f"Reflection = 0.5; Specular = 1.0, 1.0, 1.0; Power = 60; }}",
                                       "Reflection = 0.0; Specular = 1.0, 1.0, 1.0; Power = 60; }")]))
    model = tm.choose(scene)
    assert model.max_depth == 2 and "no material reflects" in model.reasons["max_depth"]


def test_full_depth_with_a_perfect_mirror():
    model = tm.choose(ref.parse_scene(SCENES / "page3.txt"))
    assert model.max_depth == 11 and "weight 1" in model.reasons["max_depth"]


def test_one_sample_when_nothing_is_random():
    for name in ("page1.txt", "page2.txt", "page3.txt"):
        model = tm.choose(ref.parse_scene(SCENES / name))
        assert model.spp == 1 and not model.stochastic, name


def test_complexity_when_lens_or_roulette_is_random(tmp_path):
    model = tm.choose(ref.parse_scene(SCENES / "page4.txt"))
    assert model.stochastic and model.spp == 16
    assert "lens blur" in model.reasons["spp"] and "Material3" in model.reasons["spp"]
    # no lens, no blob: the marble (density 1: R = 0) and the metals are certain
    quiet = variant(tmp_path, SCENES / "page4.txt", ("Dispersion = 10.0", "Dispersion = 0.0"),
                    ("NumberOfBlobs = 1", "NumberOfBlobs = 0"))
    assert tm.choose(ref.parse_scene(quiet)).spp == 1
    # a half-reflecting metal rolls the dice
    (tmp_path / "b").mkdir()
    half = variant(tmp_path / "b", quiet, ("Reflection = 1.0;", "Reflection = 0.5;"))
    model = tm.choose(ref.parse_scene(half))
    assert model.stochastic and model.spp == 16 and "Material1" in model.reasons["spp"]


def test_material_classification():
    class M:   # a page-4 material
        def __init__(self, reflection=0.0, refraction=0.0, density=0.0):
            self.reflection, self.refraction, self.density = reflection, refraction, density
    assert tm.continuation_weight(M(1.0), 4) == 1.0                   # metal mirror
    assert tm.continuation_weight(M(0.01, 0, 1.0), 4) == 0.0          # density 1: R = 0
    assert tm.continuation_weight(M(0, 0.9, 0.0), 4) == 0.0           # metal never refracts
    assert tm.continuation_weight(M(0.5, 0.9, 2.0), 4) == 0.9
    assert not tm.roulette_is_random(M(1.0), 4) and tm.roulette_is_random(M(0.5), 4)
    assert not tm.roulette_is_random(M(0.3, 1.0, 1.0), 4)             # R = 0, Tr = 1
    assert tm.roulette_is_random(M(0.9, 0.9, 2.0), 4)


def test_blob_max_error_from_the_footprint():
    scene = ref.parse_scene(SCENES / "page4.txt")
    model = tm.choose(scene)
    reach = tm._blob_reach(3) * 80          # where one of 3 sources must give >= 1/3
    assert reach == pytest.approx(math.sqrt(10 / 3 - (1 / 3 - 0.3) / 0.1 * (10 / 3 - 2.5)) * 80)
    eye = np.array([320.0, 240.0, 0.0])
    nearest = min(np.linalg.norm(np.array(c) - eye) for c in scene.blobs[0].centers) - reach
    pd = 320 / math.tan(math.radians(45))
    assert model.blob_max_error[0] == pytest.approx(tm.BLOB_FRACTION * 0.5 * nearest / pd)


def test_overrides_are_baked_into_the_xml(tmp_path):
    out = tmp_path / "p4.xml"
    result = run_cli("convert", SCENES / "page4.txt", "-o", out, "--max-depth", "5", "--spp",
                     "3", "--blob-max-error", "0.5")
    assert result.returncode == 0, result.stderr
    assert defaults(out) == {"max_depth": "5", "quirks": "clean", "min_distance": "0.1", "spp": "3",
                             "blob0_max_error": "0.5", "blob_tessellate": "false"}
    assert result.stdout.count("given by the user") == 3
    assert ("codermind convert page4.txt -o p4.xml with the options max-depth=5 spp=3 "
            "blob-max-error=0.5") in out.read_text()
    bad = run_cli("convert", SCENES / "page4.txt", "-o", out, "--spp", "0")
    assert bad.returncode == 2 and "--spp" in bad.stderr


@pytest.mark.parametrize("page", [1, 2])
def test_chosen_depth_keeps_the_target(llvm, tmp_path, page):
    """Weak mirrors (Reflection 0.1): the chosen depth is below 10, and its image is within
    the target of the full model's (before truncation), measured."""
    from codermind.tutorial import render as tr
    from codermind.tutorial.image import srgb_encode
    source = variant(tmp_path, SCENES / f"page{page}.txt",
                     *[("Reflection = 0.5;", "Reflection = 0.1;")])
    xml = tmp_path / "s.xml"
    result = run_cli("convert", source, "-o", xml)
    assert result.returncode == 0, result.stderr
    chosen = int(defaults(xml)["max_depth"])
    assert 3 <= chosen <= 7
    bound = float(re.search(r"at most ([\d.e-]+) levels", result.stdout)[1])
    values = {}
    for depth in (chosen, 11):
        scene, settings = tr.load(xml, max_depth=depth)
        tone = tr.render(scene, settings).image.tonemapped
        values[depth] = 255 * (tone if page == 1 else srgb_encode(tone))
    error = np.abs(values[chosen] - values[11]).max()
    assert 0 < error <= bound <= tm.DEFAULT_TARGET


def test_page4_bound_uses_the_traced_exposure(llvm, tmp_path):
    source = variant(tmp_path, SCENES / "page4.txt", ("NumberOfBlobs = 1", "NumberOfBlobs = 0"),
                     ("Reflection = 1.0;", "Reflection = 0.5;"))
    result = run_cli("convert", source, "-o", tmp_path / "s.xml")
    assert result.returncode == 0, result.stderr
    line = next(x for x in result.stdout.splitlines() if "max_depth" in x)
    assert re.search(r"at exposure \d", line), line
    depth = int(defaults(tmp_path / "s.xml")["max_depth"])
    assert 3 <= depth <= 11
