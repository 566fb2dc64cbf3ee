"""Comparison statistics: a two-sample z-test per sub-sample, FLIP, relative MSE, and a
two-sample test of the auto exposure.

**z-test** (:func:`z_test`), as Mitsuba's ``RenderingRegressionTest`` but with two estimated
sides: one test per sub-sample (film pixel) and RGB channel of the linear radiance, with
z = |a - b| / sqrt(var_a + var_b), each variance that of its side's mean. Its two-sided
p-value is compared with alpha Sidak-corrected over all the tests made,
1 - (1 - alpha)^(1/N) (Mitsuba corrects over the pixels and counts passing channels; here
N counts every channel and a sub-sample passes only when all three channels pass, which is
stricter on both counts). A channel also passes when |a - b| <= rtol max(|a|, |b|) + atol:
a float tolerance for pixels that neither side samples randomly (variance 0 on both sides,
e.g. pages 1-3), where float32 arithmetic in another order and Mitsuba's ray offsets
(instead of the tutorial's 0.1 epsilon) move multi-bounce hit points; defaults rtol 1e-3,
atol 1e-4 (radiance units: 1 is byte 255 on page 1), about a quarter of an 8-bit level.
The summary statistics of z (mean, sd, max) are taken over the channels whose noise sd
exceeds that tolerance (a side that sums equal values in another order reports a variance
of 1e-20, whose z means nothing).

With each side's degrees of freedom and sample count (a random scene: ``dof_a``, ``n_a``,
...), three more things (:func:`welch_scores`):

* **a variance that cannot be estimated**: where every sample of a side took the same branch
  its variance is 0 (sd within the float tolerance) although its distribution is not a
  point: a Bernoulli(p) radiance gives 16 equal samples with probability (1 - p)^16, 0.44 at
  p = 0.05. Treating that side's mean as exact (z = d / sd_other) is a one-sample test that
  the data do not support. Under the null both sides sample one distribution, so such a
  side takes the other side's per-sample variance at its own count (var_b n_b / n_a) and the
  test has the other side's degrees of freedom. Where neither side varies and the means
  differ beyond the float tolerance, the channel fails as in a scene without randomness:
  if it is random after all, every unit of each side took one value and the values differ,
  whose exact (Fisher, permutation) probability under the null, 1 / C(u_a + u_b, u_a) for
  u = dof + 1 units a side (3e-17 at 16 pass means against 64 rays), lies beyond any
  bound here; it counts against the pass rate, not the gross bound (a pixel that no sample
  varies is deterministic, and float-order disagreements at silhouettes are what the
  pass-rate allowance is for);
* **t-aware scores**: the ratio is a Welch t (each variance from dof + 1 units, Mitsuba's
  16 pass means), so it is turned into the normal score of its own p-value with
  Welch-Satterthwaite degrees of freedom (:func:`t_to_z`). At 15 degrees of freedom a t of
  5.4 (the Sidak bound of a page-4 frame) has p = 7e-5, not 3e-9: the per-sub-sample test's
  pass-rate allowance (``Thresholds.pass_rate``) absorbs that, the scores below do not
  need it;
* **the gross rule** (``GROSS_ALPHA``, ``GROSS_EFFECT``): a channel that is both certain
  and large fails the scene whatever the pass rate: its score lies beyond the Sidak bound
  of a family-wise level of 1e-6 over all the tests (about 7.3 for a 640 x 480 page 4; on
  t-aware scores, so heavy-tailed variance estimates from 16 passes do not cross it by
  chance: under the null it adds at most 1e-6 to a scene's false-alarm rate), and the two
  means differ by more than ``GROSS_EFFECT`` = 3 per-sample sds (sqrt of the mean of the
  two sides' per-sample variances, n var): the two sides' single rays barely overlap. The
  second condition does not grow with the sample count, as a score does for a fixed bias:
  the pass-rate allowance stays for disagreements that are significant but small against
  one ray's noise, such as page 4's blob (its exact surface against the original's float32
  roots under sharp highlights, at 64 spp: scores up to 7.1 on the bounding box of Light0's
  light, effects up to 1.4 sd on the crop where Light0 lands), while 93 sub-samples at |z|
  up to 192 at 64 spp (effect about 34 sd) fail.

**Calibration** (:func:`calibration`): under the null the scores are standard normal and
their two-sided p-values uniform; each test reports the scores' sd, a robust sd
(1.4826 x the median absolute deviation, which a few gross outliers do not move) and the
p-values' histogram in ``P_BINS`` equal bins.

**FLIP** (:func:`flip`): NVIDIA's ``flip-evaluator`` (LDR-FLIP, default 67 pixels per degree)
on sRGB-encoded images in [0, 1]. Its Python API prints a message and exits the process on
some bad inputs (a path that does not exist, a bad parameter), raises on others (a size
mismatch) and silently accepts the rest (NaN counts as no error, values outside [0, 1],
integer images): :func:`check_ldr` refuses all of them first with :class:`FlipInputError`.

**Relative MSE** (:func:`rel_mse`): mean over sub-samples and channels of
(test - ref)^2 / (ref^2 + 0.01), on linear radiance (the usual 0.01 keeps dark pixels from
dominating).

**Exposure test** (:func:`exposure_test`): each side's page-4 auto exposure E (facts.md F6.3: 256
single-ray probes) is a random variable of its random numbers; with E estimated for several
seeds on each side, Welch's two-sample t-test (unequal variances, Welch-Satterthwaite degrees
of freedom) of the two means at level ``EXPOSURE_ALPHA`` (two-sided). One test per scene: the
level is 0.001 so that a run over ten scenes falsely fails with about the image tests'
family-wise 0.01. When neither side's E varies beyond the float tolerance (a scene without
randomness), the means must agree within rtol |E| + atol instead. When exactly one side's E
does not vary (sd 0), Welch's t degenerates to the one-sample t of the other side's mean
against that constant (df = n - 1 of the varying side, which the Welch-Satterthwaite formula
gives exactly): a valid test of the means, but blind to what the constant itself says.
Under the null both sides draw E from one distribution, so a side whose E is the same for
every seed while the other's varies is itself a disagreement (probes that do not draw as the
original's do): the exact permutation probability that n_a of the pooled n_a + n_b
estimates, split at random, are all equal (within the float tolerance) is
sum_v C(c_v, n_a) / C(n_a + n_b, n_a) over the pooled values' clusters of sizes c_v
(1 / 12870 for 8 + 8 distinct values), no distribution assumed. In that case both tests are
made, each at ``alpha`` / 2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Significance level of the whole image (before the Sidak correction).
ALPHA = 0.01
#: Float tolerance of pixels without sampling noise (see the module doc).
RTOL = 1e-3
ATOL = 1e-4
#: The relative MSE's guard for dark pixels.
REL_MSE_EPS = 1e-2
#: Two-sided level of the exposure test (one test per scene, see the module doc).
EXPOSURE_ALPHA = 1e-3
#: Family-wise level of the gross rule: a t-aware score beyond its Sidak bound, with a
#: difference beyond GROSS_EFFECT per-sample sds, fails a scene whatever its pass rate
#: (module doc).
GROSS_ALPHA = 1e-6
GROSS_EFFECT = 3.0
#: Bins of the p-value histograms (calibration).
P_BINS = 10


#: FLIP of a random scene is judged against its noise floor F0 (the port against itself with
#: the next seed, same settings): F <= F0 (1 + FLIP_K0 + FLIP_K / sqrt(pixels)) + FLIP_EPS.
#: FLIP_K: 5 sds of F / F0 between seeds, which fall as 1 / sqrt(pixels) (measured 1.8 /
#: sqrt(pixels)); FLIP_K0: the two sides' noise may differ (other samplers), which moved
#: F / F0 by up to +8 % on whole frames; FLIP_EPS: noise-free grids (docs/results/compare.md).
FLIP_K0 = 0.15
FLIP_K = 10.0
FLIP_EPS = 1e-3


def flip_limit(floor: float, pixels: int, k: float | None = None, eps: float | None = None,
               k0: float | None = None) -> float:
    """The largest FLIP of a random scene whose noise floor is ``floor`` (see FLIP_K)."""
    k = FLIP_K if k is None else k
    k0 = FLIP_K0 if k0 is None else k0
    eps = FLIP_EPS if eps is None else eps
    return float(floor) * (1.0 + k0 + k / math.sqrt(max(pixels, 1))) + eps


class FlipInputError(ValueError):
    """An image that FLIP must not be given (it would exit the process or mislead)."""


@dataclass
class ZTest:
    """Result of :func:`z_test`; maps are per sub-sample (H, W)."""
    pass_rate: float           #: fraction of sub-samples whose three channels pass
    channel_pass_rate: float   #: fraction of (sub-sample, channel) tests that pass
    tests: int                 #: N, the number of (sub-sample, channel) tests
    alpha: float               #: per-test level after the Sidak correction
    z_critical: float          #: |z| above which a noisy channel fails
    noiseless: int             #: sub-samples whose noise (sd) is within the float tolerance
    noisy_tests: int           #: tests whose noise exceeds the float tolerance
    max_z: float | None        #: largest |z| among noisy tests (None: no noisy test)
    z_sd: float | None         #: sd of the signed z over noisy channels (about 1 when the
                               #: sides agree and the variances are right)
    z_mean: float | None       #: mean of the signed z over noisy channels (about 0)
    passed_map: np.ndarray     #: bool (H, W)
    z_map: np.ndarray          #: float (H, W): largest |z| over the channels (0 within the
                               #: float tolerance, inf: a noiseless channel outside it)
    gross_alpha: float = GROSS_ALPHA
    gross_effect: float = GROSS_EFFECT   #: per-sample sds a gross difference exceeds
    z_gross: float = math.inf  #: |score| beyond which a large difference fails (module doc)
    gross: int = 0             #: noisy channels beyond it and beyond the effect size
    gross_sub_samples: int = 0
    max_score: float | None = None   #: largest |t-aware score| among noisy tests
    zero_variance: dict | None = None   #: tests where one side had no variance (noisy) /
                                        #: neither had one and the means differ
    calibration: dict | None = None     #: of the scores (:func:`calibration`)


def sidak_alpha(alpha: float, tests: int) -> float:
    """Per-test level so that N independent tests reject anything with probability alpha."""
    return -np.expm1(np.log1p(-alpha) / max(tests, 1))


def z_test(mean_a: np.ndarray, var_a: np.ndarray, mean_b: np.ndarray, var_b: np.ndarray,
           alpha: float = ALPHA, rtol: float = RTOL, atol: float = ATOL,
           dof_a: float | None = None, dof_b: float | None = None,
           n_a: float | None = None, n_b: float | None = None,
           gross_alpha: float = GROSS_ALPHA, gross_effect: float = GROSS_EFFECT) -> ZTest:
    """Two-sample z-test of two (H, W, 3) renders with the variances of their means.

    With both sides' degrees of freedom and sample counts (``dof_*``, ``n_*``; a random
    scene), a side whose variance could not be estimated takes the other's, and the gross
    bound and the calibration use t-aware scores (module doc, :func:`welch_scores`); without
    them (a scene without randomness) the scores are the z themselves and a noiseless channel
    outside the float tolerance is infinitely far out."""
    from scipy.special import ndtri
    a, b = (np.asarray(x, dtype=np.float64) for x in (mean_a, mean_b))
    va, vb = (np.asarray(x, dtype=np.float64) for x in (var_a, var_b))
    shapes = {x.shape for x in (a, b, va, vb)}
    if len(shapes) != 1 or a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"z_test needs four (H, W, 3) arrays of one shape, got "
                         f"{[x.shape for x in (a, b, va, vb)]}")
    for name, x in (("mean", a), ("mean", b)):
        if not np.isfinite(x).all():
            raise ValueError(f"z_test: a {name} image has {int((~np.isfinite(x)).sum())} "
                             "non-finite values")
    for x in (va, vb):
        if np.isnan(x).any() or (x < 0).any():
            raise ValueError("z_test: a variance image has NaN or negative values (a side "
                             "with one sample cannot estimate its variance)")
    tests = a.size
    level = sidak_alpha(alpha, tests)
    z_crit = float(-ndtri(level / 2.0))
    diff = np.abs(a - b)
    tol = rtol * np.maximum(np.abs(a), np.abs(b)) + atol
    within = diff <= tol
    random = None not in (dof_a, dof_b, n_a, n_b)
    zero = None
    if random:
        ws = welch_scores(a, va, b, vb, dof_a, dof_b, n_a, n_b, rtol, atol)
        var, score = ws.var, ws.score
        zero = {"one_side": int(ws.one_side.sum()), "both_sides": int(ws.both.sum())}
    else:
        var = va + vb
    with np.errstate(divide="ignore", invalid="ignore"):
        sd = np.sqrt(var)
        z = np.where(var > 0, diff / np.where(var > 0, sd, 1.0), np.where(within, 0.0, np.inf))
    if not random:
        score = np.where(var > 0, np.sign(a - b) * z, 0.0)
    ok = within | ((var > 0) & (z <= z_crit))
    passed = ok.all(axis=2)
    # The z statistics describe the channels whose noise exceeds the float tolerance: a sum of
    # equal values in another order has a variance of 1e-20 or so, whose z means nothing.
    noisy = np.sqrt(va + vb) > tol
    zs = ((a - b) / np.where(noisy, np.sqrt(va + vb), 1.0))[noisy]
    z_gross = float(-ndtri(sidak_alpha(gross_alpha, tests) / 2.0))
    far = noisy & ~within & (np.abs(score) > z_gross)
    if random:      # and large: beyond gross_effect per-sample sds (module doc)
        per_sample = np.sqrt(0.5 * (n_a * ws.va_eff + n_b * ws.vb_eff))
        far &= diff > gross_effect * per_sample
    scores = score[noisy]
    return ZTest(float(passed.mean()), float(ok.mean()), tests, float(level), z_crit,
                 int((~noisy).all(axis=2).sum()), int(zs.size),
                 float(np.abs(zs).max()) if zs.size else None,
                 float(zs.std()) if zs.size > 1 else None,
                 float(zs.mean()) if zs.size else None,
                 passed, np.where(within, 0.0, z).max(axis=2), float(gross_alpha),
                 float(gross_effect), z_gross,
                 int(far.sum()), int(far.any(axis=2).sum()),
                 float(np.abs(scores).max()) if scores.size else None, zero,
                 calibration(scores))


@dataclass
class WelchScores:
    """Per channel (:func:`welch_scores`)."""
    var: np.ndarray          #: the variance of a - b used (a side without one takes the other's)
    dof: np.ndarray          #: its Welch-Satterthwaite degrees of freedom
    score: np.ndarray        #: signed normal score of the t (0 where var is 0)
    va_eff: np.ndarray       #: side a's part of ``var``
    vb_eff: np.ndarray       #: side b's part of ``var``
    one_side: np.ndarray     #: bool: one side's variance was not estimated (noisy channels)
    both: np.ndarray         #: bool: neither side's was, the means differ beyond the tolerance


def welch_scores(a, var_a, b, var_b, dof_a: float, dof_b: float, n_a: float, n_b: float,
                 rtol: float = RTOL, atol: float = ATOL) -> WelchScores:
    """The signed t-aware score of a - b per channel, valid where a side's variance is 0.

    ``var_*``: variances of the means, each estimated with ``dof_*`` degrees of freedom from
    ``dof_* + 1`` units (Mitsuba: pass means; the port: rays) of ``n_*`` samples in all.
    A side whose sd lies within the float tolerance rtol max(|a|, |b|) + atol did not
    estimate its variance (every sample took one branch, or rounding): it takes the other
    side's per-sample variance at its own count, var_other n_other / n_self, and the sum
    var_other (1 + n_other / n_self) has the other side's degrees of freedom (a side's own
    variance, if larger, is kept). Where both sides lack a variance, both keep theirs
    (``both`` marks those whose means differ beyond the tolerance: the
    float tolerance judges them, module doc); the score is not cut to 0 within the
    tolerance (the verdict passes those channels, the calibration needs their scores)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    va, vb = np.asarray(var_a, np.float64), np.asarray(var_b, np.float64)
    if min(dof_a, dof_b, n_a, n_b) <= 0:
        raise ValueError(f"welch_scores: degrees of freedom and counts must be > 0, got "
                         f"{dof_a}, {dof_b}, {n_a}, {n_b}")
    tol = rtol * np.maximum(np.abs(a), np.abs(b)) + atol
    within = np.abs(a - b) <= tol
    has_a, has_b = np.sqrt(va) > tol, np.sqrt(vb) > tol
    only_b, only_a = ~has_a & has_b, has_a & ~has_b
    va_eff = np.where(only_b, np.maximum(va, vb * (n_b / n_a)), va)
    vb_eff = np.where(only_a, np.maximum(vb, va * (n_a / n_b)), vb)
    var = va_eff + vb_eff
    dof = np.where(only_a, float(dof_a), np.where(only_b, float(dof_b),
                                                  welch_dof(va, vb, dof_a, dof_b)))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(var > 0, (a - b) / np.sqrt(np.where(var > 0, var, 1.0)), 0.0)
    score = t_to_z(t, dof)
    both = ~has_a & ~has_b & ~within
    one_side = (only_a | only_b) & (np.sqrt(va + vb) > tol)
    return WelchScores(var, dof, score, va_eff, vb_eff, one_side, both)


