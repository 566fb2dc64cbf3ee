"""``codermind compare``: a tutorial scene rendered by the Mitsuba plugins and by the port,
compared per sub-sample (z-test), perceptually (FLIP) and by relative MSE.

For each scene (:func:`compare_scene`):

1. the twin: a ``.txt`` is converted (full model) into the output folder; an ``.xml`` is used
   as it is, against the tutorial scene its header names (:func:`sides.twin_of`);
2. the exposure of the images: given, or the port's auto exposure for the seed (page 4),
   applied to both, so that the image tests compare radiance, not exposures;
3. both renders at the same sub-sample positions with ``spp`` = Complexity samples each
   (:mod:`codermind_harness.sides`): Mitsuba with ``path``, the port in clean mode;
4. the z-test on linear radiance (:func:`metrics.z_test`), FLIP on the displayed images
   (sRGB before 8 bits, each side's own pipeline, the calibration strip left out), relative
   MSE of Mitsuba against the port, and ``rel_mse_noise``, the relative MSE that the two
   sides' variances alone explain (mean of (var_a + var_b) / (ref^2 + 0.01));
5. page 4, the exposure test: each side's own auto exposure (its probe grid, its random
   numbers) for ``exposure_seeds`` seeds (seed, seed + 1, ...), compared by Welch's t-test
   (:func:`metrics.exposure_test`, level ``Thresholds.exposure_alpha``), whatever exposure
   the images use;
6. the verdict against :class:`Thresholds` (every test must pass), a heat-map PNG, a JSON
   record.
"""

from __future__ import annotations

import json
import math
import os
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from . import metrics, sides
from .sides import Grid, HarnessError


@dataclass
class Thresholds:
    pass_rate: float = 0.99       #: smallest share of sub-samples passing the z-test
    flip: float = 0.01            #: largest mean FLIP of a scene without randomness
    alpha: float = metrics.ALPHA
    rtol: float = metrics.RTOL
    atol: float = metrics.ATOL
    exposure_alpha: float = metrics.EXPOSURE_ALPHA   #: level of the exposure test
    pooled_alpha: float = metrics.POOLED_ALPHA       #: level of each pooled family
    #: random scenes: FLIP <= floor (1 + k0 + k / sqrt(pixels)) + eps (metrics.flip_limit)
    flip_k: float = metrics.FLIP_K
    flip_k0: float = metrics.FLIP_K0
    flip_eps: float = metrics.FLIP_EPS


@dataclass
class Options:
    spp: int | None = None        #: samples per sub-sample (default: sides.default_spp)
    seed: int = 0
    rect: tuple[int, int, int, int] | None = None
    stride: int = 1
    exposure: float | None = None
    blob_max_error: float | None = None
    port_mode: str = "clean"
    quirks: str = "clean"         #: the Mitsuba side's tutorialpath quirks (strict: port strict)
    out_dir: Path = Path("compare")
    defines: dict = field(default_factory=dict)
    thresholds: Thresholds = field(default_factory=Thresholds)
    progress: bool = True
    workers: int | None = None
    noise_floor: bool = False     #: also render the port with seed + 1 (FLIP of noise alone)
    exposure_seeds: int = 8       #: page 4: auto exposures per side for the exposure test
    reference: Path | None = None  #: a reference image as the other side (refimage)


def log(message: str) -> None:
    print(f"compare: {message}", file=sys.stderr, flush=True)


def labels(paths: list[str | os.PathLike]) -> list[str]:
    """A distinct file-name stem per scene: the file's stem, prefixed with its folder's name
    (and suffixed with its type) where two scenes would share it (``page1-scene``)."""
    paths = [Path(p) for p in paths]
    names = [p.stem for p in paths]
    for attempt in (lambda p: f"{p.parent.name}-{p.stem}",
                    lambda p: f"{p.parent.name}-{p.stem}-{p.suffix.lstrip('.')}"):
        if len(set(names)) == len(names):
            break
        names = [attempt(p) if names.count(n) > 1 else n for p, n in zip(paths, names)]
    seen: dict[str, int] = {}
    out = []
    for n in names:                         # the same file twice
        seen[n] = seen.get(n, 0) + 1
        out.append(n if seen[n] == 1 else f"{n}-{seen[n]}")
    return out


@dataclass
class Case:
    """A scene checked and ready to compare (:func:`prepare`)."""
    path: Path                    #: as given
    txt: Path                     #: the tutorial scene file
    xml: Path | None              #: the Mitsuba XML given, None: convert ``txt``
    scene: object                 #: codermind_ref.Scene
    grid: Grid
    random: bool
    spp: int
    reference: object = None      #: refimage.Reference, or None: the port is the other side


