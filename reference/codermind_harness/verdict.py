"""The verdict of ``codermind compare``: the thresholds and the rules that turn the tests'
numbers into failures, one sentence each (a scene passes when it has none)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import metrics


@dataclass
class Thresholds:
    pass_rate: float = 0.99       #: smallest share of sub-samples passing the z-test
    flip: float = 0.01            #: largest mean FLIP of a scene without randomness
    alpha: float = metrics.ALPHA
    rtol: float = metrics.RTOL
    atol: float = metrics.ATOL
    exposure_alpha: float = metrics.EXPOSURE_ALPHA   #: level of the exposure test
    #: family-wise level of the gross bound (metrics.GROSS_ALPHA): a sub-sample beyond it
    #: fails the scene whatever the pass rate
    gross_alpha: float = metrics.GROSS_ALPHA
    gross_effect: float = metrics.GROSS_EFFECT   #: per-sample sds of a gross difference
    pooled_alpha: float = metrics.POOLED_ALPHA       #: level of each pooled family
    #: random scenes: FLIP <= floor (1 + k0 + k / sqrt(pixels)) + eps (metrics.flip_limit)
    flip_k: float = metrics.FLIP_K
    flip_k0: float = metrics.FLIP_K0
    flip_eps: float = metrics.FLIP_EPS




@dataclass
class Tests:
    """The tests of one scene against the port (``compare.measure``)."""
    z: metrics.ZTest                        #: per sub-sample, linear radiance
    rows: slice                             #: display rows outside the calibration strip
    flip_mean: float
    flip_map: np.ndarray
    rel_mse: float
    rel_mse_noise: float                    #: the relative MSE the variances alone explain
    exposure: metrics.ExposureTest | None   #: page 4: the two sides' auto exposures
    pooled: dict | None                     #: random scenes: tiles and objects
    flip_noise: float | None = None         #: the port against itself (seed + 1)
    noise_z: dict | None = None             #: the z-test of the port against itself


def port_failures(t: Tests, random: bool, pixels: int, th: Thresholds) -> tuple[list[str], float]:
    """The failures of a scene against the port, and the FLIP limit it was held to: a fixed
    one without randomness, else the noise floor's (metrics.flip_limit)."""
    failures = []
    if t.z.pass_rate < th.pass_rate:
        failures.append(f"z-test pass rate {t.z.pass_rate:.5f} < {th.pass_rate}")
    if t.z.gross:
        failures.append(gross_failure(t.z))
    flip_limit = th.flip if not random else metrics.flip_limit(
        t.flip_noise, pixels, th.flip_k, th.flip_eps, th.flip_k0)
    if t.flip_mean > flip_limit:
        failures.append(f"mean FLIP {t.flip_mean:.5f} > {flip_limit:.5f}" + (
            "" if not random else f" (its noise floor {t.flip_noise:.5f} x (1 + {th.flip_k0:g} "
            f"+ {th.flip_k:g} / sqrt({pixels} pixels)) + {th.flip_eps:g})"))
    if t.exposure is not None and not t.exposure.passed:
        failures.append(exposure_failure(t.exposure))
    failures += pooled_failures(t.pooled or {}, "sub-samples")
    return failures, flip_limit


def pooled_failures(pooled: dict, unit: str) -> list[str]:
    """One sentence per pooled family that failed (its worst group), ``unit`` what it pools."""
    failures = []
    for kind, p in pooled.items():
        if not p["passed"]:
            g, c, zz, n = p["failing"][0]
            failures.append(f"pooled z over {kind}: {len(p['failing'])}"
                            f"{'+' if len(p['failing']) == 10 else ''} of {p['tests']} beyond "
                            f"{p['z_critical']:.3g} (worst: {g} {c}, Z {zz:.3g} over "
                            f"{n} {unit})")
    return failures


def gross_failure(z: metrics.ZTest) -> str:
    """A disagreement far beyond noise, which no pass-rate allowance excuses."""
    worst = "inf" if z.max_score is None and z.noisy_tests == 0 else (
        f"{z.max_score:.3g}" if z.max_score is not None else "inf")
    return (f"z-test: {z.gross_sub_samples} sub-samples ({z.gross} channels) differ grossly: "
            f"score beyond {z.z_gross:.3g} (Sidak at {z.gross_alpha:g} family-wise over "
            f"{z.tests} tests) and difference beyond {z.gross_effect:g} per-sample sds "
            f"(largest |score| {worst})")


def exposure_failure(e: metrics.ExposureTest) -> str:
    if e.method == "welch":
        where = f"Welch t = {e.t:.2f} (df {e.df:.1f}), p = {e.p:.2g} < {e.alpha}"
    elif e.method == "welch + spread":
        side = "Mitsuba's" if e.sd[0] <= e.sd[1] else "the port's"
        where = (f"{side} exposure is the same for every seed while the other's varies "
                 f"(exact p = {e.p_spread:.2g}), Welch t = {e.t:.2f} (df {e.df:.1f}), "
                 f"p = {e.p:.2g}; each at {e.alpha / 2:g}")
    else:
        where = "outside the float tolerance (neither side varies)"
    return (f"auto exposure: Mitsuba {e.mean[0]:.4f} (sd {e.sd[0]:.4f}) vs port "
            f"{e.mean[1]:.4f} (sd {e.sd[1]:.4f}) over {e.n[0]} seeds each, "
            f"{100 * e.rel_diff:+.2f} %: {where}")