def calibration(scores, bins: int = P_BINS) -> dict | None:
    """The calibration of signed scores that are standard normal under the null: count,
    mean, sd, robust sd (1.4826 median |score - median|) and the histogram of the two-sided
    p-values in ``bins`` equal bins on [0, 1] (flat under the null; the first bin holds
    what a disagreement adds). None without scores."""
    from scipy.special import ndtr
    s = np.asarray(scores, np.float64).ravel()
    s = s[np.isfinite(s)]
    if s.size == 0:
        return None
    med = float(np.median(s))
    p = np.clip(2.0 * ndtr(-np.abs(s)), 0.0, 1.0)
    hist = np.histogram(p, bins=bins, range=(0.0, 1.0))[0]
    return {"n": int(s.size), "mean": float(s.mean()),
            "sd": float(s.std()) if s.size > 1 else None,
            "sd_robust": float(1.482602218505602 * np.median(np.abs(s - med))),
            "p_hist": [int(x) for x in hist], "p_hist_expected": s.size / bins}


def rel_mse(test: np.ndarray, ref: np.ndarray, eps: float = REL_MSE_EPS) -> float:
    """mean((test - ref)^2 / (ref^2 + eps))."""
    t, r = np.asarray(test, dtype=np.float64), np.asarray(ref, dtype=np.float64)
    if t.shape != r.shape:
        raise ValueError(f"rel_mse: shapes differ, {t.shape} vs {r.shape}")
    return float(np.mean(np.square(t - r) / (np.square(r) + eps)))