def prepare(path: str | os.PathLike, opt: Options) -> Case:
    """Everything about one scene that can be wrong before rendering (its twin, its parse, the
    grid, the options for its page), as a HarnessError naming the problem."""
    txt, xml = sides.twin_of(path)
    scene = sides.parse(txt)
    random = sides.is_random(scene)
    spp = opt.spp or (sides.default_spp(scene) if opt.reference is None
                      else reference_spp(scene, random))
    if spp < 1:
        raise HarnessError(f"--spp must be >= 1, got {spp}")
    if random and spp < 2:
        raise HarnessError(f"{txt}: a random scene needs --spp >= 2 (both sides estimate "
                           "their variance from their samples)")
    if opt.exposure is not None and scene.page == 1:
        raise HarnessError(f"{txt}: page 1 has no exposure")
    if opt.exposure_seeds < 2:
        raise HarnessError(f"--exposure-seeds: must be >= 2 (the test estimates each side's "
                           f"spread), got {opt.exposure_seeds}")
    grid = Grid.of(scene.width, scene.height, scene.page, opt.rect, opt.stride)
    strip_free_rows(grid, scene.page)
    ref = None
    if opt.reference is not None:
        from . import refimage
        ref = refimage.read(opt.reference, scene.width, scene.height, grid.sub)
    return Case(Path(path), txt, xml, scene, grid, random, spp, ref)


def reference_spp(scene, random: bool) -> int:
    """Default samples against a reference image: 1 without randomness, else the scene's
    Complexity (what the tutorial's program renders with, at least 2): the statistical tests
    assume the reference has our side's noise."""
    return max(scene.complexity, 2) if random else 1


def mitsuba_xml(case: Case, opt: Options, label: str, out: Path) -> tuple[Path, dict]:
    """The Mitsuba side's XML (``case.xml``, or ``case.txt`` converted into ``out``) and the
    XML defines the options ask for."""
    txt, xml, scene = case.txt, case.xml, case.scene
    if xml is None:
        xml = sides.convert_xml(txt, scene, out, opt.blob_max_error, name=f"{label}.mitsuba.xml",
                                quirks=opt.quirks)
        defines = dict(opt.defines)
    else:
        defines = dict(opt.defines)
        if opt.quirks != "clean":
            if '<default name="quirks"' not in xml.read_text(encoding="utf-8"):
                raise HarnessError(f"{xml}: no tutorialpath integrator with a quirks default "
                                   "(convert it again without --integrator path)")
            defines["quirks"] = opt.quirks
        if opt.blob_max_error is not None:
            defines.update({f"blob{i}_max_error": str(opt.blob_max_error)
                            for i in range(len(scene.blobs))})
    defines["spp"] = str(case.spp)
    return xml, defines


