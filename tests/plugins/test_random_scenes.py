"""Properties of random scenes nobody tuned anything to (drawn by tests/support/random_scenes.py: any
world scale, built-in and our shapes, BSDFs, textures, lights and cameras mixed), rendered
with ``path``, ``prb``, ``direct`` and ``tutorialpath`` (clean; strict where the scene is in
the tutorial's style) in ``llvm_ad_rgb``, and in ``scalar_rgb`` at 4 x 4 pixels in a worker
process (a crash there ends the worker, not the test run).

CI runs the "ci" hypothesis profile: a few derandomized scenes per property (the two render
properties of each variant see the same scenes, rendered once). A long run with its counts
is ``benchmarks/random_scenes.py`` (docs/results/random-scenes.md)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import assume, given, seed

from support import random_scenes as rs
from support import PROFILE, examples

SPP = 2                  #: samples per pixel of the render properties
K, K_SPP = 8, 16         #: independent renders per side and their spp in the z-test
ALPHA = 1e-3             #: the z-test's false-alarm rate per scene (at most)

#: In the "ci" profile the render properties of a variant draw the same scenes (one seed),
#: so that each scene is rendered once for both; the long profile draws at random.
same_scenes = seed(20261205) if PROFILE == "ci" else (lambda test: test)


@pytest.fixture(scope="module")
def assets(tmp_path_factory):
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    return rs.write_assets(mi, tmp_path_factory.mktemp("assets"))


@pytest.fixture(scope="module")
def worker(assets):
    w = rs.Worker(assets)
    yield w
    w.close()


def _key(spec: dict, *rest) -> str:
    return json.dumps([spec, *rest], sort_keys=True)


_llvm_renders: dict = {}
_scalar_renders: dict = {}


def llvm_renders(mi, assets, spec: dict) -> dict:
    """Every integrator's render of ``spec`` in llvm_ad_rgb (cached per scene)."""
    key = _key(spec)
    if key not in _llvm_renders:
        _llvm_renders[key] = {
            name: rs.render(mi, spec, assets, name, spp=SPP)
            for name in rs.INTEGRATORS
            if name != "tutorialpath_strict" or rs.strict_allowed(spec)}
    return _llvm_renders[key]


def scalar_renders(worker, spec: dict) -> dict:
    """Every integrator's render of ``spec`` in scalar_rgb, 4 x 4 pixels, by the worker."""
    key = _key(spec)
    if key not in _scalar_renders:
        _scalar_renders[key] = {
            name: worker.run({"variant": "scalar_rgb", "spec": spec, "integrator": name,
                              "spp": SPP, "size": 4})
            for name in rs.SCALAR_INTEGRATORS
            if name != "tutorialpath_strict" or rs.strict_allowed(spec)}
    return _scalar_renders[key]


def _refusal_failures(results: dict, spec: dict) -> list[str]:
    return [f"{name}: {r['error']}: {r['message']}" for name, r in results.items()
            if "error" in r and not rs.is_refusal(r, spec)]


# -- nothing crashes, refusals are one line, films are finite ---------------------------------

@same_scenes
@examples(ci=4, long=200, shrink=False)
@given(spec=rs.scenes())
def test_random_scene_renders_or_refuses_in_one_line(llvm, assets, spec):
    """Evidence: each integrator either renders the scene or refuses it with a ValueError or
    RuntimeError whose one-line message names a plugin of the scene and a quoted parameter
    (an exception of any other kind, or a message without them, is a crash)."""
    results = llvm_renders(llvm, assets, spec)
    assert not _refusal_failures(results, spec)


@same_scenes
@examples(ci=4, long=200, shrink=False)
@given(spec=rs.scenes())
def test_random_scene_film_is_finite(llvm, assets, spec):
    """Evidence: every rendered film (each integrator, llvm_ad_rgb) has no NaN or inf."""
    results = llvm_renders(llvm, assets, spec)
    bad = [name for name, r in results.items()
           if "images" in r and not all(np.isfinite(i).all() for i in r["images"])]
    assert not bad, f"non-finite pixels from {bad}"


@same_scenes
@examples(ci=2, long=50, shrink=False)
@given(spec=rs.scenes())
def test_random_scene_does_not_crash_in_scalar(assets, worker, spec):
    """Evidence: the scalar_rgb worker answers for every integrator (a segfault ends it with
    a non-zero exit status) and every refusal is one line naming plugin and parameter."""
    results = scalar_renders(worker, spec)
    crashed = {name: r["exit"] for name, r in results.items() if "exit" in r}
    assert not crashed, f"worker exit status per integrator: {crashed}"
    assert not _refusal_failures(results, spec)


@same_scenes
@examples(ci=2, long=50, shrink=False)
@given(spec=rs.scenes())
def test_random_scene_film_is_finite_in_scalar(assets, worker, spec):
    """Evidence: every film the scalar_rgb worker renders has no NaN or inf."""
    results = scalar_renders(worker, spec)
    bad = [name for name, r in results.items() if "finite" in r and not r["finite"]]
    assert not bad, f"non-finite pixels from {bad}"


# -- clean tutorialpath has path's expectation ------------------------------------------------

@examples(ci=4, long=200, shrink=False)
@given(spec=rs.scenes())
def test_clean_tutorialpath_has_the_expectation_of_path(llvm, assets, spec):
    """Evidence: Mitsuba's built-in ``path`` (no Russian roulette: ``rr_depth`` beyond
    ``max_depth``) against ``tutorialpath`` clean with ``exact_hits`` false, whose docstring
    claims path's expected value on every scene: per pixel and channel a two-sample test of
    K = 8 independent renders a side (distinct seeds, 16 spp each; tests/support/zstat.py
    ``t_test``), Sidak-corrected over the scene's values, so that a scene where both agree
    fails with probability at most 1e-3. Blobs without a mesh are skipped (``path`` does not
    see them)."""
    mi = llvm
    assume(not rs.has_analytic_blob(spec))
    out = rs.compare(mi, spec, assets, K, K_SPP, ALPHA)
    a, b = out["path"], out["tutorialpath"]
    if "error" in a or "error" in b:     # refused: the same refusal on both sides
        assert a.get("message") == b.get("message")
        return
    assert rs.finite(a) and rs.finite(b)
    assert out["test"].passed, str(out["test"])
