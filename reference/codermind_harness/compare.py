"""``codermind compare``: a tutorial scene rendered by the Mitsuba plugins and by the port,
compared per sub-sample (z-test), perceptually (FLIP) and by relative MSE.

For each scene (:func:`compare_scene`):

1. the twin: a ``.txt`` is converted (full model) into the output folder; an ``.xml`` is used
   as it is, against the tutorial scene its header names (:func:`sides.twin_of`);
2. the exposure of the images: given, or the port's auto exposure for the seed (page 4),
   applied to both, so that the image tests compare radiance, not exposures;
3. both renders at the same sub-sample positions with ``spp`` = Complexity samples each
   (:func:`render_sides`): Mitsuba with ``path``, the port in clean mode;
4. the tests (:func:`measure`): the z-test on linear radiance (:func:`metrics.z_test`),
   FLIP on the displayed images (sRGB before 8 bits, each side's own pipeline, the
   calibration strip left out), relative MSE of Mitsuba against the port, and
   ``rel_mse_noise``, the relative MSE that the two sides' variances alone explain (mean of
   (var_a + var_b) / (ref^2 + 0.01));
5. page 4, the exposure test: each side's own auto exposure (its probe grid, its random
   numbers) for ``exposure_seeds`` seeds (seed, seed + 1, ...), compared by Welch's t-test
   (:func:`metrics.exposure_test`, level ``Thresholds.exposure_alpha``; where one side's
   exposure is the same for every seed and the other's is not, also by an exact
   permutation test of that), whatever exposure the images use;
6. the verdict against :class:`Thresholds` (every test must pass; :mod:`.verdict`), a
   heat-map PNG and a JSON record (:mod:`.report`).

``--reference IMAGE`` compares the Mitsuba side with an image instead
(:mod:`.compare_image`). Any other Mitsuba XML (no tutorial twin, or ``--against OTHER.xml``)
is compared with another render of it (:mod:`.scene_compare`). The renders are units of the
runner handed in (:mod:`.runner`).
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict
from pathlib import Path

import numpy as np

from . import metrics, report, scene_compare, sides, verdict
from .case import Case, Options, labels, log, mitsuba_xml, prepare, strip_free_rows
from .compare_image import compare_reference
from .report import format_table  # noqa: F401  (the command prints the tables)
from .runner import LOCAL, Runner
from .scene_compare import SceneCase
from .sides import Grid, Renders
from .verdict import Tests, Thresholds


def prepare_any(path: str | os.PathLike, opt: Options) -> Case | SceneCase:
    """A tutorial scene's :class:`Case`, or an ordinary Mitsuba scene's
    :class:`~.scene_compare.SceneCase` (``--against``, or an XML without a tutorial twin)."""
    if scene_compare.is_ordinary(path, opt):
        return scene_compare.prepare(path, opt)
    return prepare(path, opt)


def compare_scene(path: str | os.PathLike | Case | SceneCase, opt: Options,
                  label: str | None = None, runner: Runner = LOCAL) -> dict:
    """Compare one scene; returns its JSON record (``passed``, ``failures``, numbers).
    ``label``: the stem of the files written for it (default: the scene file's stem)."""
    case = path if isinstance(path, (Case, SceneCase)) else prepare_any(path, opt)
    label = label or case.path.stem
    if isinstance(case, SceneCase):
        out = Path(opt.out_dir)
        out.mkdir(parents=True, exist_ok=True)
        return scene_compare.compare(case, opt, label, out, runner)
    if case.scene.page != 4 and case.spp != 1:
        log(f"{case.txt.name}: page {case.scene.page} is deterministic; --spp {case.spp} "
            "changes nothing (the port ignores it)")
    out = Path(opt.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if case.reference is not None:
        return compare_reference(case, opt, label, out, runner)
    renders = render_sides(case, opt, label, out, runner)
    tests = measure(case, opt, renders)
    failures, flip_limit = verdict.port_failures(tests, case.random, case.grid.pixels,
                                                 opt.thresholds)
    heatmap = report.port_heatmap(out, label, renders, tests)
    return report.port_record(case, opt, label, renders, tests, failures, flip_limit, heatmap)


def render_sides(case: Case, opt: Options, label: str, out: Path,
                 runner: Runner = LOCAL) -> sides.Renders:
    """Both sides of ``case`` at one exposure, their renders units of ``runner``: the port
    with either tie rule where they differ (a scene without randomness), the port again with
    seed + 1 where the verdict needs its noise floor, each side's auto exposures (page 4)."""
    txt, scene, grid, random, spp = case.txt, case.scene, case.grid, case.random, case.spp
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

    def port(seed: int, progress: bool, ties: str = "first") -> sides.SideImage:
        return sides.render_port(scene, grid, spp, seed, exposure, opt.port_mode, random,
                                 opt.workers, progress, ties=ties, runner=runner)

    own = port(opt.seed, opt.progress)
    # iid: the pooled tests need the port's kind of estimator on both sides (sides.iid_sampler_xml)
    mits = sides.render_mitsuba(xml, grid, spp, opt.seed, exposure, defines,
                                progress=opt.progress, exposure_seeds=seeds, iid=random,
                                runner=runner)
    r = Renders(xml, defines, exposure, seeds, port_es, port_probe_seconds, own, mits, own)
    if not random:
        # exact ties between two spheres: either sphere is a faithful float renderer's answer
        last = port(opt.seed, False, ties="last")
        r.port, tie_pixels, tie_last = sides.either_tie(mits, own, last, grid.sub)
        r.ties = {"pixels": tie_pixels, "mitsuba_took_last": tie_last}
        if tie_pixels:
            log(f"{txt.name}: {tie_pixels} pixels see two spheres at exactly the same distance;"
                f" Mitsuba matches the later sphere at {tie_last} of them")
    if opt.noise_floor or random:
        log(f"{txt.name}: the port again with seed {opt.seed + 1} (noise floor)")
        r.again = port(opt.seed + 1, opt.progress)
    return r


def measure(case: Case, opt: Options, r: Renders) -> Tests:
    """The tests of both sides' renders (no verdict: :func:`verdict.port_failures`)."""
    th, mits, port = opt.thresholds, r.mits, r.port
    etest = None
    if r.seeds:
        etest = metrics.exposure_test(mits.probe_exposures, r.port_exposures, th.exposure_alpha,
                                      th.rtol, th.atol)
    z = metrics.z_test(mits.linear, mits.variance, port.linear, port.variance, th.alpha,
                       th.rtol, th.atol, **sample_counts(mits, port), gross_alpha=th.gross_alpha,
                       gross_effect=th.gross_effect)
    pooled = (pooled_tests(mits, port, r.xml, case.grid, r.defines, case.random, th)
              if case.random else None)
    rows = strip_free_rows(case.grid, case.scene.page)
    flip_mean, flip_map = metrics.flip(port.encoded[rows], mits.encoded[rows])
    rel_noise = float(np.mean((mits.variance + port.variance)
                              / (np.square(port.linear) + metrics.REL_MSE_EPS)))
    t = Tests(z, rows, flip_mean, flip_map, metrics.rel_mse(mits.linear, port.linear),
              rel_noise, etest, pooled)
    if r.again is not None:         # the noise floor: the port against itself, unmerged
        own, again = r.own, r.again
        t.flip_noise = metrics.flip(own.encoded[rows], again.encoded[rows])[0]
        zn = metrics.z_test(again.linear, again.variance, own.linear, own.variance,
                            th.alpha, th.rtol, th.atol, **sample_counts(again, own),
                            gross_alpha=th.gross_alpha, gross_effect=th.gross_effect)
        t.noise_z = {"pass_rate": zn.pass_rate, "failing_sub_samples": int((~zn.passed_map).sum()),
                     "max_abs_z": zn.max_z, "z_sd": zn.z_sd, "max_abs_score": zn.max_score,
                     "gross": zn.gross, "z_gross": zn.z_gross, "calibration": zn.calibration}
    return t


def sample_counts(a: sides.SideImage, b: sides.SideImage) -> dict:
    """The degrees of freedom and sample counts of two sides' variances, for
    :func:`metrics.z_test` (none where a side estimated no variance: a scene without
    randomness)."""
    if a.dof is None or b.dof is None:
        return {}
    return {"dof_a": a.dof, "dof_b": b.dof, "n_a": a.spp, "n_b": b.spp}


def pooled_tests(mits, port, xml: Path, grid: Grid, defines: dict, random: bool,
                 th: Thresholds) -> dict:
    """The pooled difference sum(a - b) / sqrt(sum(var_a + var_b)) over tiles of 16 x 16
    sub-samples and over each object's sub-samples (the shape Mitsuba's lens-centre ray sees
    first; the sky is one group) and each point light's (the first hits it lights:
    sides.geometry_groups), as a normal score with Welch-Satterthwaite degrees of
    freedom, each family (tiles; objects and lights) at ``Thresholds.pooled_alpha``
    Sidak-corrected
    (metrics.pooled_difference: centred for any two unbiased sides, which Stouffer's Z of
    the per-sub-sample z is not)."""
    dofs = [np.inf if s.dof is None else s.dof for s in (mits, port)]
    args = (mits.linear, mits.variance, port.linear, port.variance)
    out = {"tiles": metrics.pooled_difference(*args, metrics.tile_labels(mits.linear.shape[:2]),
                                              "tiles", *dofs, th.pooled_alpha, th.rtol, th.atol)}
    groups = sides.geometry_groups(xml, grid, defines)
    labels_ = np.where(groups.labels < 0, len(groups.names), groups.labels)
    out["objects"] = metrics.pooled_difference(
        *args, labels_, "objects", *dofs, th.pooled_alpha, th.rtol, th.atol,
        names=groups.names + ["sky"] + groups.light_names, masks=groups.lit)
    return {k: asdict(v) for k, v in out.items()}


def run(scenes: list[str], opt: Options, variant: str | None = None,
        runner: Runner = LOCAL) -> tuple[list[dict], int]:
    """Compare every scene, write ``compare.json`` and ``compare.txt`` into the output folder.
    Returns (records, exit status: 0 all pass, 1 some scene fails its thresholds). On a
    remote ``runner`` the scenes are compared in threads, every scene's units in flight
    together."""
    from codermind.variants import set_variant      # heavy: Mitsuba
    set_variant(variant)
    import codermind  # noqa: F401  (registers the plugins)
    t0 = time.perf_counter()
    cases = [prepare_any(s, opt) for s in scenes]  # bad input stops before any rendering
    jobs = list(zip(cases, labels(scenes)))
    if not runner.remote or len(jobs) < 2:
        records = [compare_scene(c, opt, label, runner) for c, label in jobs]
    else:
        with ThreadPoolExecutor(min(len(jobs), 8)) as pool:
            records = list(pool.map(lambda job: compare_scene(job[0], opt, job[1], runner),
                                    jobs))
    report.write_outputs(Path(opt.out_dir), opt, records, time.perf_counter() - t0)
    return records, 0 if all(r["passed"] for r in records) else 1