# -- against a reference image ---------------------------------------------------------------

def bytes_failures(ba: metrics.ByteAgreement, flip_mean: float, th: Thresholds) -> list[str]:
    """An 8-bit reference of a scene without randomness: bytes within one level, FLIP."""
    failures = []
    if ba.within_one < th.pass_rate:
        failures.append(f"bytes within 1 level {ba.within_one:.5f} < {th.pass_rate}")
    if flip_mean > th.flip:
        failures.append(f"mean FLIP {flip_mean:.5f} > {th.flip}")
    return failures


def float_failures(z: metrics.ZTest, th: Thresholds) -> list[str]:
    """A linear reference of a scene without randomness: the float tolerance."""
    if z.pass_rate < th.pass_rate:
        return [f"sub-samples within the float tolerance {z.pass_rate:.5f} < {th.pass_rate}"]
    return []


def statistical_failures(bt: metrics.BlurTest, mt: metrics.MeanTest) -> list[str]:
    """A random scene against a reference: the blurred and the mean difference against the
    noise floor."""
    failures = []
    if not bt.passed:
        failures.append(f"blurred difference: {bt.failing_pixels} pixels beyond the noise floor "
                        f"(max |t| {bt.max_abs_z:.3g} > {bt.z_critical:.3g})")
    if not mt.passed:
        worst = int(np.argmin(mt.p))
        failures.append(f"mean difference {mt.mean_diff[worst]:+.3g} (channel {'RGB'[worst]}), "
                        f"z {mt.z[worst]:.3g}, p {mt.p[worst]:.2g} < {mt.alpha:.2g}")
    return failures


# -- any Mitsuba scene (``--against OTHER.xml``, or an ordinary scene's ``--reference``) ------

#: A noisy channel whose z, as the normal score of its Welch t (each side's variance
#: estimated from its pass means: :func:`metrics.signed_z` with degrees of freedom), lies
#: beyond SCENE_Z_FAR times the Sidak bound of the per-pixel z-test fails the scene on its
#: own, whatever the pass rate: p ~ 1e-19 or less where the bound is 4.5, which noise does
#: not reach (a Welch t is bounded near 1 where one rare sample dominates both its
#: difference and its variance), while one pixel that truly differs does.
SCENE_Z_FAR = 2.0


@dataclass
class SceneTests:
    """The tests of an ordinary scene against another render (``scene_compare.measure``)."""
    z: metrics.ZTest                        #: per pixel, linear radiance
    far_z: float | None                     #: largest |z| (Welch, dof-corrected), noisy channels
    far_where: tuple | None                 #: (x, y, channel) of it, display order
    flip_mean: float
    flip_map: np.ndarray
    flip_noise: float                       #: SCENE against itself with another seed
    rel_mse: float
    rel_mse_noise: float                    #: the relative MSE the variances alone explain
    pooled: dict                            #: tiles, objects (where known), image
    far_judged: bool = True                 #: False: far_z reported, not judged (a reference
                                            #: without a variance image)


def scene_failures(t: SceneTests, pixels: int, th: Thresholds) -> tuple[list[str], float]:
    """The failures of an ordinary scene against another render, and the FLIP limit it was
    held to (its noise floor's, :func:`metrics.flip_limit`): the per-pixel z-test's pass
    rate, a |z| far beyond its Sidak bound (:data:`SCENE_Z_FAR`; where ``far_judged``), FLIP,
    and the pooled
    differences over tiles, objects and the whole image."""
    failures = []
    z = t.z
    if z.pass_rate < th.pass_rate:
        failures.append(f"z-test pass rate {z.pass_rate:.5f} < {th.pass_rate}")
    bound = SCENE_Z_FAR * z.z_critical
    if t.far_judged and t.far_z is not None and t.far_z > bound:
        x, y, c = t.far_where
        failures.append(f"|z| {t.far_z:.3g} at pixel ({x}, {y}) {'RGB'[c]} > {SCENE_Z_FAR:g} x "
                        f"the Sidak bound {z.z_critical:.3g}")
    flip_limit = metrics.flip_limit(t.flip_noise, pixels, th.flip_k, th.flip_eps, th.flip_k0)
    if t.flip_mean > flip_limit:
        failures.append(f"mean FLIP {t.flip_mean:.5f} > {flip_limit:.5f} (its noise floor "
                        f"{t.flip_noise:.5f} x (1 + {th.flip_k0:g} + {th.flip_k:g} / "
                        f"sqrt({pixels} pixels)) + {th.flip_eps:g})")
    failures += pooled_failures(t.pooled, "pixels")
    return failures, flip_limit