def compare_scene(path: str | os.PathLike | Case, opt: Options, label: str | None = None) -> dict:
    """Compare one scene; returns its JSON record (``passed``, ``failures``, numbers).
    ``label``: the stem of the files written for it (default: the scene file's stem)."""
    case = path if isinstance(path, Case) else prepare(path, opt)
    path, txt, xml, scene, grid = case.path, case.txt, case.xml, case.scene, case.grid
    random, spp = case.random, case.spp
    label = label or path.stem
    if scene.page != 4 and spp != 1:
        log(f"{txt.name}: page {scene.page} is deterministic; --spp {spp} changes nothing "
            "(the port ignores it)")
    out = Path(opt.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if case.reference is not None:
        return compare_reference(case, opt, label, out)
    xml, defines = mitsuba_xml(case, opt, label, out)
    seeds = [opt.seed + k for k in range(opt.exposure_seeds)] if scene.page == 4 else []
    t0 = time.perf_counter()
    port_es = sides.port_exposures(scene, seeds, opt.port_mode)
    port_probe_seconds = time.perf_counter() - t0
    exposure = opt.exposure
    if exposure is None:
        exposure = port_es[0] if port_es else sides.port_exposure(scene, opt.seed,
                                                                  opt.port_mode)
    log(f"{txt.name}: page {scene.page}, {grid.pixels} pixels, {spp} spp, seed {opt.seed}"
        + ("" if exposure is None else f", exposure {exposure:.6g}"))

    port = sides.render_port(scene, grid, spp, opt.seed, exposure, opt.port_mode, random,
                             opt.workers, opt.progress)
    # iid: the pooled tests need the port's kind of estimator on both sides (sides.iid_sampler_xml)
    mits = sides.render_mitsuba(xml, grid, spp, opt.seed, exposure, defines,
                                progress=opt.progress, exposure_seeds=seeds, iid=random)
    ties = None
    own = port                      # the noise floor is the port against itself, unmerged
    if not random:
        # exact ties between two spheres: either sphere is a faithful float renderer's answer
        last = sides.render_port(scene, grid, spp, opt.seed, exposure, opt.port_mode, random,
                                 opt.workers, False, ties="last")
        port, tie_pixels, tie_last = sides.either_tie(mits, port, last, grid.sub)
        ties = {"pixels": tie_pixels, "mitsuba_took_last": tie_last}
        if tie_pixels:
            log(f"{txt.name}: {tie_pixels} pixels see two spheres at exactly the same distance;"
                f" Mitsuba matches the later sphere at {tie_last} of them")
    th = opt.thresholds
    etest = None
    if seeds:
        etest = metrics.exposure_test(mits.probe_exposures, port_es, th.exposure_alpha,
                                      th.rtol, th.atol)
    z = metrics.z_test(mits.linear, mits.variance, port.linear, port.variance, th.alpha,
                       th.rtol, th.atol)
    pooled = pooled_tests(mits, port, xml, grid, defines, random, th) if random else None
    rows = strip_free_rows(grid, scene.page)
    flip_mean, flip_map = metrics.flip(port.encoded[rows], mits.encoded[rows])
    rel = metrics.rel_mse(mits.linear, port.linear)
    rel_noise = float(np.mean((mits.variance + port.variance)
                              / (np.square(port.linear) + metrics.REL_MSE_EPS)))
    flip_noise = noise_z = None
    if opt.noise_floor or random:
        log(f"{txt.name}: the port again with seed {opt.seed + 1} (noise floor)")
        again = sides.render_port(scene, grid, spp, opt.seed + 1, exposure, opt.port_mode,
                                  random, opt.workers, opt.progress)
        flip_noise = metrics.flip(own.encoded[rows], again.encoded[rows])[0]
        zn = metrics.z_test(again.linear, again.variance, own.linear, own.variance,
                            th.alpha, th.rtol, th.atol)
        noise_z = {"pass_rate": zn.pass_rate, "failing_sub_samples": int((~zn.passed_map).sum()),
                   "max_abs_z": zn.max_z, "z_sd": zn.z_sd}

    failures = []
    if z.pass_rate < th.pass_rate:
        failures.append(f"z-test pass rate {z.pass_rate:.5f} < {th.pass_rate}")
    flip_limit = th.flip if not random else metrics.flip_limit(
        flip_noise, grid.pixels, th.flip_k, th.flip_eps, th.flip_k0)
    if flip_mean > flip_limit:
        failures.append(f"mean FLIP {flip_mean:.5f} > {flip_limit:.5f}" + (
            "" if not random else f" (its noise floor {flip_noise:.5f} x (1 + {th.flip_k0:g} "
            f"+ {th.flip_k:g} / sqrt({grid.pixels} pixels)) + {th.flip_eps:g})"))
    if etest is not None and not etest.passed:
        failures.append(exposure_failure(etest))
    for kind, p in (pooled or {}).items():
        if not p["passed"]:
            g, c, zz, n = p["failing"][0]
            failures.append(f"pooled z over {kind}: {len(p['failing'])}"
                            f"{'+' if len(p['failing']) == 10 else ''} of {p['tests']} beyond "
                            f"{p['z_critical']:.3g} (worst: {g} {c}, Z {zz:.3g} over "
                            f"{n} sub-samples)")
    heatmap = out / f"{label}.compare.png"
    write_heatmap(heatmap, mits.encoded, port.encoded, rows, flip_map, z, port.label,
                  f"{label}: pass rate {z.pass_rate:.4f}, FLIP {flip_mean:.4f}, "
                  f"relMSE {rel:.3g}")
    record = {
        "scene": str(path), "label": label, "tutorial_scene": str(txt), "xml": str(xml), "page": scene.page,
        "width": scene.width, "height": scene.height,
        "rect": list(grid.rect), "stride": grid.stride, "pixels": grid.pixels,
        "sub_samples": int(z.passed_map.size), "spp": spp, "seed": opt.seed,
        "random": random, "exposure": exposure, "port_mode": opt.port_mode,
        "quirks": opt.quirks,
        "defines": defines,
        "z_test": {"pass_rate": z.pass_rate, "channel_pass_rate": z.channel_pass_rate,
                   "tests": z.tests, "alpha": th.alpha, "alpha_sidak": z.alpha,
                   "z_critical": z.z_critical, "noiseless_sub_samples": z.noiseless,
                   "noisy_tests": z.noisy_tests,
                   "failing_sub_samples": int((~z.passed_map).sum()),
                   "max_abs_z": z.max_z, "z_mean": z.z_mean, "z_sd": z.z_sd,
                   "rtol": th.rtol, "atol": th.atol},
        "pooled": pooled, "ties": ties, "flip_limit": flip_limit,
        "flip_mean": flip_mean, "flip_noise": flip_noise, "z_test_noise": noise_z,
        "rel_mse": rel,
        "rel_mse_noise": rel_noise,
        "exposure_test": None if etest is None else {
            "seeds": seeds, "mitsuba": mits.probe_exposures, "port": port_es,
            **asdict(etest)},
        "thresholds": {"pass_rate": th.pass_rate, "flip": th.flip,
                       "exposure_alpha": th.exposure_alpha, "pooled_alpha": th.pooled_alpha,
                       "flip_k": th.flip_k, "flip_k0": th.flip_k0,
                       "flip_eps": th.flip_eps},
        "passed": not failures, "failures": failures,
        "seconds": {"port": port.seconds, "mitsuba": mits.seconds,
                    "mitsuba_load": mits.load_seconds,
                    "port_probes": port_probe_seconds, "mitsuba_probes": mits.probe_seconds},
        "heatmap": str(heatmap),
    }
    return record


def compare_reference(case: Case, opt: Options, label: str, out: Path) -> dict:
    """One scene's Mitsuba side against a reference image (``--reference``; module
    :mod:`codermind_harness.refimage`). Our side follows ``codermind render``'s exposure
    rules (page 4: its own probe exposure for the seed, unless ``--exposure``; pages 2-3: 1).

    * 8-bit reference, scene without randomness: its bytes against ours (the share identical
      and the share within one level, which must reach the pass rate) and FLIP;
    * linear (EXR) reference, scene without randomness: the float tolerance per sub-sample
      (:func:`metrics.z_test` with no variance on either side);
    * a random scene, either kind: our side again with seed + 1 is the noise floor; the
      Gaussian-blurred difference (:func:`metrics.blur_test`) and the mean difference
      (:func:`metrics.mean_test`) against it, both with the spread of the auto exposure
      (page 4) over ``exposure_seeds`` seeds of our side; FLIP and its floor reported."""
    from codermind.tutorial.image import to_bytes
    from codermind.tutorial.render import read_settings
    path, txt, scene, grid, ref = case.path, case.txt, case.scene, case.grid, case.reference
    random, spp, th = case.random, case.spp, opt.thresholds
    xml, defines = mitsuba_xml(case, opt, label, out)
    settings = read_settings(xml)
    if settings is None:
        raise HarnessError(f"{xml}: not a converted tutorial scene (no codermind-tutorial block)")
    page4_auto = scene.page == 4 and opt.exposure is None
    eseeds = [opt.seed + k for k in range(max(opt.exposure_seeds, 2))] if page4_auto else []
    log(f"{txt.name}: page {scene.page}, {grid.pixels} pixels, {spp} spp, seed {opt.seed}, "
        f"against {ref.path.name} ({ref.kind})")
    mits = sides.render_mitsuba(xml, grid, spp, opt.seed, None, defines, variance=False,
                                progress=opt.progress, exposure_seeds=eseeds)
    again = None
    if random:
        log(f"{txt.name}: our side again with seed {opt.seed + 1} (noise floor)")
        again = sides.render_mitsuba(xml, grid, spp, opt.seed + 1, None, defines,
                                     variance=False, progress=opt.progress)
    if page4_auto:
        exposures = [float(e) for e in mits.probe_exposures]
    else:
        e = opt.exposure if opt.exposure is not None else (None if scene.page == 1 else 1.0)
        exposures = [e, e]
    enc = [sides.encode_mitsuba(s.linear, settings, e)
           for s, e in zip([mits] + ([again] if again else []), exposures)]
    var_log_e = float(np.var(np.log(exposures), ddof=1)) if page4_auto else 0.0
    rows = strip_free_rows(grid, scene.page)
    record = {"scene": str(path), "label": label, "tutorial_scene": str(txt), "xml": str(xml),
              "page": scene.page, "width": scene.width, "height": scene.height,
              "rect": list(grid.rect), "stride": grid.stride, "pixels": grid.pixels,
              "spp": spp, "seed": opt.seed, "random": random, "quirks": opt.quirks,
              "defines": defines, "reference": str(ref.path), "reference_kind": ref.kind,
              "exposure": exposures[0], "exposure_again": exposures[1] if again else None,
              "exposure_seeds": eseeds, "exposures": exposures if page4_auto else None,
              "var_log_exposure": var_log_e,
              "bytes": None, "float_test": None, "blur_test": None, "mean_test": None}
    failures = []
    if ref.kind == "8-bit":
        ours = [to_bytes(x) for x in enc]
        theirs = ref.grid_pixels(grid)
        shown = theirs / 255.0
        flip_mean, flip_map = metrics.flip(shown[rows], ours[0][rows] / 255.0)
        flip_noise = (metrics.flip(ours[1][rows] / 255.0, ours[0][rows] / 255.0)[0]
                      if again else None)
        ba = metrics.byte_agreement(ours[0][rows], theirs[rows])
        record["bytes"] = {"identical": ba.identical, "within_one": ba.within_one,
                           "max_diff": ba.max_diff, "bytes": ba.bytes}
        if not random:
            method = "bytes"
            zmap = _Map(ba.diff_map.astype(float), ba.diff_map <= 1, 1.0)
            if ba.within_one < th.pass_rate:
                failures.append(f"bytes within 1 level {ba.within_one:.5f} < {th.pass_rate}")
            if flip_mean > th.flip:
                failures.append(f"mean FLIP {flip_mean:.5f} > {th.flip}")
        else:
            a, b, r = ours[0][rows] / 255.0, ours[1][rows] / 255.0, theirs[rows] / 255.0
            slope = None
            if page4_auto:
                h = 1e-2
                up, down = (to_bytes(sides.encode_mitsuba(mits.linear, settings,
                                                          exposures[0] * math.exp(s)))
                            for s in (h, -h))
                slope = ((up.astype(float) - down) / (255.0 * 2 * h))[rows]
            # half a level per blurred pixel (identical truncation on both sides, but regions
            # without noise); a twentieth of a level for the mean of the whole grid
            method, zmap = _statistical(record, failures, a, b, r, 0.5 / 255.0, slope,
                                        var_log_e, th, mean_tol=0.05 / 255.0)
    else:
        theirs = ref.grid_film(grid)
        e0 = exposures[0]
        shown = sides.encode_mitsuba(theirs, settings, e0)
        flip_mean, flip_map = metrics.flip(shown[rows], enc[0][rows])
        flip_noise = (metrics.flip(sides.encode_mitsuba(again.linear, settings, e0)[rows],
                                   enc[0][rows])[0] if again else None)
        if not random:
            method = "float tolerance"
            zero = np.zeros_like(theirs)
            z = metrics.z_test(mits.linear, zero, theirs, zero, th.alpha, th.rtol, th.atol)
            record["float_test"] = {"pass_rate": z.pass_rate, "sub_samples": int(z.passed_map.size),
                                    "failing_sub_samples": int((~z.passed_map).sum()),
                                    "rtol": th.rtol, "atol": th.atol}
            zmap = _Map(np.minimum(z.z_map, 2.0), z.passed_map, 1.0)
            if z.pass_rate < th.pass_rate:
                failures.append(f"sub-samples within the float tolerance {z.pass_rate:.5f} < "
                                f"{th.pass_rate}")
        else:
            tol = th.rtol * np.abs(theirs) + th.atol
            method, zmap = _statistical(record, failures, mits.linear, again.linear, theirs,
                                        tol, None, 0.0, th)
    heatmap = out / f"{label}.compare.png"
    write_heatmap(heatmap, enc[0], shown, rows, flip_map, zmap, f"reference {ref.path.name}",
                  f"{label} against {ref.path.name}: {method}, FLIP {flip_mean:.4f}",
                  zlabel="|blurred t|" if random else "|difference|")
    record.update({"method": method, "flip_mean": flip_mean, "flip_noise": flip_noise,
                   "thresholds": {"pass_rate": th.pass_rate, "flip": th.flip,
                                  "alpha": th.alpha},
                   "passed": not failures, "failures": failures,
                   "seconds": {"mitsuba": mits.seconds + (again.seconds if again else 0.0),
                               "mitsuba_load": mits.load_seconds,
                               "mitsuba_probes": mits.probe_seconds},
                   "heatmap": str(heatmap)})
    return record


@dataclass
class _Map:
    """What the heat map's last panel shows (as :class:`metrics.ZTest` gives it)."""
    z_map: np.ndarray
    passed_map: np.ndarray
    z_critical: float


def _statistical(record: dict, failures: list, a, b, r, tol, slope, var_log_e,
                 th: Thresholds, mean_tol: float | None = None) -> tuple[str, _Map]:
    bt = metrics.blur_test(a, b, r, tol, slope, var_log_e, th.alpha)
    mean_tol = float(np.mean(tol)) if mean_tol is None else mean_tol
    mt = metrics.mean_test(a, b, r, mean_tol, slope, var_log_e, th.alpha)
    record["blur_test"] = {k: v for k, v in asdict(bt).items()
                           if k not in ("z_map", "passed_map")}
    record["mean_test"] = asdict(mt)
    if not bt.passed:
        failures.append(f"blurred difference: {bt.failing_pixels} pixels beyond the noise floor "
                        f"(max |t| {bt.max_abs_z:.3g} > {bt.z_critical:.3g})")
    if not mt.passed:
        worst = int(np.argmin(mt.p))
        failures.append(f"mean difference {mt.mean_diff[worst]:+.3g} (channel {'RGB'[worst]}), "
                        f"z {mt.z[worst]:.3g}, p {mt.p[worst]:.2g} < {mt.alpha:.2g}")
    return "statistical", _Map(bt.z_map, bt.passed_map, bt.z_critical)


def pooled_tests(mits, port, xml: Path, grid: Grid, defines: dict, random: bool,
                 th: Thresholds) -> dict:
    """The pooled difference sum(a - b) / sqrt(sum(var_a + var_b)) over tiles of 16 x 16
    sub-samples and over each object's sub-samples (the shape Mitsuba's lens-centre ray sees
    first; the sky is one group), as a normal score with Welch-Satterthwaite degrees of
    freedom, each family at ``Thresholds.pooled_alpha`` Sidak-corrected
    (metrics.pooled_difference: centred for any two unbiased sides, which Stouffer's Z of
    the per-sub-sample z is not)."""
    dofs = [np.inf if s.dof is None else s.dof for s in (mits, port)]
    args = (mits.linear, mits.variance, port.linear, port.variance)
    out = {"tiles": metrics.pooled_difference(*args, metrics.tile_labels(mits.linear.shape[:2]),
                                              "tiles", *dofs, th.pooled_alpha, th.rtol, th.atol)}
    labels_, names = sides.object_labels(xml, grid, defines)
    labels_ = np.where(labels_ < 0, len(names), labels_)
    out["objects"] = metrics.pooled_difference(*args, labels_, "objects", *dofs,
                                               th.pooled_alpha, th.rtol, th.atol,
                                               names=names + ["sky"])
    return {k: asdict(v) for k, v in out.items()}


def exposure_failure(e: metrics.ExposureTest) -> str:
    where = (f"Welch t = {e.t:.2f} (df {e.df:.1f}), p = {e.p:.2g} < {e.alpha}"
             if e.method == "welch" else "outside the float tolerance (neither side varies)")
    return (f"auto exposure: Mitsuba {e.mean[0]:.4f} (sd {e.sd[0]:.4f}) vs port "
            f"{e.mean[1]:.4f} (sd {e.sd[1]:.4f}) over {e.n[0]} seeds each, "
            f"{100 * e.rel_diff:+.2f} %: {where}")


def strip_free_rows(grid: Grid, page: int) -> slice:
    """Display rows of the grid's image that are rendered (pages 2 and 4 replace tutorial rows
    y < 10 by the calibration strip, which both sides write identically)."""
    if page == 1:
        return slice(None)
    keep = int((grid.ys >= 10).sum())
    if keep == 0:
        raise HarnessError("the grid lies entirely in the calibration strip (y < 10)")
    return slice(0, keep)


def write_heatmap(path: Path, mits: np.ndarray, port: np.ndarray, rows: slice,
                  flip_map: np.ndarray, z: metrics.ZTest, port_label: str, title: str,
                  zlabel: str = "|z| per sub-sample") -> None:
    """One PNG: both images, the FLIP map and the |z| map (failing sub-samples in red)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from codermind.imageio import atomic_path
    with _PYPLOT:       # pyplot is not thread-safe (scenes compared in threads on a cluster)
        _heatmap(plt, matplotlib, atomic_path, path, mits, port, rows, flip_map, z,
                 port_label, title, zlabel)


_PYPLOT = threading.Lock()


def _heatmap(plt, matplotlib, atomic_path, path, mits, port, rows, flip_map, z, port_label,
             title, zlabel="|z| per sub-sample") -> None:
    h, w = mits.shape[:2]
    panel = min(max(w / 100, 2.5), 5.0)          # inches: small grids enlarged, large shrunk
    fig, axes = plt.subplots(2, 2, figsize=(2 * panel + 1.5, 2 * panel * h / w + 1.2),
                             dpi=100, constrained_layout=True)
    axes[0, 0].imshow(mits, interpolation="nearest")
    axes[0, 0].set_title("Mitsuba", fontsize=9)
    axes[0, 1].imshow(port, interpolation="nearest")
    axes[0, 1].set_title(port_label, fontsize=9)
    full_flip = np.full((h, w), np.nan)
    full_flip[rows] = flip_map
    im = axes[1, 0].imshow(full_flip, cmap="magma", vmin=0.0, vmax=1.0, interpolation="nearest")
    axes[1, 0].set_title("FLIP" + (" (strip rows blank)" if flip_map.shape[0] < h else ""),
                         fontsize=9)
    fig.colorbar(im, ax=axes[1, 0], shrink=0.8)
    zmap = np.minimum(z.z_map, 2 * z.z_critical)
    im = axes[1, 1].imshow(zmap, cmap="viridis", vmin=0.0, vmax=z.z_critical,
                           interpolation="nearest")
    fails = np.ma.masked_where(z.passed_map, np.ones(z.passed_map.shape))
    axes[1, 1].imshow(fails, cmap=matplotlib.colors.ListedColormap(["red"]), vmin=0, vmax=1,
                      interpolation="nearest")
    axes[1, 1].set_title(f"{zlabel} (red: fails, > {z.z_critical:.3g})",
                         fontsize=9)
    fig.colorbar(im, ax=axes[1, 1], shrink=0.8)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title, fontsize=10)
    with atomic_path(path, ".png") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def format_table(records: list[dict]) -> str:
    """Fixed-width tables: the image tests, one row per scene (``E test``: the exposure
    test's verdict), then the exposure test, one row per page-4 scene; scenes compared with a
    reference image (``--reference``) in a table of their own."""
    refs = [r for r in records if r.get("reference")]
    records = [r for r in records if not r.get("reference")]
    parts = ([_port_table(records)] if records else []) + ([_reference_table(refs)] if refs else [])
    return "\n\n".join(parts)


def _reference_table(records: list[dict]) -> str:
    head = ("scene", "reference", "page", "pixels", "spp", "exposure", "method", "identical",
            "within 1/tol", "max|t|", "t crit", "mean z", "FLIP", "FLIP noise", "mitsuba s",
            "verdict")
    rows = []
    for r in records:
        b, bt, mt = r["bytes"], r["blur_test"], r["mean_test"]
        worst = None if mt is None else max(mt["z"], key=abs)
        rows.append((r["label"], Path(r["reference"]).name, str(r["page"]), str(r["pixels"]),
                     str(r["spp"]), "-" if r["exposure"] is None else f"{r['exposure']:.4g}",
                     r["method"], "-" if b is None else f"{b['identical']:.5f}",
                     f"{b['within_one']:.5f}" if b else
                     f"{r['float_test']['pass_rate']:.5f}" if r["float_test"] else "-",
                     "-" if bt is None else _num(bt["max_abs_z"], ".3g"),
                     "-" if bt is None else f"{bt['z_critical']:.3g}",
                     "-" if worst is None else _num(worst, ".3g"),
                     f"{r['flip_mean']:.5f}", _num(r["flip_noise"], ".5f"),
                     f"{r['seconds']['mitsuba']:.1f}", "pass" if r["passed"] else "FAIL"))
    return _fixed(head, rows)


def _port_table(records: list[dict]) -> str:
    head = ("scene", "page", "pixels", "spp", "exposure", "pass rate", "fail", "max|z|",
            "z sd", "pooled", "FLIP", "FLIP noise", "relMSE", "noise", "E test", "port s",
            "mitsuba s", "verdict")
    rows = []
    for r in records:
        z = r["z_test"]
        e = r.get("exposure_test")
        rows.append((r["label"], str(r["page"]), str(r["pixels"]), str(r["spp"]),
                     "-" if r["exposure"] is None else f"{r['exposure']:.4g}",
                     f"{z['pass_rate']:.5f}", str(z["failing_sub_samples"]),
                     _num(z["max_abs_z"], ".3g"), _num(z["z_sd"], ".3f"), _pooled(r),
                     f"{r['flip_mean']:.5f}",
                     _num(r["flip_noise"], ".5f"), f"{r['rel_mse']:.3g}", f"{r['rel_mse_noise']:.3g}",
                     "-" if e is None else "pass" if e["passed"] else "FAIL",
                     f"{r['seconds']['port']:.1f}", f"{r['seconds']['mitsuba']:.1f}",
                     "pass" if r["passed"] else "FAIL"))
    text = _fixed(head, rows)
    tested = [r for r in records if r.get("exposure_test")]
    if tested:
        e0 = tested[0]["exposure_test"]
        head = ("scene", "seeds", "mitsuba E", "sd", "port E", "sd", "diff %", "t", "df", "p",
                "E test")
        rows = []
        for r in tested:
            e = r["exposure_test"]
            rows.append((r["label"], f"{e['seeds'][0]}-{e['seeds'][-1]}",
                         f"{e['mean'][0]:.4f}", f"{e['sd'][0]:.4f}", f"{e['mean'][1]:.4f}",
                         f"{e['sd'][1]:.4f}", f"{100 * e['rel_diff']:+.2f}",
                         _num(e["t"], ".2f"), _num(e["df"], ".1f"), _num(e["p"], ".2g"),
                         "pass" if e["passed"] else "FAIL"))
        text += (f"\n\nexposure test: each side's auto exposure over {len(e0['seeds'])} seeds, "
                 f"Welch's t-test, alpha {e0['alpha']:g} (two-sided)\n" + _fixed(head, rows))
    return text


def _pooled(r: dict) -> str:
    """The pooled tests' verdict and largest |Z| (tiles / objects)."""
    p = r.get("pooled")
    if not p:
        return "-"
    cell = "/".join(_num(v["max_abs_z"], ".2g") for v in p.values())
    return cell + ("" if all(v["passed"] for v in p.values()) else " FAIL")


def _fixed(head, rows) -> str:
    widths = [max(len(x) for x in col) for col in zip(head, *rows)]
    line = lambda cells: "  ".join(c.rjust(w) if i else c.ljust(w)   # noqa: E731
                                   for i, (c, w) in enumerate(zip(cells, widths)))
    return "\n".join([line(head), line(["-" * w for w in widths])] + [line(r) for r in rows])


def _num(x: float | None, fmt: str) -> str:
    return "-" if x is None else "inf" if math.isinf(x) else format(x, fmt)


def write_json(path: Path, payload) -> None:
    from codermind.imageio import atomic_path
    with atomic_path(path, ".json") as tmp:
        tmp.write_text(json.dumps(payload, indent=2, default=_jsonable) + "\n", encoding="utf-8")


def _jsonable(x):
    if isinstance(x, Path):
        return str(x)
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"not JSON serializable: {type(x).__name__}")


def run(scenes: list[str], opt: Options, variant: str | None = None) -> tuple[list[dict], int]:
    """Compare every scene, write ``compare.json`` and ``compare.txt`` into the output folder.
    Returns (records, exit status: 0 all pass, 1 some scene fails its thresholds)."""
    from codermind.variants import set_variant
    set_variant(variant)
    import codermind  # noqa: F401  (registers the plugins)
    t0 = time.perf_counter()
    cases = [prepare(s, opt) for s in scenes]      # bad input stops before any rendering
    jobs = list(zip(cases, labels(scenes)))
    from .cluster import current
    if current() is None or len(jobs) < 2:
        records = [compare_scene(c, opt, label) for c, label in jobs]
    else:           # every scene's tasks in flight together on the cluster
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(min(len(jobs), 8)) as pool:
            records = list(pool.map(lambda job: compare_scene(job[0], opt, job[1]), jobs))
    out = Path(opt.out_dir)
    table = format_table(records)
    write_json(out / "compare.json", {"options": _options_json(opt), "scenes": records,
                                      "seconds": time.perf_counter() - t0})
    from codermind.imageio import atomic_path
    with atomic_path(out / "compare.txt", ".txt") as tmp:
        tmp.write_text(table + "\n", encoding="utf-8")
    return records, 0 if all(r["passed"] for r in records) else 1


def _options_json(opt: Options) -> dict:
    d = asdict(opt)
    d["out_dir"] = str(opt.out_dir)
    return d