def check_ldr(image, name: str = "image") -> np.ndarray:
    """The image as FLIP's LDR input (float32 (H, W, 3) C-contiguous, finite, in [0, 1]),
    or FlipInputError saying what is wrong."""
    if not isinstance(image, np.ndarray):
        raise FlipInputError(f"FLIP: {name} must be a numpy array, got {type(image).__name__}")
    if image.dtype.kind != "f":
        raise FlipInputError(f"FLIP: {name} must be floating point (sRGB in [0, 1]), got "
                             f"{image.dtype}")
    if image.ndim != 3 or image.shape[2] != 3:
        raise FlipInputError(f"FLIP: {name} must be (H, W, 3), got {image.shape}")
    if image.shape[0] < 1 or image.shape[1] < 1:
        raise FlipInputError(f"FLIP: {name} is empty, {image.shape}")
    bad = ~np.isfinite(image)
    if bad.any():
        raise FlipInputError(f"FLIP: {name} has {int(bad.sum())} NaN or infinite values")
    lo, hi = float(image.min()), float(image.max())
    if lo < 0.0 or hi > 1.0:
        raise FlipInputError(f"FLIP: {name} must lie in [0, 1] (LDR, sRGB-encoded), got "
                             f"[{lo:.4g}, {hi:.4g}]")
    return np.ascontiguousarray(image, dtype=np.float32)


