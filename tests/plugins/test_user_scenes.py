"""The scenes of scenes/user/, written as a new user would write them (nobody tuned anything
to them): a room of rectangle walls with a ceiling area light, a tutorialpoint, a
four-source blob in blinnphong, noisebump around roughplastic and marble feeding diffuse
(room.xml); a glass blob and a gold sphere under an envmap (glass.xml); the conic camera's
tutorial lens with the cube map and turbulence (lens.xml). Each loads, prints, renders
without NaN or inf in llvm_ad_rgb and (4 x 4 pixels, in a worker process) in scalar_rgb, and
clean tutorialpath agrees with path on it."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from support import random_scenes as rs
from support import zstat
from support import ROOT

USER = ROOT / "scenes" / "user"
SCENES = ["room", "glass", "lens"]
K, K_SPP, ALPHA = 8, 16, 1e-3     #: the z-test: renders a side, their spp, alpha per scene
SMALL = {"resx": 40, "resy": 30}  #: the z-test's film


def defaults(name: str) -> dict:
    """The ``<default>`` values of a scene file."""
    root = ET.parse(USER / f"{name}.xml").getroot()
    return {d.get("name"): d.get("value") for d in root.iter("default")}


@pytest.fixture(scope="module")
def worker(tmp_path_factory):
    w = rs.Worker(tmp_path_factory.mktemp("assets"))
    yield w
    w.close()


@pytest.mark.parametrize("name", SCENES)
def test_user_scene_renders_finite_and_prints(llvm, name):
    """Evidence: Mitsuba's own loader, ``str(scene)`` and a render with the scene's own
    integrator (``path`` with its Russian roulette) at its default spp, on a film a quarter
    of the default size: every value finite, the image not black."""
    mi = llvm
    d = defaults(name)
    scene = rs.load_file(mi, USER / f"{name}.xml", resx=int(d["resx"]) // 2,
                         resy=int(d["resy"]) // 2)
    assert str(scene).startswith("Scene[")
    image = np.array(mi.render(scene, seed=0))
    assert np.isfinite(image).all()
    assert image.mean() > 0.01


def test_user_scenes_render_finite_in_scalar(worker):
    """Evidence: each scene in scalar_rgb, 4 x 4 pixels, 2 spp, its own integrator, in the
    worker process (a crash there is its non-zero exit status): finite, and it prints."""
    for name in SCENES:
        answer = worker.run({"kind": "file", "variant": "scalar_rgb", "spec": None,
                             "file": str(USER / f"{name}.xml"), "spp": 2,
                             "params": {"resx": 4, "resy": 4}})
        assert "exit" not in answer, f"{name}: worker exit status {answer.get('exit')}"
        assert "error" not in answer, f"{name}: {answer}"
        assert answer["finite"] and answer["printed"], name


@pytest.mark.parametrize("name", SCENES)
def test_clean_tutorialpath_has_the_expectation_of_path_on_user_scene(llvm, name):
    """Evidence: Mitsuba's built-in ``path`` (the scene's ``max_depth``, no Russian roulette)
    against ``tutorialpath`` clean with ``exact_hits`` false (its docstring claims path's
    expected value on every scene): K = 8 independent renders a side of 16 spp on a 40 x 30
    film, tests/support/zstat.py ``t_test``, Sidak-corrected over the values: a false alarm in at most
    1e-3 of runs where both agree."""
    mi = llvm
    depth = int(defaults(name)["max_depth"])
    scene = rs.load_file(mi, USER / f"{name}.xml", **SMALL)
    sides = []
    for integrator, seeds in (("path", range(K)), ("tutorialpath", range(K, 2 * K))):
        integrator = mi.load_dict(rs.integrator(integrator, depth))
        images = [np.array(mi.render(scene, integrator=integrator, spp=K_SPP, seed=s),
                           dtype=np.float64) for s in seeds]
        assert all(np.isfinite(i).all() for i in images)
        sides.append(zstat.renders(images))
    result = zstat.t_test(*sides, ALPHA)
    assert result.passed, str(result)
