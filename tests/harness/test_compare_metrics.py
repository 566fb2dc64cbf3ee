"""The statistics of ``codermind compare`` (codermind_harness.metrics) on synthetic images
with known answers: the Sidak-corrected z-test, the float tolerance, FLIP's input guard,
relative MSE."""

from __future__ import annotations

import math

import numpy as np
import pytest

from codermind_harness import metrics


def noisy_means(rng, mean, sd_mean, shape):
    """Per-pixel means with the given sd of the mean, and the variance each side reports."""
    return mean + sd_mean * rng.standard_normal(shape), np.full(shape, sd_mean ** 2)


def test_sidak_level_makes_the_family_level_alpha():
    assert metrics.sidak_alpha(0.01, 1) == pytest.approx(0.01, rel=1e-12)
    for n in (3, 1000, 3 * 1280 * 960):
        level = metrics.sidak_alpha(0.01, n)
        assert -math.expm1(n * math.log1p(-level)) == pytest.approx(0.01, rel=1e-12)
        assert level == pytest.approx(0.01 / n, rel=0.01)     # Bonferroni, to first order


def test_critical_z_is_the_two_sided_normal_quantile():
    zero = np.zeros((1, 1, 3))
    z = metrics.z_test(zero, zero, zero, zero)
    level = 1 - 0.99 ** (1 / 3)
    assert z.tests == 3 and z.alpha == pytest.approx(level)
    assert math.erfc(z.z_critical / math.sqrt(2)) == pytest.approx(level, rel=1e-9)


def test_z_is_the_difference_over_the_combined_sd():
    a = np.full((1, 2, 3), 1.0)
    b = np.zeros((1, 2, 3))
    va = np.stack([np.full(3, 0.125), np.full(3, 0.005)])[None]   # sd 0.5 / 0.1 combined
    z = metrics.z_test(a, va, b, va)
    assert z.z_map[0] == pytest.approx([2.0, 10.0])
    assert z.passed_map.tolist() == [[True, False]]     # z_critical is 2.94 for N = 6
    assert z.pass_rate == 0.5 and z.channel_pass_rate == 0.5


def test_same_distribution_passes_with_unit_z_spread():
    rng = np.random.default_rng(1)
    shape = (100, 100, 3)
    mean = rng.uniform(0.1, 2.0, shape)
    a, va = noisy_means(rng, mean, 0.05, shape)
    b, vb = noisy_means(rng, mean, 0.02, shape)
    z = metrics.z_test(a, va, b, vb)
    # 30,000 tests at a family level of 0.01: P(any fails) = 0.01
    assert z.pass_rate == 1.0
    assert z.noisy_tests == 30_000 and z.noiseless == 0
    assert abs(z.z_mean) < 0.03 and abs(z.z_sd - 1) < 0.03   # sd of the estimates ~0.006


def test_a_bias_of_ten_sd_fails_exactly_where_it_is():
    rng = np.random.default_rng(2)
    shape = (40, 40, 3)
    a, va = noisy_means(rng, 1.0, 0.01, shape)
    b, vb = noisy_means(rng, 1.0, 0.01, shape)
    a[:10, :, 1] += 10 * math.sqrt(2) * 0.01 + 0.1      # z about 17 > z_critical 4.9
    z = metrics.z_test(a, va, b, vb)
    assert not z.passed_map[:10].any() and z.passed_map[10:].all()
    assert z.pass_rate == 0.75


def test_noiseless_pixels_must_agree_within_the_float_tolerance():
    a = np.full((1, 3, 3), 0.5)
    b = a.copy()
    b[0, 1] += 0.4 * (metrics.RTOL * 0.5 + metrics.ATOL)     # inside the tolerance
    b[0, 2] += 2.0 * (metrics.RTOL * 0.5 + metrics.ATOL)     # outside: no noise excuses it
    zero = np.zeros_like(a)
    z = metrics.z_test(a, zero, b, zero)
    assert z.passed_map.tolist() == [[True, True, False]]
    assert z.z_map[0].tolist() == [0.0, 0.0, math.inf]
    assert z.noiseless == 3 and z.noisy_tests == 0 and z.z_sd is None