def flip(reference: np.ndarray, test: np.ndarray) -> tuple[float, np.ndarray]:
    """Mean LDR-FLIP and the (H, W) error map of two sRGB images in [0, 1]."""
    ref = check_ldr(reference, "reference")
    tst = check_ldr(test, "test")
    if ref.shape != tst.shape:
        raise FlipInputError(f"FLIP: the images differ in size, {ref.shape[1]}x{ref.shape[0]} "
                             f"vs {tst.shape[1]}x{tst.shape[0]}")
    import flip_evaluator
    try:
        error_map, mean, _ = flip_evaluator.evaluate(ref, tst, "LDR", applyMagma=False)
    except SystemExit as e:     # its Python layer exits on what it dislikes
        raise FlipInputError(f"FLIP refused its input (exit status {e.code})") from None
    except RuntimeError as e:   # its C++ layer raises on what it dislikes
        raise FlipInputError(f"FLIP refused its input: {' '.join(str(e).split())}") from None
    error_map = np.asarray(error_map, dtype=np.float64)
    if error_map.ndim == 3:
        error_map = error_map[..., 0]
    return float(mean), error_map


@dataclass
class ExposureTest:
    """Result of :func:`exposure_test`; side ``a`` is Mitsuba, ``b`` the port in compare."""
    passed: bool
    method: str                #: "welch" or "float tolerance" (neither side noisy)
    alpha: float
    n: tuple[int, int]         #: seeds per side
    mean: tuple[float, float]
    sd: tuple[float, float]    #: sample sd over the seeds
    rel_diff: float            #: (mean_a - mean_b) / |mean_b|
    t: float | None            #: Welch's t (None: float tolerance)
    df: float | None
    p: float | None            #: two-sided p-value
    p_spread: float | None = None   #: one side constant, the other not: the exact
                                    #: permutation p-value of that (module doc); else None


