"""The verdict's statistics beyond the per-sub-sample pass rate (codermind_harness.metrics,
verdict): the gross bound that no pass-rate allowance excuses, sides whose variance could not
be estimated (every sample took one branch), the calibration report, and the exposure test
when one side's exposure does not vary. Evidence kind: closed form (binomial enumeration,
Fisher-type permutation counts) and synthetic images with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom, norm

from codermind_harness import metrics, verdict


def noisy_pair(rng, shape, sd_mean=0.02):
    mean = rng.uniform(0.2, 1.0, shape)
    a = mean + sd_mean * rng.standard_normal(shape)
    b = mean + sd_mean * rng.standard_normal(shape)
    v = np.full(shape, sd_mean ** 2)
    return a, v, b, v.copy()


COUNTS = {"dof_a": 15, "dof_b": 63, "n_a": 64, "n_b": 64}     # compare's page 4


def scene_tests(z: metrics.ZTest) -> verdict.Tests:
    """A random scene's Tests with everything but the z-test passing."""
    return verdict.Tests(z, slice(None), 0.001, np.zeros((1, 1)), 0.0, 0.0, None, None,
                         flip_noise=0.05)


def test_one_huge_z_fails_the_scene_at_pass_rate_0999():
    rng = np.random.default_rng(3)
    a, va, b, vb = noisy_pair(rng, (25, 40, 3))            # 1000 sub-samples
    a[7, 11, 1] += 192 * math.sqrt(va[7, 11, 1] + vb[7, 11, 1])
    z = metrics.z_test(a, va, b, vb, **COUNTS)
    assert z.pass_rate == pytest.approx(0.999)             # the allowance would pass it
    assert z.gross == 1 and z.gross_sub_samples == 1
    failures, _ = verdict.port_failures(scene_tests(z), True, 1000, verdict.Thresholds())
    assert len(failures) == 1 and failures[0].startswith("z-test: 1 sub-samples")
    assert "differ grossly" in failures[0] and "3 per-sample sds" in failures[0]


def test_a_z_just_beyond_sidak_but_inside_the_gross_bound_is_left_to_the_pass_rate():
    rng = np.random.default_rng(4)
    a, va, b, vb = noisy_pair(rng, (25, 40, 3))
    z0 = metrics.z_test(a, va, b, vb, **COUNTS)
    assert z0.z_critical < z0.z_gross                      # 4.6 and 6.6 at N = 3000
    step = 1.3 * z0.z_critical                             # a z of 6.0
    a[3, 5, 0] += step * math.sqrt(va[3, 5, 0] + vb[3, 5, 0])
    z = metrics.z_test(a, va, b, vb, **COUNTS)
    assert z.pass_rate == pytest.approx(0.999)
    assert z.gross == 0 and z.max_score < z0.z_gross    # t-aware: t 6.0 at ~27 df
    failures, _ = verdict.port_failures(scene_tests(z), True, 1000, verdict.Thresholds())
    assert failures == []


def test_a_certain_but_small_difference_is_left_to_the_pass_rate():
    # page 4's blob at 64 spp (measured): means 0.370 and 0.169, per-sample sds 0.10 and
    # 0.19: a score of 6.4 beyond the Sidak bound of a crop, but 1.3 per-sample sds apart
    rng = np.random.default_rng(5)
    a, va, b, vb = noisy_pair(rng, (25, 40, 3))
    a[2, 2, 0], va[2, 2, 0] = 0.37039, 0.000167
    b[2, 2, 0], vb[2, 2, 0] = 0.16948, 0.000589
    z = metrics.z_test(a, va, b, vb, **COUNTS)
    assert z.max_score > 6.3 > z.z_critical and z.pass_rate == pytest.approx(0.999)
    z_strict = metrics.z_test(a, va, b, vb, **COUNTS, gross_effect=1.0)
    assert z_strict.gross == 1 and z_strict.max_score > z_strict.z_gross - 0.5
    # the same bias with 256 x the samples: the score grows 16-fold, the effect does not
    z256 = metrics.z_test(a, va / 256, b, vb / 256, dof_a=15, dof_b=255 * 4 + 3,
                          n_a=64 * 256, n_b=64 * 256)
    assert z256.max_score > 2 * z256.z_gross and z256.gross == 0