def test_rounding_variance_does_not_count_as_noise():
    # a side summing 64 equal float values in another order reports a variance of ~1e-20
    a = np.full((2, 2, 3), 0.0479050)
    b = a + 6e-8
    z = metrics.z_test(a, np.zeros_like(a), b, np.full_like(a, 3e-20))
    assert z.pass_rate == 1.0
    assert z.noisy_tests == 0 and z.max_z is None


def test_z_test_refuses_bad_images():
    good = np.zeros((2, 2, 3))
    with pytest.raises(ValueError, match="one shape"):
        metrics.z_test(good, good, np.zeros((2, 3, 3)), good)
    bad = good.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        metrics.z_test(bad, good, good, good)
    with pytest.raises(ValueError, match="variance"):
        metrics.z_test(good, bad, good, good)


def test_rel_mse_analytic():
    ref = np.zeros((4, 4, 3))
    assert metrics.rel_mse(ref + 0.1, ref) == pytest.approx(0.01 / 0.01)
    assert metrics.rel_mse(ref + 2.0, ref + 1.0) == pytest.approx(1 / 1.01)
    assert metrics.rel_mse(ref + 1.0, ref + 1.0) == 0.0
    with pytest.raises(ValueError, match="shapes differ"):
        metrics.rel_mse(ref, ref[:2])


def test_flip_of_identical_images_is_zero_and_of_black_and_white_large():
    rng = np.random.default_rng(3)
    img = rng.uniform(0, 1, (32, 32, 3))
    mean, error_map = metrics.flip(img, img)
    assert mean == 0.0 and error_map.shape == (32, 32)
    mean, _ = metrics.flip(np.zeros((32, 32, 3)), np.ones((32, 32, 3)))
    assert mean > 0.9


def test_flip_evaluator_itself_exits_on_a_missing_path():
    """Why the guard exists: the package calls sys.exit (pytest sees SystemExit)."""
    import flip_evaluator
    with pytest.raises(SystemExit):
        flip_evaluator.evaluate("no/such/reference.png", "no/such/test.png", "LDR")


@pytest.mark.parametrize("test, message", [
    ("no/such/test.png", "numpy array"),
    (np.zeros((8, 8, 3), dtype=np.uint8), "floating point"),
    (np.zeros((8, 8)), r"\(H, W, 3\)"),
    (np.zeros((0, 8, 3)), "empty"),
    (np.full((8, 8, 3), np.nan), "NaN"),
    (np.full((8, 8, 3), 1.5), r"\[0, 1\]"),
    (np.zeros((8, 9, 3)), "differ in size"),
])
def test_flip_guard_refuses_bad_inputs_and_the_process_lives(test, message):
    with pytest.raises(metrics.FlipInputError, match=message):
        metrics.flip(np.zeros((8, 8, 3)), test)


def test_exposure_test_is_welchs_t_test():
    """t, df and p equal scipy's Welch test (ttest_ind, equal_var=False), an implementation
    outside ours; the verdict is p >= alpha."""
    from scipy.stats import ttest_ind
    rng = np.random.default_rng(4)
    a, b = rng.normal(2.13, 0.016, 8), rng.normal(2.10, 0.03, 8)
    e = metrics.exposure_test(a, b, alpha=1e-3)
    ref = ttest_ind(a, b, equal_var=False)
    assert e.method == "welch" and e.n == (8, 8)
    assert e.t == pytest.approx(ref.statistic, rel=1e-12)
    assert e.p == pytest.approx(ref.pvalue, rel=1e-9)
    assert e.df == pytest.approx(ref.df, rel=1e-12)
    assert e.passed == (ref.pvalue >= 1e-3)
    assert e.rel_diff == pytest.approx((a.mean() - b.mean()) / b.mean())