def exposure_test(a, b, alpha: float = EXPOSURE_ALPHA, rtol: float = RTOL,
                  atol: float = ATOL) -> ExposureTest:
    """Welch's two-sample t-test of two sets of auto-exposure estimates (module doc)."""
    from scipy.stats import t as student_t
    a, b = (np.asarray(x, dtype=np.float64).ravel() for x in (a, b))
    if a.size < 2 or b.size < 2:
        raise ValueError(f"exposure_test needs >= 2 estimates per side, got {a.size} and "
                         f"{b.size}")
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise ValueError("exposure_test: a non-finite exposure estimate")
    ma, mb = float(a.mean()), float(b.mean())
    sa, sb = float(a.std(ddof=1)), float(b.std(ddof=1))
    rel = (ma - mb) / abs(mb) if mb != 0 else (0.0 if ma == mb else math.inf)
    tol = rtol * max(abs(ma), abs(mb)) + atol
    common = dict(alpha=alpha, n=(a.size, b.size), mean=(ma, mb), sd=(sa, sb), rel_diff=rel)
    if sa <= tol and sb <= tol:
        return ExposureTest(abs(ma - mb) <= tol, "float tolerance", t=None, df=None, p=None,
                            **common)
    # a side within the float tolerance counts as constant: sd exactly 0 in its terms
    va = sa * sa / a.size if sa > tol else 0.0
    vb = sb * sb / b.size if sb > tol else 0.0
    t = (ma - mb) / math.sqrt(va + vb)
    df = (va + vb) ** 2 / (va * va / (a.size - 1) + vb * vb / (b.size - 1))
    p = float(2.0 * student_t.sf(abs(t), df))
    if va > 0 and vb > 0:
        return ExposureTest(p >= alpha, "welch", t=float(t), df=float(df), p=p, **common)
    constant = a if va == 0 else b
    spread = constant_split_p(constant.size, np.concatenate([a, b]), tol)
    return ExposureTest(p >= alpha / 2 and spread >= alpha / 2, "welch + spread", t=float(t),
                        df=float(df), p=p, p_spread=spread, **common)


def constant_split_p(k: int, pooled, tol: float) -> float:
    """The probability that ``k`` of the ``pooled`` values drawn at random without
    replacement are all equal within ``tol`` (values chained by gaps <= tol are one
    value): sum over the clusters of C(size, k) / C(len, k)."""
    x = np.sort(np.asarray(pooled, np.float64).ravel())
    breaks = np.flatnonzero(np.diff(x) > tol)
    sizes = np.diff(np.concatenate([[0], breaks + 1, [x.size]]))
    return float(sum(math.comb(int(c), k) for c in sizes) / math.comb(x.size, k))


# -- a reference image as the other side (``codermind compare --reference``) ----------------

#: Standard deviation, in pixels, of the Gaussian that blurs a difference image.
BLUR_SIGMA = 3.0


@dataclass
class ByteAgreement:
    """Two 8-bit images compared exactly (:func:`byte_agreement`)."""
    identical: float           #: share of bytes equal
    within_one: float          #: share of bytes within 1 level
    max_diff: int
    bytes: int
    diff_map: np.ndarray       #: int (H, W): largest |difference| over the channels


def byte_agreement(a: np.ndarray, b: np.ndarray) -> ByteAgreement:
    """Identical bytes and bytes within one level of two uint8 (H, W, 3) images."""
    d = np.abs(np.asarray(a, dtype=np.int64) - np.asarray(b, dtype=np.int64))
    return ByteAgreement(float((d == 0).mean()), float((d <= 1).mean()), int(d.max()),
                         int(d.size), d.max(axis=2))


def _kernel(sigma: float) -> np.ndarray:
    r = max(1, int(math.ceil(3.0 * sigma)))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    return k / k.sum()


