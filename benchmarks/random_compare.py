"""`codermind compare` on random tutorial scenes (codermind_harness.randscene): its false
alarms on correct plugins, the distribution of its statistics, its time, and (``--power``)
the errors it catches on scenes nobody calibrated it to.

Each scene is drawn from its seed (``--seed``, ``--seed + 1``, ...; 160 x 120 by default,
``--size``), written with the bundled cube-map faces, and compared exactly as the command line
compares it: ``compare_scene`` with the CLI's default thresholds, exposure seeds and seed 0,
and ``--spp`` (default 16, what the issue that asked for this ran).

* default: the false-alarm rate with its Clopper-Pearson 95 % interval, which sub-tests
  fail, the largest |z| of each scene against its Sidak bound (a scene's family-wise level is
  0.01, so max |z| beyond the bound should happen in about 1 % of the scenes, and far beyond
  it not at all), the sd of the signed z (1 when both sides agree and their variances are
  right), by scene feature (glass, mirror, blob, cube map, depth of field, bump), and the
  wall time of a comparison and of its renders;
* ``--power``: one error injected into the Mitsuba side of each scene (its scene text edited,
  then converted; the port renders the scene as drawn): a material colour, a light's
  intensity, a glass's refractive index, a bump level, the camera's field of view, each at
  ``--sizes`` per cent, on the scenes that have what it edits; the catch rate per error and
  size, counted on the scenes whose control (the same scene unedited, compared first) passes
  (``--pages``: the same edits on the bundled pages 1, 2 and 4 at ``--page-stride``).

    python benchmarks/random_compare.py --scenes 200 [--write-results [PATH]]
    python benchmarks/random_compare.py --power --scenes 40 [--pages] [--write-results [PATH]]

Every run's record is written as JSON beside ``--out`` as it goes; ``--write-results``
writes docs/results/random-compare.md (section ``runs``, or ``power``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import _results

ROOT = _results.ROOT
PAGE = "random-compare.md"
FEATURES = (("glass", lambda r: "glass" in r["kinds"]),
            ("mirror", lambda r: "mirror" in r["kinds"]),
            ("metal or plastic", lambda r: bool({"metal", "plastic"} & set(r["kinds"]))),
            ("blob", lambda r: r["blob"]), ("cube map", lambda r: r["cubemap"]),
            ("no cube map", lambda r: not r["cubemap"]),
            ("depth of field", lambda r: r["dof"]), ("bump", lambda r: r["bumped"] > 0),
            ("no randomness", lambda r: not r["random"]))


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    from scipy.stats import beta
    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k))
    return lo, hi


def rate(k: int, n: int) -> str:
    if n == 0:
        return "-"
    lo, hi = clopper_pearson(k, n)
    return f"{k} / {n} = {100 * k / n:.1f} % ({100 * lo:.1f}-{100 * hi:.1f} %)"


def which(failures: list[str]) -> str:
    """The sub-tests that failed, in short (as benchmarks/false_alarm.py)."""
    keys = (("z-test", "z-test"), ("pooled z over tiles", "tiles"),
            ("pooled z over objects", "objects"), ("mean FLIP", "FLIP"),
            ("auto exposure", "exposure"))
    return ", ".join(short for key, short in keys if any(f.startswith(key) for f in failures))


# -- one comparison --------------------------------------------------------------------------

def compare_one(txt: Path, out: Path, spp: int, xml_text_of: Path | None = None,
                rect=None, stride: int = 1) -> dict:
    """``codermind compare txt --spp spp`` (the CLI's defaults otherwise) as a record; with
    ``xml_text_of`` the Mitsuba side renders that (edited) scene instead, converted."""
    from codermind_harness import sides
    from codermind_harness.compare import Options, compare_scene, prepare
    opt = Options(spp=spp if spp else None, out_dir=out, progress=False, rect=rect,
                  stride=stride)
    t0 = time.perf_counter()
    case = prepare(txt, opt)
    if xml_text_of is not None:
        edited = sides.parse(xml_text_of)
        xml = sides.convert_xml(xml_text_of, edited, out, name=f"{txt.stem}.edited.xml")
        case = replace(case, xml=xml)
    rec = compare_scene(case, opt, txt.stem)
    z = rec["z_test"]
    pooled = rec.get("pooled") or {}
    return {"passed": rec["passed"], "failed": which(rec["failures"]),
            "failures": rec["failures"], "random": rec["random"], "spp": rec["spp"],
            "sub_samples": rec["sub_samples"], "tests": z["tests"],
            "pass_rate": z["pass_rate"], "failing_sub_samples": z["failing_sub_samples"],
            "max_abs_z": z["max_abs_z"], "z_critical": z["z_critical"], "z_sd": z["z_sd"],
            "z_mean": z["z_mean"],
            "pooled_max": {k: v["max_abs_z"] for k, v in pooled.items()},
            "pooled_crit": {k: v["z_critical"] for k, v in pooled.items()},
            "flip": rec["flip_mean"], "flip_limit": rec["flip_limit"],
            "exposure_p": (rec["exposure_test"] or {}).get("p"),
            "render_seconds": {k: rec["seconds"][k] for k in ("port", "mitsuba",
                                                              "mitsuba_load", "port_probes",
                                                              "mitsuba_probes")},
            "seconds": time.perf_counter() - t0}


# -- false alarms ----------------------------------------------------------------------------

def run_scenes(args, work: Path, out: Path) -> list[dict]:
    from codermind_harness import randscene
    rows = []
    for k in range(args.scenes):
        seed = args.seed + k
        txt, drawn = randscene.write_scene(work / "scenes", seed, width=args.size[0],
                                           height=args.size[1], cubemap=args.cubemap)
        try:
            rec = compare_one(txt, work / f"out{seed}", args.spp)
        except Exception as e:      # noqa: BLE001  (a crash is a result: reported, counted)
            rec = {"passed": False, "failed": "error", "failures": [f"{type(e).__name__}: {e}"],
                   "error": True, "seconds": 0.0}
        rec.update(seed=seed, kinds=drawn.kinds, blob=drawn.blob, cubemap=drawn.cubemap,
                   dof=drawn.dof, bumped=drawn.bumped, tags=drawn.tags)
        rec.setdefault("random", True)
        rows.append(rec)
        print(line(rec), flush=True)
        out.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")
    return rows


def line(r: dict) -> str:
    if r.get("error"):
        return f"seed {r['seed']:5d} ERROR {r['failures'][0]}"
    return (f"seed {r['seed']:5d} {'pass' if r['passed'] else 'FAIL'} {r['failed'] or '-':14s} "
            f"z {r['pass_rate']:.4f} ({r['failing_sub_samples']} fail) max|z| "
            f"{_g(r['max_abs_z'], '.3g')} / {r['z_critical']:.3g} sd {_g(r['z_sd'], '.3f')} "
            f"FLIP {r['flip']:.4f}/{r['flip_limit']:.4f} ({r['seconds']:.0f} s) [{r['tags']}]")


def _g(x, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def _q(values: list[float], qs=(0.5, 0.9, 0.99, 1.0)) -> str:
    if not values:
        return "-"
    import numpy as np
    return " / ".join(f"{float(np.quantile(values, q)):.3g}" for q in qs)


def summary(rows: list[dict]) -> str:
    ok = [r for r in rows if not r.get("error")]
    n, fails = len(rows), sum(not r["passed"] for r in rows)
    noisy = [r for r in ok if r["max_abs_z"] is not None]
    ratio = [r["max_abs_z"] / r["z_critical"] for r in noisy]
    lines = [f"{n} scenes, {sum(bool(r.get('error')) for r in rows)} errors.", "",
             "| measure | value |", "| --- | --- |",
             f"| false alarms (any sub-test), 95 % interval | {rate(fails, n)} |"]
    for key in ("z-test", "tiles", "objects", "FLIP", "exposure"):
        k = sum(key in r["failed"].split(", ") for r in rows)
        lines.append(f"| ... of which {key} | {k} |")
    beyond = sum(x > 1 for x in ratio)
    lines += [
        f"| scenes with max \\|z\\| beyond the Sidak bound (expected about 1 %) | "
        f"{rate(beyond, len(noisy))} |",
        f"| ... beyond 2x the bound | {sum(x > 2 for x in ratio)} |",
        f"| ... with max \\|z\\| > 20 | {sum(r['max_abs_z'] > 20 for r in noisy)} |",
        f"| ... that still pass (the 0.99 pass-rate allowance) | "
        f"{sum(x > 1 and r['passed'] for x, r in zip(ratio, noisy))} |",
        f"| max \\|z\\|: median / 90 % / 99 % / max | {_q([r['max_abs_z'] for r in noisy])} |",
        f"| Sidak bound: median | {_q([r['z_critical'] for r in noisy], (0.5,))} |",
        f"| z sd: median / 90 % / 99 % / max | {_q([r['z_sd'] for r in noisy if r['z_sd']])} |",
        f"| failing sub-samples per scene: median / 90 % / 99 % / max | "
        f"{_q([r['failing_sub_samples'] for r in ok])} |",
        f"| wall time per comparison, median (s) | {_q([r['seconds'] for r in ok], (0.5,))} |",
        f"| ... Mitsuba render (with load), median (s) | "
        f"{_q([r['render_seconds']['mitsuba'] for r in ok], (0.5,))} |",
        f"| ... port render, median (s) | {_q([r['render_seconds']['port'] for r in ok], (0.5,))} |",
        f"| ... auto-exposure probes, Mitsuba / port, median (s) | "
        f"{_q([r['render_seconds']['mitsuba_probes'] for r in ok], (0.5,))} / "
        f"{_q([r['render_seconds']['port_probes'] for r in ok], (0.5,))} |",
        "", "By feature (a scene counts under each feature it has):", "",
        "| feature | scenes | false alarms | median max \\|z\\| | median z sd |",
        "| --- | --- | --- | --- | --- |"]
    for name, has in FEATURES:
        sel = [r for r in ok if has(r)]
        lines.append(f"| {name} | {len(sel)} | {rate(sum(not r['passed'] for r in sel), len(sel))}"
                     f" | {_q([r['max_abs_z'] for r in sel if r['max_abs_z'] is not None], (0.5,))}"
                     f" | {_q([r['z_sd'] for r in sel if r['z_sd']], (0.5,))} |")
    bad = [r for r in rows if not r["passed"] or (r.get("max_abs_z") or 0) > r.get("z_critical", 1e9)]
    if bad:
        lines += ["", "Scenes that fail, or whose max |z| is beyond the bound:", ""]
        lines += [f"- seed {r['seed']} ({r.get('tags', '')}): "
                  + ("pass" if r["passed"] else "FAIL: " + "; ".join(r["failures"]))
                  + ("" if r.get("error") else
                     f"; max |z| {_g(r['max_abs_z'], '.3g')} (bound {r['z_critical']:.3g}), "
                     f"{r['failing_sub_samples']} failing sub-samples, z sd {_g(r['z_sd'], '.3g')}")
                  for r in bad]
    return "\n".join(lines) + "\n"


# -- power -----------------------------------------------------------------------------------

def run_power(args, work: Path, out: Path) -> list[dict]:
    from codermind_harness import randscene
    rows = []

    def record(label: str, seed, txt: Path, error: str, size: float, edited: str | None,
               **grid):
        edited_txt = None
        if edited is not None:
            edited_txt = txt.with_name(f"{txt.stem}.{error}{size:g}.txt")
            edited_txt.write_text(edited, encoding="utf-8")
        try:
            rec = compare_one(txt, work / f"out-{label}-{error}{size:g}", args.spp, edited_txt,
                              **grid)
        except Exception as e:      # noqa: BLE001
            rec = {"passed": True, "failed": "error", "failures": [f"{type(e).__name__}: {e}"],
                   "error": True, "seconds": 0.0}
        rec.update(scene=label, seed=seed, error=error, size=size, caught=not rec["passed"])
        rows.append(rec)
        print(f"{label:14s} {error:8s} +{size:g} % {'FAILS' if rec['caught'] else 'passes'} "
              f"{rec['failed'] or '-'} ({rec['seconds']:.0f} s)", flush=True)
        out.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")

    for k in range(args.scenes):
        seed = args.seed + k
        txt, _ = randscene.write_scene(work / "scenes", seed, width=args.size[0],
                                       height=args.size[1], cubemap=args.cubemap)
        text = txt.read_text(encoding="utf-8")
        errors = randscene.ERRORS
        if not args.every_error:    # one error a scene: the next in turn that applies
            turn = errors[k % len(errors):] + errors[:k % len(errors)]
            errors = [e for e in turn if randscene.inject(text, e, 0.1) is not None][:1]
        record(f"seed {seed}", seed, txt, "none", 0.0, None)     # the control
        for e in errors:
            for size in args.sizes:
                edited = randscene.inject(text, e, size / 100)
                if edited is not None:
                    record(f"seed {seed}", seed, txt, e, size, edited)
    if args.pages:
        for name in ("page1", "page2", "page4"):
            txt = ROOT / "scenes" / f"{name}.txt"
            copy = work / "pages" / txt.name
            copy.parent.mkdir(parents=True, exist_ok=True)
            text = txt.read_text(encoding="utf-8").replace("= sky/", f"= {ROOT / 'scenes' / 'sky'}/")
            copy.write_text(text, encoding="utf-8")
            record(name, None, copy, "none", 0.0, None, stride=args.page_stride)
            for e in randscene.ERRORS:
                for size in args.sizes:
                    edited = randscene.inject(text, e, size / 100)
                    if edited is not None:
                        record(name, None, copy, e, size, edited, stride=args.page_stride)
    return rows


def power_summary(rows: list[dict]) -> str:
    """Catch rates per error and size, counted on the scenes whose control (the same scene
    unedited) passes: a catch on a scene that fails anyway says nothing."""
    control = {r["scene"]: r["passed"] for r in rows if r["error"] == "none"}
    n_control = len(control)
    lines = [f"Controls (each scene unedited): {rate(sum(not v for v in control.values()), n_control)}"
             " fail; the catch rates count only scenes whose control passes.", "",
             "| error | size | scenes (control passes) | caught | by |",
             "| --- | --- | --- | --- | --- |"]
    groups: dict = {}
    for r in rows:
        if r["error"] == "none" or not control.get(r["scene"], False):
            continue
        kind = "pages" if r["seed"] is None else "random"
        groups.setdefault((kind, r["error"], r["size"]), []).append(r)
    for (kind, error, size), sel in sorted(groups.items()):
        by: dict = {}
        for r in sel:
            for t in filter(None, r["failed"].split(", ")):
                by[t] = by.get(t, 0) + 1
        label = error if kind == "random" else f"{error} ({', '.join(r['scene'] for r in sel)})"
        lines.append(f"| {label} | +{size:g} % | {len(sel)} | "
                     f"{rate(sum(r['caught'] for r in sel), len(sel))} | "
                     + (", ".join(f"{t} {n}" for t, n in sorted(by.items())) or "-") + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", type=int, default=200, metavar="N",
                    help="random scenes (default 200)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the first scene (default 0)")
    ap.add_argument("--size", type=lambda s: tuple(int(v) for v in s.split("x")),
                    default=(160, 120), metavar="WxH", help="image size (default 160x120)")
    ap.add_argument("--spp", type=int, default=16, help="compare's --spp (default 16)")
    ap.add_argument("--cubemap", choices=("any", "always", "never"), default="any")
    ap.add_argument("--power", action="store_true",
                    help="inject errors into the Mitsuba side and count the catches")
    ap.add_argument("--sizes", type=float, nargs="+", default=[2.0, 10.0], metavar="PCT",
                    help="--power: error sizes in per cent (default 2 10)")
    ap.add_argument("--every-error", action="store_true",
                    help="--power: every error on every scene (default: one error a scene, "
                         "in turn)")
    ap.add_argument("--pages", action="store_true",
                    help="--power: also the bundled pages 1, 2 and 4")
    ap.add_argument("--page-stride", type=int, default=8,
                    help="--pages: compare every K-th pixel of the 640 x 480 pages (default 8)")
    ap.add_argument("--out", default="/tmp/random-compare.md",
                    help="the summary and, beside it, every run's record (.json)")
    _results.add_argument(ap, PAGE)
    args = ap.parse_args(argv)
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401  (registers the plugins)
    # the scene files and faces must lie beside each other: scenes in work/scenes
    work = Path(tempfile.mkdtemp(prefix="random_compare_"))
    out = Path(args.out)
    t0 = time.perf_counter()
    if args.power:
        rows = run_power(args, work, out)
        text = power_summary(rows)
    else:
        rows = run_scenes(args, work, out)
        text = summary(rows)
    out.write_text(text)
    print(text)
    if args.write_results:
        _results.write(args.write_results, text, section="power" if args.power else "runs",
                       title="Compare on random scenes", seconds=time.perf_counter() - t0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