def test_gross_bound_is_sidak_at_its_family_level():
    zero = np.zeros((960, 1280, 3))                        # a 640 x 480 page 4
    z = metrics.z_test(zero, zero, zero, zero, gross_alpha=1e-6)
    assert 2 * norm.sf(z.z_gross) == pytest.approx(metrics.sidak_alpha(1e-6, zero.size),
                                                   rel=1e-6)
    assert 7.2 < z.z_gross < 7.4


def bernoulli_grid(n: int):
    """Every outcome (k_a, k_b) of two sides of n Bernoulli samples: means and the
    variances of the means, as (n + 1, n + 1, 3) images."""
    k = np.arange(n + 1)
    ka, kb = np.meshgrid(k, k, indexing="ij")

    def side(kk):
        m = kk / n
        return m, kk * (n - kk) / (n * (n - 1)) / n

    (a, va), (b, vb) = side(ka), side(kb)
    return ka, kb, [np.repeat(x[..., None], 3, axis=2) for x in (a, va, b, vb)]


@pytest.mark.parametrize("p", [0.02, 0.05, 0.1, 0.2])
def test_zero_variance_side_keeps_the_level_exactly(p):
    """Bernoulli(p) radiance, 16 samples a side: P(a side's 16 samples are equal) is
    (1 - p)^16 (0.44 at p = 0.05). Enumerating every outcome (k_a, k_b) with its binomial
    probability gives each statistic's exact rejection rate."""
    n = 16
    ka, kb, (a, va, b, vb) = bernoulli_grid(n)
    w = binom.pmf(ka, n, p) * binom.pmf(kb, n, p)
    ws = metrics.welch_scores(a, va, b, vb, n - 1, n - 1, n, n)
    score = np.abs(ws.score[..., 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        exact_side = np.where(va + vb > 0, np.abs(a - b) / np.sqrt(va + vb), 0.0)[..., 0]
    for c in (2.576, 3.291, 4.417):
        assert w[score > c].sum() <= 2 * norm.sf(c)
    if p == 0.2:     # a zero-variance side taken as exact: 2.3 times the level at 1e-5
        assert w[exact_side > 4.417].sum() > 2 * 2 * norm.sf(4.417)
    # no outcome at all comes near the gross bound of a page-4 frame
    z_gross = -norm.ppf(metrics.sidak_alpha(1e-6, 3 * 4 * 640 * 480) / 2)
    assert score.max() < z_gross


def test_a_side_without_variance_takes_the_others_per_sample_variance():
    # side a: 16 equal samples (0); side b: 8 ones in 16 (closed form below)
    a, va = np.zeros((1, 1, 3)), np.zeros((1, 1, 3))
    b = np.full((1, 1, 3), 0.5)
    s2 = 8 * 8 / (16 * 15)                 # b's sample variance
    vb = np.full((1, 1, 3), s2 / 16)
    ws = metrics.welch_scores(a, va, b, vb, 15, 15, 16, 16)
    t = -0.5 / math.sqrt(2 * s2 / 16)      # var_b (1 + n_b / n_a), b's 15 degrees of freedom
    from scipy.stats import t as student_t
    expect = norm.isf(student_t.sf(abs(t), 15)) * np.sign(t)
    assert ws.score[0, 0, 0] == pytest.approx(expect, rel=1e-9)
    assert ws.dof[0, 0, 0] == 15 and ws.one_side.all() and not ws.both.any()
    assert ws.var[0, 0, 0] == pytest.approx(2 * s2 / 16)
    # the other way round (b without variance), and counts of another size: var_a n_a / n_b
    ws2 = metrics.welch_scores(b, vb, a, va, 15, 63, 16, 64)
    assert ws2.var[0, 0, 0] == pytest.approx(s2 / 16 + s2 / 64)
    assert ws2.dof[0, 0, 0] == 15


def test_neither_side_varying_is_judged_by_the_float_tolerance_not_the_gross_bound():
    a = np.zeros((1, 2, 3))
    b = np.zeros((1, 2, 3))
    b[0, 1] = 1.0                          # every sample of b took another branch
    zero = np.zeros_like(a)
    z = metrics.z_test(a, zero, b, zero, **COUNTS)
    assert z.passed_map.tolist() == [[True, False]]
    assert z.zero_variance == {"one_side": 0, "both_sides": 3} and z.gross == 0


def test_calibration_of_null_scores_is_unit_sd_and_flat():
    rng = np.random.default_rng(7)
    a, va, b, vb = noisy_pair(rng, (100, 100, 3))
    z = metrics.z_test(a, va, b, vb)
    c = z.calibration
    assert c["n"] == 30_000 and abs(c["sd"] - 1) < 0.03 and abs(c["sd_robust"] - 1) < 0.04
    hist = np.array(c["p_hist"])
    assert hist.sum() == 30_000 and len(hist) == 10
    assert np.all(np.abs(hist - 3000) < 5 * math.sqrt(3000))   # flat within 5 sd
    # a bias of 3 sd of a side over a third of the image: the first bin fills
    a[:33] += 0.02 * 3
    c2 = metrics.z_test(a, va, b, vb).calibration
    assert c2["p_hist"][0] > 2 * c["p_hist"][0] and c2["sd"] > 1.2
    assert c2["p_hist"][-1] < c["p_hist"][-1]


def test_pooled_tests_report_their_calibration():
    rng = np.random.default_rng(8)
    a, va, b, vb = noisy_pair(rng, (64, 64, 3))
    pooled = metrics.pooled_difference(a, va, b, vb, metrics.tile_labels((64, 64), 8),
                                       "tiles", 15, 63)
    c = pooled.calibration
    assert c["n"] == pooled.tests == 192 and sum(c["p_hist"]) == 192
    assert 0.7 < c["sd"] < 1.3


# -- the exposure test with one side constant ---------------------------------------------

def test_exposure_constant_side_against_a_bimodal_one_8_percent_apart_fails():
    # the reported case: Mitsuba 20.2626 for all 8 seeds, the port bimodal, mean 18.75 sd 2.06
    port = np.array([16.9, 20.6, 16.9, 20.6, 16.9, 20.6, 16.9, 20.6]) \
        + np.array([0.1, -0.2, 0.3, 0.0, -0.1, 0.2, -0.3, 0.05])
    e = metrics.exposure_test([20.2626] * 8, port)
    assert e.p > 1e-3                          # Welch (one-sample t, df 7) alone passes it
    assert e.df == pytest.approx(7.0)
    assert e.method == "welch + spread" and not e.passed
    assert e.p_spread == pytest.approx(1 / math.comb(16, 8))
    assert "same for every seed" in verdict.exposure_failure(e)


def test_exposure_constant_side_against_a_tight_one_8_percent_apart_fails_by_welch():
    rng = np.random.default_rng(2)
    e = metrics.exposure_test([20.2626] * 8, rng.normal(20.2626 / 1.08, 0.15, 8))
    assert not e.passed and e.p < 1e-6 and e.df == pytest.approx(7.0)


def test_exposure_constant_side_passes_where_the_other_side_mostly_agrees():
    # E from a probe set whose randomness rarely fires: 6 of the port's 8 equal Mitsuba's
    e = metrics.exposure_test([20.0] * 8, [20.0] * 6 + [20.4, 19.6])
    assert e.passed and e.p_spread == pytest.approx(math.comb(14, 8) / math.comb(16, 8))


def test_constant_split_p_counts_clusters():
    assert metrics.constant_split_p(2, [1, 1, 2, 2], 0.0) == pytest.approx(2 / 6)
    assert metrics.constant_split_p(2, [1, 1.05, 2, 2], 0.1) == pytest.approx(2 / 6)
    assert metrics.constant_split_p(3, [1, 2, 3, 4, 5, 6], 0.0) == 0.0


def test_object_labels_see_the_analytic_blob(llvm):
    """The converted page 4 leaves its blob without a mesh (tutorialpath intersects the
    zone field); the labels of the pooled-object test see it through a coarse mesh.
    Evidence kind: our own scene (the blob covers most of the crop where Light0 lands)."""
    from pathlib import Path
    from codermind_harness import sides
    root = Path(__file__).resolve().parents[2] / "scenes"
    grid = sides.Grid.of(640, 480, 4, (56, 248, 88, 272))
    lab, names = sides.object_labels(root / "page4.xml", grid, {"spp": "64"})
    blob = [k for k, n in enumerate(names) if n.endswith("blob")]
    assert len(blob) == 1
    share = float((lab == blob[0]).mean())
    assert 0.7 < share < 0.95 and (lab == -1).any()          # the blob and the sky beside it