def _separable(image: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The 2-D correlation of each channel with k (x) k, zeros outside the image."""
    from scipy.ndimage import correlate1d
    out = correlate1d(image, k, axis=0, mode="constant", cval=0.0)
    return correlate1d(out, k, axis=1, mode="constant", cval=0.0)


@dataclass
class BlurTest:
    """The Gaussian-blurred difference against the noise floor (:func:`blur_test`)."""
    passed: bool
    sigma: float               #: the blur's sd, pixels
    tests: int                 #: pixels x channels
    alpha: float               #: per-test level after the Sidak correction
    dof: float                 #: degrees of freedom of the local variance estimate
    z_critical: float          #: |t| above which a blurred pixel fails (Student t, dof)
    failing_pixels: int
    max_abs_z: float
    z_sd: float                #: sd of the blurred z over all tests (<= about 1 under H0)
    z_map: np.ndarray          #: (H, W) largest |z| over the channels
    passed_map: np.ndarray     #: bool (H, W)


def blur_test(ours: np.ndarray, again: np.ndarray, ref: np.ndarray, tol: float | np.ndarray,
              exposure_slope: np.ndarray | None = None, var_log_exposure: float = 0.0,
              alpha: float = ALPHA, sigma: float = BLUR_SIGMA) -> BlurTest:
    """Whether ``ref`` differs from our side anywhere by more than noise.

    ``ours`` and ``again``: our side with two seeds, ``ref`` the reference, (H, W, 3) at the
    same sample count. The difference d = (ours + again)/2 - ref and the floor f = ours -
    again, both blurred with a Gaussian g of sd ``sigma`` (zeros outside the image, weights
    renormalised). With each pixel's noise variance s^2 the same on all three images (the
    reference made at our sample count), var d = 1.5 s^2 and E f^2 = 2 s^2, so the variance
    of the blurred d at p is estimated without bias by 0.75 sum_q g(p - q)^2 f(q)^2 (the
    squared kernel): local, with 2 pi sigma^2 degrees of freedom (Satterthwaite). An
    ``exposure_slope`` (dI/dlnE per pixel) adds the exposure's spread, which is the same
    for every pixel of an image: (g * slope)^2 1.5 ``var_log_exposure``. A pixel fails when
    |blurred d| exceeds ``tol`` (quantisation, float error) and its t exceeds the Student-t
    critical value at ``alpha`` Sidak-corrected over every pixel and channel (conservative:
    the blurred tests are correlated)."""
    from scipy.stats import t as student_t
    a, b, r = (np.asarray(x, dtype=np.float64) for x in (ours, again, ref))
    if not (a.shape == b.shape == r.shape) or a.ndim != 3:
        raise ValueError(f"blur_test needs three (H, W, C) images of one shape, got "
                         f"{a.shape}, {b.shape}, {r.shape}")
    k = _kernel(sigma)
    norm = _separable(np.ones(a.shape[:2] + (1,)), k)
    d = _separable((a + b) / 2.0 - r, k) / norm
    var = 0.75 * _separable(np.square(a - b), k * k) / np.square(norm)
    if exposure_slope is not None and var_log_exposure > 0:
        var = var + np.square(_separable(np.asarray(exposure_slope, np.float64), k) / norm) \
            * 1.5 * var_log_exposure
    excess = np.maximum(np.abs(d) - tol, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(excess > 0, excess / np.sqrt(var), 0.0)
    z = np.where(np.isnan(z), np.inf, z)
    tests = a.size
    level = float(sidak_alpha(alpha, tests))
    dof = 2.0 * math.pi * sigma * sigma
    crit = float(student_t.isf(level / 2.0, dof))
    ok = z <= crit
    passed_map = ok.all(axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        signed = np.where(var > 0, d / np.sqrt(np.where(var > 0, var, 1.0)), 0.0)
    return BlurTest(bool(ok.all()), sigma, tests, level, dof, crit, int((~passed_map).sum()),
                    float(z.max()) if z.size else 0.0,
                    float(signed[var > 0].std()) if (var > 0).any() else 0.0,
                    z.max(axis=2), passed_map)


@dataclass
class MeanTest:
    """The mean difference of the whole image, per channel (:func:`mean_test`)."""
    passed: bool
    mean_diff: list[float]     #: per channel, ours - ref
    se: list[float]            #: its standard error under H0
    z: list[float]
    p: list[float]             #: two-sided
    alpha: float               #: per-channel level (Sidak over the channels)


def mean_test(ours: np.ndarray, again: np.ndarray, ref: np.ndarray, tol: float,
              exposure_slope: np.ndarray | None = None, var_log_exposure: float = 0.0,
              alpha: float = ALPHA) -> MeanTest:
    """Two-sided z-test of the mean of d = (ours + again)/2 - ref per channel, its variance
    0.75 sum f^2 / n^2 from the floor f = ours - again (pixels independent; see
    :func:`blur_test`) plus the exposure's 1.5 ``var_log_exposure`` mean(slope)^2; a mean
    within ``tol`` passes. Sidak over the channels."""
    from scipy.special import ndtr
    a, b, r = (np.asarray(x, dtype=np.float64) for x in (ours, again, ref))
    c = a.shape[-1]
    d = ((a + b) / 2.0 - r).reshape(-1, c)
    f = (a - b).reshape(-1, c)
    n = d.shape[0]
    m = d.mean(axis=0)
    var = 0.75 * np.square(f).sum(axis=0) / n ** 2
    if exposure_slope is not None and var_log_exposure > 0:
        var = var + np.square(np.asarray(exposure_slope, np.float64).reshape(-1, c)
                              .mean(axis=0)) * 1.5 * var_log_exposure
    excess = np.maximum(np.abs(m) - tol, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(excess > 0, excess / np.sqrt(var), 0.0)
    z = np.where(np.isnan(z), np.inf, z)
    p = 2.0 * ndtr(-z)
    level = float(sidak_alpha(alpha, c))
    se = np.sqrt(var)
    return MeanTest(bool((p >= level).all()), [float(x) for x in m], [float(x) for x in se],
                    [float(x) for x in np.sign(m) * z], [float(x) for x in p], level)


# -- pooled tests of the per-sub-sample z ------------------------------------------------------

#: Level of each pooled family (tiles, objects), two-sided, before the Sidak correction.
POOLED_ALPHA = 5e-3
#: Each signed z is clipped to +-Z_CLIP before pooling: a lone outlier (which the
#: per-sub-sample test already judges) must not fail a pool of a few hundred.
Z_CLIP = 4.0
#: Tile side in sub-samples.
TILE = 16


def signed_z(mean_a, var_a, mean_b, var_b, rtol: float = RTOL, atol: float = ATOL,
             dof_a: float | None = None, dof_b: float | None = None):
    """(H, W, 3) signed z = (a - b) / sqrt(var_a + var_b) where the noise sd exceeds the float
    tolerance, NaN elsewhere (those channels carry no noise to pool).

    With both sides' degrees of freedom (``dof_a``, ``dof_b``: those of each variance
    estimate, e.g. passes - 1), that ratio is a Welch t and is returned as the normal score
    of its own p-value, with Welch-Satterthwaite degrees of freedom per channel
    (:func:`welch_dof`): at 16 samples a side the ratio has sd ~1.035-1.07, and Stouffer's
    Z over a few hundred such values inherits it, which multiplies a pooled test's tail
    probability several times (docs/results/false-alarm.md)."""
    a, b = (np.asarray(x, dtype=np.float64) for x in (mean_a, mean_b))
    va, vb = np.asarray(var_a, np.float64), np.asarray(var_b, np.float64)
    sd = np.sqrt(va + vb)
    noisy = noisy_channels(a, va, b, vb, rtol, atol)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(noisy, (a - b) / np.where(noisy, sd, 1.0), np.nan)
    if dof_a is None or dof_b is None:
        return t
    return t_to_z(t, welch_dof(va, vb, dof_a, dof_b))


def noisy_channels(a: np.ndarray, var_a: np.ndarray, b: np.ndarray, var_b: np.ndarray,
                   rtol: float = RTOL, atol: float = ATOL) -> np.ndarray:
    """Channels whose noise sd exceeds the float tolerance rtol max(|a|, |b|) + atol: the
    ones the pooled tests pool (the others carry no noise)."""
    return np.sqrt(var_a + var_b) > rtol * np.maximum(np.abs(a), np.abs(b)) + atol


def welch_dof(var_a, var_b, dof_a: float, dof_b: float) -> np.ndarray:
    """Welch-Satterthwaite degrees of freedom of var_a + var_b, each the variance of a mean
    estimated with ``dof_a`` / ``dof_b`` degrees of freedom; inf where both are 0."""
    va, vb = np.asarray(var_a, np.float64), np.asarray(var_b, np.float64)
    if min(dof_a, dof_b) <= 0:
        raise ValueError(f"welch_dof: degrees of freedom must be > 0, got {dof_a}, {dof_b}")
    den = np.square(va) / dof_a + np.square(vb) / dof_b
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, np.square(va + vb) / np.where(den > 0, den, 1.0), np.inf)


def t_to_z(t, dof) -> np.ndarray:
    """The normal score with the same two-sided p-value and sign as Student's ``t`` with
    ``dof`` degrees of freedom (NaN stays NaN; inf dof: t itself)."""
    from scipy.special import ndtri, stdtr
    t = np.asarray(t, np.float64)
    dof = np.broadcast_to(np.asarray(dof, np.float64), t.shape)
    finite = np.isfinite(dof)
    with np.errstate(invalid="ignore"):
        lower = stdtr(np.where(finite, dof, 1.0), -np.abs(np.nan_to_num(t)))
        z = np.sign(t) * -ndtri(lower)          # the lower tail: accurate far out
    # beyond double precision (p < 1e-308) the score is infinite: keep t, as far out
    z = np.where(lower > 0, z, t)
    return np.where(np.isnan(t), np.nan, np.where(finite, z, t))


@dataclass
class PooledTest:
    """Stouffer's Z over groups of sub-samples, per channel (:func:`stouffer`)."""
    passed: bool
    kind: str                  #: "tiles" or "objects"
    groups: int                #: groups with noisy channels
    tests: int                 #: groups x channels tested
    alpha: float               #: per-test level after the Sidak correction
    z_critical: float
    max_abs_z: float | None
    z_sd: float | None         #: sd of the pooled Z (about 1 under H0)
    failing: list              #: [(group, channel, Z, n)] of the failing tests, worst first
    calibration: dict | None = None   #: of the pooled Z (:func:`calibration`)
    every: list | None = None  #: named groups (objects, lights): [(group, channel, Z, n)] of
                               #: every test made


