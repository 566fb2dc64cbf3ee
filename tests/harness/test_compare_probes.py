"""The auto-exposure probes traced through Mitsuba (codermind.tutorial.render.probe_exposure,
as compare's Mitsuba side takes them) against the port's (codermind_ref): the probes draw
their roulette as the original does (facts.md F6.3, F8.3), so E varies with the seed and has
the port's distribution, not only its expectation. Evidence kind: our two sides agreeing
(the port draws the original's events), and facts.md F6.3 (E varies with the random
sequence)."""

from __future__ import annotations

import numpy as np
import pytest

from support import probe_scenes

SEEDS = range(16)


def exposures(mi, txt):
    """(port, Mitsuba drawn, Mitsuba with the expected lighting) E for SEEDS."""
    from codermind.tutorial.render import probe_exposure
    from codermind_harness import sides
    scene = sides.parse(txt)
    port = np.array(sides.port_exposures(scene, SEEDS))
    xml = sides.convert_xml(txt, scene, txt.parent)
    grid = sides.Grid.of(scene.width, scene.height, 4)
    scenes, settings = sides._load(xml, grid, {"spp": "4"}, True)
    drawn = np.array([probe_exposure(scenes, settings, s) for s in SEEDS])
    # the converted scene as it is (not compare's iid side, which draws the event as well)
    plain, _ = sides._load(xml, grid, {"spp": "4"}, False)
    integrator = plain[0].integrator()
    assert not integrator.draw_diffuse
    expected = np.array([probe_exposure(plain, settings, s, integrator=integrator)
                         for s in SEEDS])
    return port, drawn, expected


def agree(x, y, sds: float = 4.0) -> bool:
    se = np.sqrt(x.var(ddof=1) / x.size + y.var(ddof=1) / y.size)
    return abs(x.mean() - y.mean()) <= sds * se


def test_glass_sphere_probes_vary_with_the_seed_and_match_the_port(llvm, tmp_path):
    port, drawn, _ = exposures(llvm, probe_scenes.write(tmp_path, probe_scenes.GLASS))
    assert np.unique(drawn).size == drawn.size           # every seed its own E
    assert port.std(ddof=1) > 0 and drawn.std(ddof=1) > 0
    assert agree(drawn, port)


def test_half_mirror_probes_have_the_originals_exposure(llvm, tmp_path):
    # lit half the time by the original's draw: E = 1 / rms, so the lighting's expectation
    # at every hit (no draw) gives another E, the same for every seed where nothing else draws
    port, drawn, expected = exposures(llvm, probe_scenes.write(
        tmp_path, probe_scenes.HALF_MIRROR, sky={f: (5, 5, 5) for f in probe_scenes.FACES}))
    assert agree(drawn, port)
    assert expected.mean() > 1.2 * port.mean() and expected.std() < 0.1 * port.std()


@pytest.mark.parametrize("seed", [0, 1, 3])
def test_random_scene_exposures_agree_within_2_percent(llvm, tmp_path, seed):
    port, drawn, _ = exposures(llvm, probe_scenes.random_scene(tmp_path, seed))
    assert abs(drawn.mean() / port.mean() - 1) < 0.02
    assert agree(drawn, port)


def test_probe_integrator_is_a_drawing_copy_of_the_scenes(llvm):
    from codermind.tutorial.render import probe_integrator
    base = llvm.load_dict({"type": "tutorialpath", "max_depth": 7, "quirks": "strict",
                           "min_distance": 0.25})
    probe = probe_integrator(base)
    assert probe is not base and probe.draw_diffuse and not base.draw_diffuse
    assert (probe.max_depth, probe.quirks, probe.min_distance, probe.exact_hits) == \
        (7, "strict", 0.25, base.exact_hits)
    assert probe_integrator(base) is probe                   # kept
    path = llvm.load_dict({"type": "path"})
    assert probe_integrator(path) is path