def test_exposure_test_level_and_power():
    """Over 4000 pairs of 8 + 8 normal estimates with equal means (sd 0.016 and 0.02) the test
    rejects at about its level (0.05 here, for a measurable rate); a 3 % shift of the mean
    (the probe mix-up it must catch was 6 %) is rejected nearly always at the default level
    0.001 (sd 0.016 as the original's E over seeds; a 2 % shift: about 83 %)."""
    rng = np.random.default_rng(11)
    rejected = sum(not metrics.exposure_test(rng.normal(2.13, 0.016, 8),
                                             rng.normal(2.13, 0.02, 8), alpha=0.05).passed
                   for _ in range(4000))
    assert abs(rejected / 4000 - 0.05) < 0.012          # 3.5 sigma of a binomial rate
    caught = sum(not metrics.exposure_test(rng.normal(2.13 * 1.03, 0.016, 8),
                                           rng.normal(2.13, 0.016, 8)).passed
                 for _ in range(500))
    assert caught / 500 > 0.95


def test_exposure_test_without_noise_uses_the_float_tolerance():
    """A scene without randomness gives the same E for every seed: the means must agree
    within rtol |E| + atol (1e-3, 1e-4)."""
    same = metrics.exposure_test([4.8181] * 8, [4.8185] * 8)
    assert same.method == "float tolerance" and same.passed and same.t is None
    assert not metrics.exposure_test([4.8181] * 8, [4.83] * 8).passed
    with pytest.raises(ValueError, match=">= 2 estimates"):
        metrics.exposure_test([1.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="non-finite"):
        metrics.exposure_test([1.0, np.nan], [1.0, 1.0])


# -- the reference-image tests (compare --reference) ------------------------------------------

def _noisy(rng, shape, sd):
    base = np.linspace(0.2, 0.8, shape[0] * shape[1] * 3).reshape(shape)
    return [base + rng.normal(0.0, sd, shape) for _ in range(3)], base


def test_blur_test_is_calibrated_on_pure_noise_and_catches_a_local_bias():
    """Three images with the same Gaussian noise: the blurred t has sd about 1 (the variance
    estimate from the floor is unbiased) and nothing fails; a bias of 5 noise sd over a
    20 x 20 patch of the reference fails there and only there (analytic: the blur's sd is
    sd sqrt(1.5) / (2 sqrt(pi) sigma), so the patch's t is about 5 / 0.26 = 19)."""
    from codermind_harness.metrics import blur_test
    rng = np.random.default_rng(1)
    (a, b, r), _ = _noisy(rng, (96, 128, 3), 0.05)
    t = blur_test(a, b, r, 0.0)
    assert t.passed and t.failing_pixels == 0 and 0.85 < t.z_sd < 1.15
    assert t.dof == pytest.approx(2 * np.pi * 9) and t.z_critical > 5
    r2 = r.copy()
    r2[40:60, 50:70] += 0.25 * 0.05 * 20        # 0.25: five sd of 0.05
    t2 = blur_test(a, b, r2, 0.0)
    ys, xs = np.nonzero(~t2.passed_map)
    assert not t2.passed and 30 <= ys.min() and ys.max() < 70 and 40 <= xs.min() and xs.max() < 80


def test_blur_test_tolerance_and_exposure_spread():
    from codermind_harness.metrics import blur_test
    zero = np.zeros((16, 16, 3))
    assert blur_test(zero, zero, zero + 0.001, 0.002).passed        # within the tolerance
    assert not blur_test(zero, zero, zero + 0.01, 0.002).passed     # no noise: any excess fails
    # a shift the exposure's spread explains: slope 1 per unit ln E, sd ln E 0.01, shift 0.02
    assert blur_test(zero, zero, zero - 0.02, 0.0, np.ones_like(zero), 1e-4).passed
    assert not blur_test(zero, zero, zero - 0.2, 0.0, np.ones_like(zero), 1e-4).passed


def test_mean_test_se_matches_the_analytic_value():
    """se of the mean of d = (a + b)/2 - r over n pixels: sd sqrt(1.5 / n)."""
    from codermind_harness.metrics import mean_test
    rng = np.random.default_rng(2)
    (a, b, r), _ = _noisy(rng, (64, 64, 3), 0.1)
    m = mean_test(a, b, r, 0.0)
    assert m.passed
    assert m.se == pytest.approx([0.1 * np.sqrt(1.5 / 4096)] * 3, rel=0.05)
    shifted = mean_test(a, b, r - 0.01, 0.0)             # 0.01 = 5.2 se
    assert not shifted.passed and min(shifted.z) > 4


def test_byte_agreement_counts():
    from codermind_harness.metrics import byte_agreement
    a = np.zeros((2, 2, 3), np.uint8)
    b = a.copy()
    b[0, 0, 0], b[1, 1, 2] = 1, 3
    ba = byte_agreement(a, b)
    assert ba.identical == 10 / 12 and ba.within_one == 11 / 12 and ba.max_diff == 3
    assert ba.diff_map.tolist() == [[1, 0], [0, 3]]


def test_stouffer_tiles_calibrated_and_catch_a_small_widespread_bias():
    """Pure N(0, 1) z: the tiles' Stouffer Z has sd about 1 and nothing fails; a bias of
    0.5 sd over one 16 x 16 tile (no single z near the per-sub-sample critical 5.5) gives
    Z about 0.5 x 16 = 8 there: that tile fails, in all three channels."""
    from codermind_harness.metrics import stouffer, tile_labels
    rng = np.random.default_rng(3)
    z = rng.normal(size=(128, 160, 3))
    lab = tile_labels(z.shape[:2])
    p = stouffer(z, lab, "tiles")
    assert p.passed and p.tests == 8 * 10 * 3 and 0.85 < p.z_sd < 1.15
    z[32:48, 64:80] += 0.5
    p = stouffer(z, lab, "tiles")
    assert not p.passed and {f[0] for f in p.failing} == {2 * 10 + 4}
    assert {f[1] for f in p.failing} == set("RGB") and all(f[3] == 256 for f in p.failing)


def test_stouffer_clips_a_lone_outlier_and_skips_noiseless_channels():
    from codermind_harness.metrics import signed_z, stouffer
    rng = np.random.default_rng(4)
    z = rng.normal(size=(16, 16, 3))
    z[3, 3, 0] = 200.0                      # alone: 200 / 16 = 12.5 unclipped
    assert stouffer(z, np.zeros((16, 16), int), "objects").passed
    # channels within the float tolerance are NaN in signed_z and not pooled
    a = np.ones((4, 4, 3))
    s = signed_z(a, np.zeros_like(a), a + 1e-5, np.zeros_like(a))
    assert np.isnan(s).all()
    assert stouffer(s, np.zeros((4, 4), int), "objects").tests == 0


def test_t_to_z_keeps_the_p_value():
    """Closed forms: Student's t with 1 degree of freedom is Cauchy, P(T < -t) = 1/2 -
    atan(t)/pi; with infinite degrees of freedom t is already normal."""
    from scipy.special import ndtr
    from codermind_harness.metrics import t_to_z
    t = np.array([-3.0, -0.5, 0.0, 0.5, 3.0, 40.0, np.nan])
    z = t_to_z(t, 1.0)
    lower = 0.5 - np.arctan(np.abs(t[:-1])) / np.pi
    assert np.allclose(ndtr(-np.abs(z[:-1])), lower, rtol=1e-9, atol=0)
    assert np.array_equal(np.sign(z[:-1]), np.sign(t[:-1])) and np.isnan(z[-1])
    assert np.array_equal(t_to_z(t[:-1], np.inf), t[:-1])
    assert abs(z[5]) < 40.0 and abs(z[5]) > 2.0     # far out: shrunk, not lost to 1 - p
    assert t_to_z(np.array([500.0]), 4000.0)[0] == 500.0   # p underflows: t, not inf


def test_welch_dof_closed_forms():
    from codermind_harness.metrics import welch_dof
    assert welch_dof(1.0, 0.0, 15, 7) == pytest.approx(15)      # one side's noise alone
    assert welch_dof(1.0, 1.0, 15, 15) == pytest.approx(30)     # equal sides: the sum
    assert welch_dof(0.0, 0.0, 15, 15) == np.inf
    with pytest.raises(ValueError, match="degrees of freedom"):
        welch_dof(1.0, 1.0, 0, 15)


def test_pooled_z_has_sd_one_at_16_samples_a_side():
    """Null: both sides 16 iid normal samples per sub-sample. The raw ratio is a Welch t
    with 15-30 degrees of freedom (sd ~1.035), which Stouffer's Z over independent values
    inherits, and a pooled test at 3.8 feels several times over; the normal scores of the t
    (signed_z with the degrees of freedom) have sd 1, and so does their Z over 2000 groups of
    256 (sampling error +-0.016 at 1 sd)."""
    from codermind_harness.metrics import signed_z
    rng = np.random.default_rng(11)
    n, groups = 16, 2000
    xa = rng.normal(size=(groups, 256, 1, n))
    xb = rng.normal(size=(groups, 256, 1, n))
    ma, mb = xa.mean(-1), xb.mean(-1)
    va, vb = xa.var(-1, ddof=1) / n, xb.var(-1, ddof=1) / n
    raw = signed_z(ma, va, mb, vb, 0.0, 0.0)
    fixed = signed_z(ma, va, mb, vb, 0.0, 0.0, n - 1, n - 1)
    assert 1.025 < raw.std() < 1.045 and abs(fixed.std() - 1.0) < 0.004
    assert 0.95 < (fixed[..., 0].sum(1) / 16.0).std() < 1.05


def _sides_with_one_mean(rng, n=64, shape=(48, 64)):
    """Two unbiased sides of mean 1 per sample, distributed unlike each other: ``rare`` is
    20 with probability 0.05 (a rare bright path), ``smooth`` is normal(1, 0.1). Returns
    each side's (mean, variance of the mean) over ``n`` samples per sub-sample, (H, W, 3)."""
    rare = np.where(rng.random(shape + (3, n)) < 0.05, 20.0, 0.0)
    smooth = rng.normal(1.0, 0.1, size=shape + (3, n))
    return [(x.mean(-1), x.var(-1, ddof=1) / n) for x in (rare, smooth)]


def test_pooled_difference_is_centred_where_stouffer_is_not():
    """Null: both sides' mean is exactly 1, but the rare side's sub-sample mean and its
    variance estimate rise together, so the per-sub-sample z has E[z] < 0 and Stouffer's Z over
    3072 of them fails (Z about -16 to -19); the pooled difference's numerator has mean 0 and
    passes."""
    from codermind_harness.metrics import pooled_difference, signed_z, stouffer
    rng = np.random.default_rng(5)
    (ra, rv), (sa, sv) = _sides_with_one_mean(rng)
    one = np.zeros(ra.shape[:2], int)
    z = signed_z(ra, rv, sa, sv, 0.0, 0.0, 63, 63)
    assert not stouffer(z, one, "objects").passed
    p = pooled_difference(ra, rv, sa, sv, one, "objects", 63, 63)
    assert p.passed and p.tests == 3 and p.max_abs_z < p.z_critical


def test_pooled_difference_catches_a_small_widespread_bias():
    """The same two sides at 256 samples, the rare one 10 % brighter (E = 1.1) over one
    16 x 16 tile: per sub-sample 0.1 / sqrt(19 / 256) ~ 0.37 sd, invisible alone (the
    per-sub-sample critical is ~4.9); over the tile's 256 about 5.9 sd, less the rare side's
    own spread in the variance sum: that tile fails in all three channels, no other does."""
    from codermind_harness.metrics import pooled_difference, tile_labels
    rng = np.random.default_rng(6)
    (ra, rv), (sa, sv) = _sides_with_one_mean(rng, n=256)
    ra, rv = ra.copy(), rv.copy()
    ra[16:32, 16:32] *= 1.1
    rv[16:32, 16:32] *= 1.21
    lab = tile_labels(ra.shape[:2])
    p = pooled_difference(ra, rv, sa, sv, lab, "tiles", 255, 255)
    assert not p.passed and {f[0] for f in p.failing} == {1 * 4 + 1}
    assert {f[1] for f in p.failing} == set("RGB")


def test_flip_limit_formula():
    from codermind_harness.metrics import flip_limit
    assert flip_limit(0.0, 100) == pytest.approx(1e-3)
    assert flip_limit(0.02, 10_000) == pytest.approx(0.02 * (1.15 + 0.1) + 1e-3)
    assert flip_limit(0.02, 10_000, k=0.0, k0=0.0, eps=0.0) == pytest.approx(0.02)