def stouffer(z: np.ndarray, labels: np.ndarray, kind: str, alpha: float = POOLED_ALPHA,
             clip: float = Z_CLIP, min_count: int = 16, names=None) -> PooledTest:
    """Stouffer's Z = sum clip(z_i) / sqrt(n) over the noisy channels of each group (``labels``:
    int (H, W), one group per value, negative: none) and channel, two-sided, Sidak-corrected
    over every group and channel with at least ``min_count`` noisy values."""
    z = np.asarray(z, dtype=np.float64)
    lab = np.asarray(labels)
    zc = np.clip(z, -clip, clip)
    out, where = [], []
    for g in np.unique(lab[lab >= 0]):
        sel = zc[lab == g]                       # (n, 3)
        for c in range(sel.shape[1]):
            v = sel[:, c]
            v = v[np.isfinite(v)]
            if v.size >= min_count:
                out.append(float(v.sum() / math.sqrt(v.size)))
                where.append((g, c, v.size))
    return _pooled_verdict(out, where, kind, alpha, names)


def pooled_difference(mean_a, var_a, mean_b, var_b, labels: np.ndarray, kind: str,
                      dof_a: float, dof_b: float, alpha: float = POOLED_ALPHA,
                      rtol: float = RTOL, atol: float = ATOL, min_count: int = 16,
                      names=None, masks=None) -> PooledTest:
    """The pooled difference of each group (``labels``: int (H, W), one group per value,
    negative: none; ``masks``: more groups, each a bool (H, W), which may overlap them, named
    ``names[max label + 1 + k]``) and channel, over its noisy channels (as :func:`signed_z`):
    t = sum(a - b) / sqrt(sum(var_a + var_b)), as a normal score with the Welch-Satterthwaite
    degrees of freedom of that variance sum (each side's ``dof``); two-sided, Sidak-corrected
    over every group and channel with at least ``min_count`` noisy values (conservative for
    overlapping groups).

    Unlike Stouffer's Z of the per-sub-sample z (:func:`stouffer`), whose null mean is 0 only
    when both sides' sub-sample means are distributed alike (a side whose mean and variance
    estimate rise together, e.g. rare bright paths, pulls E[z] off 0), its numerator has mean
    0 for any two unbiased sides; the degrees of freedom widen its tails where a few noisy
    sub-samples dominate the variance sum (docs/results/false-alarm.md)."""
    a, b = (np.asarray(x, dtype=np.float64) for x in (mean_a, mean_b))
    va, vb = np.asarray(var_a, np.float64), np.asarray(var_b, np.float64)
    noisy = noisy_channels(a, va, b, vb, rtol, atol)
    lab = np.asarray(labels)
    groups = [(g, lab == g) for g in np.unique(lab[lab >= 0])]
    first = int(lab.max()) + 1 if lab.size and (lab >= 0).any() else 0
    groups += [(first + k, np.asarray(m, dtype=bool)) for k, m in enumerate(masks or [])]
    out, where = [], []
    for g, m in groups:
        for c in range(a.shape[2]):
            k = noisy[..., c] & m
            n = int(k.sum())
            if n < min_count:
                continue
            x, y = va[..., c][k], vb[..., c][k]
            v = float(x.sum() + y.sum())
            t = float((a[..., c][k] - b[..., c][k]).sum()) / math.sqrt(v)
            den = float(np.square(x).sum() / dof_a + np.square(y).sum() / dof_b)
            dof = v * v / den if den > 0 else np.inf
            out.append(float(t_to_z(t, dof)))
            where.append((g, c, n))
    return _pooled_verdict(out, where, kind, alpha, names)


