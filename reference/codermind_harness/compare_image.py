"""``codermind compare --reference IMAGE``: one scene's Mitsuba side against a render made
elsewhere instead of the port (the image read by :mod:`codermind_harness.refimage`)."""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path

import numpy as np

from . import metrics, report, sides, verdict
from .case import Case, Options, log, mitsuba_xml, strip_free_rows
from .report import MapPanel
from .runner import LOCAL, Runner
from .sides import HarnessError
from .verdict import Thresholds


def compare_reference(case: Case, opt: Options, label: str, out: Path,
                      runner: Runner = LOCAL) -> dict:
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
      (page 4) over ``exposure_seeds`` seeds of our side; FLIP and its floor reported.

    Our side's renders are units of ``runner``."""
    from codermind.tutorial.image import to_bytes     # heavy: importing codermind starts Mitsuba
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
                                progress=opt.progress, exposure_seeds=eseeds, runner=runner)
    again = None
    if random:
        log(f"{txt.name}: our side again with seed {opt.seed + 1} (noise floor)")
        again = sides.render_mitsuba(xml, grid, spp, opt.seed + 1, None, defines,
                                     variance=False, progress=opt.progress, runner=runner)
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
            zmap = MapPanel(ba.diff_map.astype(float), ba.diff_map <= 1, 1.0)
            failures += verdict.bytes_failures(ba, flip_mean, th)
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
            zmap = MapPanel(np.minimum(z.z_map, 2.0), z.passed_map, 1.0)
            failures += verdict.float_failures(z, th)
        else:
            tol = th.rtol * np.abs(theirs) + th.atol
            method, zmap = _statistical(record, failures, mits.linear, again.linear, theirs,
                                        tol, None, 0.0, th)
    heatmap = out / f"{label}.compare.png"
    report.write_heatmap(heatmap, enc[0], shown, rows, flip_map, zmap,
                         f"reference {ref.path.name}",
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


def _statistical(record: dict, failures: list, a, b, r, tol, slope, var_log_e,
                 th: Thresholds, mean_tol: float | None = None) -> tuple[str, MapPanel]:
    """The blurred and the mean difference against the noise floor, into ``record`` and
    ``failures``."""
    bt = metrics.blur_test(a, b, r, tol, slope, var_log_e, th.alpha)
    mean_tol = float(np.mean(tol)) if mean_tol is None else mean_tol
    mt = metrics.mean_test(a, b, r, mean_tol, slope, var_log_e, th.alpha)
    record["blur_test"] = {k: v for k, v in asdict(bt).items()
                           if k not in ("z_map", "passed_map")}
    record["mean_test"] = asdict(mt)
    failures.extend(verdict.statistical_failures(bt, mt))
    return "statistical", MapPanel(bt.z_map, bt.passed_map, bt.z_critical)
