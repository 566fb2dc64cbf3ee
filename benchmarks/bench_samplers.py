"""Equal-error speed of the page-4 scene with ``tutorialpath`` and Mitsuba's samplers, on a crop.

    nice python benchmarks/bench_samplers.py [--rect 368,120,464,192] [--ref-spp 2048]
    nice python benchmarks/bench_samplers.py --pairs --rect 0,0,640,480 --spp 16,64 --port-c 2,4 \
        --samplers multijitter [--vector-width 8] [--write-results [PATH]]

Error as ``codermind chart`` measures it: relative MSE of the linear sub-sample means against
a converged reference (``codermind_harness.metrics.rel_mse``). The original program's error
at Complexity 256 (1024 samples per pixel) is stood in for by the strict port: its error
against the converged STRICT reference (``tutorialpath`` strict, ``--ref-spp``) at
Complexity 2, 4, 8, 16 (it needs 2 rays per sub-sample for its variance), fitted as a / C + floor (``chart.fit_noise_floor``) and evaluated at
C = 256. Each sampler's clean error (against the converged CLEAN reference, another seed)
over ``--spp`` then gives the CPU time to reach that error (log-log interpolation as
``chart.time_to_reach``; beyond the sweep error ~ 1 / time from the nearest point), and the
ratio to the original's time for the crop (145.7 s x crop share of the image: the original's
cost per pixel is taken as uniform). Both wall seconds (as ``codermind chart`` times a render,
and as issue 14 compares two cores against the original's one) and CPU seconds of this
process (all Dr.Jit threads, against the original's one core; less sensitive to a shared
machine) are printed, with the load. The sampler with the smallest wall time is the
winner (``codermind convert`` writes it: codermind.tutorial.xml.RANDOM_SAMPLER).
Counts are the samplers' own (codermind.passes.sampler_plan: passes of counts each
sampler keeps, so a pass renders what it counts).

``--pairs`` measures the same without converged references (so that the whole image fits in
a run): an estimator's error against its own converged mean is its variance, estimated for
the port from its per-sub-sample variance of the mean (its rays are independent) and for each
sampler from two renders with different seeds, mean((X1 - X2)^2 / 2 / (N^2 + eps)), which
holds for stratified samplers too (two independent randomisations). N, the normaliser, is one
clean render at the largest ``--spp`` (its noise moves the denominator by a fraction of a
percent). The port's error is fitted as a / C (a variance has no floor) and evaluated at
C = 256; the original's error against the converged tutorial image is the same quantity.

A timing: run it on a quiet machine. ``--write-results`` writes the table to
docs/results/integrator.md (section ``equal-error``, or ``equal-error-w8`` with
``--vector-width 8``).
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from typing import NamedTuple
from pathlib import Path

import numpy as np

import _results

ROOT = _results.ROOT
SCENE = _results.TUTORIAL / "page4" / "derived_scene_complexity256.txt"
ORIGINAL_SECONDS = 145.7            # Complexity 256, 640x480, one core (issue 14)
SAMPLERS = ("independent", "stratified", "multijitter", "ldsampler", "orthogonal")


class Cost(NamedTuple):
    cpu: float      #: CPU seconds of this process (all Dr.Jit threads)
    wall: float     #: wall seconds


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def reach(times, errs, target: float) -> float:
    """CPU time at which error = target: log-log interpolation between the bracketing points;
    outside the sweep, error ~ 1 / time from the nearest point (noise-limited)."""
    pts = sorted(zip(times, errs))
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e1 <= target <= e0 and e0 > e1 > 0:
            f = (np.log(e0) - np.log(target)) / (np.log(e0) - np.log(e1))
            return float(np.exp(np.log(t0) + f * (np.log(t1) - np.log(t0))))
    t, e = min(pts, key=lambda q: abs(np.log(q[1] / target)))
    return t * e / target


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", type=Path, default=SCENE)
    p.add_argument("--rect", default="368,120,464,192")
    p.add_argument("--ref-spp", type=int, default=2048)
    p.add_argument("--spp", default="4,16,64,256")  # squares, powers of 2
    p.add_argument("--port-c", default="2,4,8,16")
    p.add_argument("--samplers", default=",".join(SAMPLERS))
    p.add_argument("--pass-spp", type=int, default=None,
                   help="passes of at most this many spp (default: codermind's plan; a "
                        "stratifying sampler's pass is one stratified set)")
    p.add_argument("--vector-width", type=int, choices=(0, 8), default=0,
                   help="Dr.Jit's LLVM vector width: 0 the host's, 8 without AVX-512 "
                        "(bench_page4_c256.llvm_width)")
    p.add_argument("--pairs", action="store_true",
                   help="variance from seed pairs instead of converged references")
    _results.add_argument(p, "integrator.md")
    args = p.parse_args(argv)
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    from bench_page4_c256 import llvm_width
    width = llvm_width(dr, args.vector_width)
    import codermind  # noqa: F401
    from codermind.tutorial.render import render_linear
    from codermind_harness import sides
    from codermind_harness.chart_data import fit_noise_floor
    from codermind_harness.metrics import rel_mse

    rect = tuple(int(v) for v in args.rect.split(","))
    scene_txt = sides.parse(args.scene)
    grid = sides.Grid.of(scene_txt.width, scene_txt.height, scene_txt.page, rect)
    folder = Path(tempfile.mkdtemp(prefix="bench_samplers_"))
    xml = sides.convert_xml(args.scene, scene_txt, folder, name="page4.xml")
    text = xml.read_text()
    exposure = sides.port_exposure(scene_txt, 0, "strict")
    print(f"{args.scene.name}, tutorial rect {rect} ({grid.pixels} pixels), LLVM vector width "
          f"{width}, "
          f"load average {'%.2f %.2f %.2f' % os.getloadavg()}")

    def scene_with(sampler: str, quirks: str = "clean"):
        t = sides.sampler_xml(text, sampler)
        path = folder / f"{sampler}_{quirks}.xml"
        path.write_text(t)
        scene, _ = sides.load_mitsuba(path, grid, {"quirks": quirks, "spp": "1"})
        return scene

    def render(scene, spp: int, seed: int, warm: bool = True):
        # untimed, at the same count: a sampler whose kernel depends on the sample count
        # (stratified and the others bake it in) compiles here, not in the timed render
        # (the references are not timed: no warm-up)
        if warm:
            render_linear(scene, spp, 777, pass_spp=args.pass_spp)
        dr.sync_thread()
        c0, w0 = cpu(), time.perf_counter()
        mean, _, _, _ = render_linear(scene, spp, seed, pass_spp=args.pass_spp)
        dr.sync_thread()
        return grid.take(mean.astype(np.float64)), Cost(cpu() - c0, time.perf_counter() - w0)

    if args.pairs:
        return pairs(args, scene_txt, grid, exposure, scene_with, render)
    refs = {}
    for quirks in ("clean", "strict"):
        refs[quirks], c = render(scene_with("independent", quirks), args.ref_spp, 4242,
                                    warm=False)
        print(f"reference {quirks}: {args.ref_spp} spp, {c.cpu:.1f} CPU s")

    port_c = [int(v) for v in args.port_c.split(",")]
    port_err = []
    for c in port_c:
        side = sides.render_port(scene_txt, grid, c, 1, exposure, "strict", True, 2, False)
        port_err.append(rel_mse(side.linear, refs["strict"]))
        print(f"  port strict C={c}: relMSE {port_err[-1]:.4g}")
    a, b = fit_noise_floor(port_c, port_err)
    target = a / 256 + b
    share = grid.pixels / (scene_txt.width * scene_txt.height)
    original = ORIGINAL_SECONDS * share
    print(f"port fit: relMSE = {a:.4g} / C + {b:.3g}; at C = 256 (the original's 1024 spp): "
          f"{target:.4g}; the original's time for this crop: {original:.3f} s")

    def error(scene, spp: int):
        lin, c = render(scene, spp, 7)
        return rel_mse(lin, refs["clean"]), c

    return sweep(args, scene_with, error, target, original)


def counts(sampler: str, spp: int) -> int:
    """``spp``, or where the sampler does not take it as is the nearest count it does
    (``codermind.tutorial.xml.sampler_fits``; orthogonal: a prime's square, ldsampler: a
    power of 4), in log scale."""
    from codermind.tutorial.xml import sampler_fits
    if sampler_fits(sampler, spp):
        return spp
    keep = [n for n in range(1, 4 * spp + 1) if sampler_fits(sampler, n)]
    return min(keep, key=lambda n: abs(np.log(n / spp)))


def sweep(args, scene_with, error, target: float, original: float) -> int:
    """Each sampler's (error, cost) = ``error(scene, n)`` over ``--spp`` (each count as
    :func:`counts` makes it), the time at which it reaches ``target`` in wall seconds (as
    ``codermind chart`` times it, the issue's measure: two cores against the original's one)
    and in CPU seconds (against its one core), and the winner by wall time."""
    spps = [int(v) for v in args.spp.split(",")]
    best = None
    rows = []
    print(f"{'sampler':12s} " + " ".join(f"{'spp ~' + str(s):>27s}" for s in spps)
          + f" {'wall s to target':>17s} {'vs original':>11s} {'CPU s to target':>16s}"
          f" {'vs original':>11s}")
    for sampler in args.samplers.split(","):
        scene = scene_with(sampler)
        ns = [counts(sampler, s) for s in spps]
        errs, costs = zip(*(error(scene, n) for n in ns))
        wall = reach([c.wall for c in costs], errs, target)
        cpu_s = reach([c.cpu for c in costs], errs, target)
        cells = " ".join(f"{n:4d}: {e:8.3g} {c.wall:5.2f}/{c.cpu:5.2f}s"
                         for n, e, c in zip(ns, errs, costs))
        print(f"{sampler:12s} {cells} {wall:17.3f} {original / wall:10.1f}x {cpu_s:16.3f} "
              f"{original / cpu_s:10.1f}x", flush=True)
        rows.append([sampler] + [f"{n}: {e:.3g} in {c.wall:.2f} s" for n, e, c
                                 in zip(ns, errs, costs)]
                    + [f"{wall:.2f}", f"{original / wall:.1f}x", f"{cpu_s:.2f}",
                       f"{original / cpu_s:.1f}x"])
        if best is None or wall < best[1]:
            best = (sampler, wall, cpu_s)
    print(f"winner: {best[0]} ({original / best[1]:.1f}x the original at equal error in wall "
          f"seconds, {original / best[2]:.1f}x in CPU seconds against its one core); "
          f"load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    if args.write_results:
        body = (f"Region {args.rect} of the tutorial's page 4 "
                f"({'variance from seed pairs' if args.pairs else 'against converged references'}); "
                f"the original's error: the strict port fitted at Complexity {args.port_c} and "
                f"taken at 256 ({target:.4g}); the original's time for the region: "
                f"{original:.2f} s (its {ORIGINAL_SECONDS} s x the region's share of the image).\n\n"
                + _results.table(["sampler"] + [f"spp ~{s}: rel MSE in wall s" for s in spps]
                                 + ["wall s to the original's error", "speed-up (wall)",
                                    "CPU s to it", "speed-up (CPU)"], rows))
        _results.write(args.write_results, body, section="equal-error" if args.vector_width == 0
                       else f"equal-error-w{args.vector_width}")
    return 0


def pairs(args, scene_txt, grid, exposure, scene_with, render) -> int:
    from codermind_harness import sides
    from codermind_harness.metrics import REL_MSE_EPS
    spps = [int(v) for v in args.spp.split(",")]
    norm, c = render(scene_with("independent"), max(spps), 4242, warm=False)
    denominator = np.square(norm) + REL_MSE_EPS
    print(f"normaliser: clean, {max(spps)} spp, {c.cpu:.1f} CPU s")
    port_c = [int(v) for v in args.port_c.split(",")]
    port_err = []
    for c in port_c:
        side = sides.render_port(scene_txt, grid, c, 1, exposure, "strict", True, 2, False)
        port_err.append(float(np.mean(side.variance / denominator)))
        print(f"  port strict C={c}: variance relMSE {port_err[-1]:.4g} "
              f"(x C = {port_err[-1] * c:.4g})")
    a = float(np.exp(np.mean(np.log(np.array(port_err) * port_c))))   # a / C, geometric mean
    target = a / 256
    share = grid.pixels / (scene_txt.width * scene_txt.height)
    original = ORIGINAL_SECONDS * share
    print(f"port fit: variance relMSE = {a:.4g} / C; at C = 256 (the original's 1024 spp): "
          f"{target:.4g}; the original's time for this region: {original:.2f} s")

    def error(scene, spp: int):
        (x1, c1), (x2, c2) = render(scene, spp, 7), render(scene, spp, 8, warm=False)
        return (float(np.mean(np.square(x1 - x2) / 2 / denominator)),
                Cost((c1.cpu + c2.cpu) / 2, (c1.wall + c2.wall) / 2))

    return sweep(args, scene_with, error, target, original)


if __name__ == "__main__":
    sys.exit(main())