def _pooled_verdict(out: list, where: list, kind: str, alpha: float, names) -> PooledTest:
    """The family's verdict from one Z per (group, channel, count) in ``where``: two-sided at
    ``alpha`` Sidak-corrected over the tests made."""
    from scipy.special import ndtri
    tests = len(out)
    level = float(sidak_alpha(alpha, tests))
    crit = float(-ndtri(level / 2.0))
    zs = np.array(out)
    bad = [((names[int(g)] if names is not None else int(g)), "RGB"[c], float(x), int(n))
           for (g, c, n), x in zip(where, out) if abs(x) > crit]
    bad.sort(key=lambda t: -abs(t[2]))
    every = None if names is None else [(names[int(g)], "RGB"[c], float(x), int(n))
                                        for (g, c, n), x in zip(where, out)]
    return PooledTest(not bad, kind, len({w[0] for w in where}), tests, level, crit,
                      float(np.abs(zs).max()) if tests else None,
                      float(zs.std()) if tests > 1 else None, bad[:10], calibration(zs), every)


def tile_labels(shape: tuple[int, int], tile: int = TILE) -> np.ndarray:
    """(H, W) tile index of each sub-sample, tiles of ``tile`` x ``tile``."""
    h, w = shape
    ty, tx = np.arange(h)[:, None] // tile, np.arange(w)[None, :] // tile
    return (ty * (-(-w // tile)) + tx).astype(np.int64)
