"""The false-alarm rate of `codermind compare` on correct plugins, and compare at every sample
count from 16 to 1024.

Runs compare exactly as a user gets it (``compare_scene`` with the CLI's default thresholds,
exposure seeds and noise floor; the CLI's ``--spp``, ``--seed``, ``--rect``, ``--stride``) on
the unedited bundled scenes (``scenes/*.txt``, ``scenes/*.xml`` that have a tutorial twin) and
the tutorial's original ones (``$CODERMIND_TUTORIAL/*/scene*.txt``), on many small grids, and
prints each run's verdict, the sub-tests that failed and the overall rate with its
Clopper-Pearson 95 % interval.

* default (false alarms): first the scenes without randomness (pages 1-3: their verdict does
  not depend on the seed) on three grids each (every 4th pixel, every 3rd pixel from (1, 1),
  a 64 x 48 crop); then ``--runs`` page-4 runs (the only scenes with randomness), at compare's
  default ``spp`` (64), every 6th at 16 and every 6th at 256 (on a 12 x 9 crop), each with
  its own seed (seeds 10 apart: a run's exposure test uses seeds SEED..SEED+7 and its noise
  floor SEED+1, so no two runs share a random number) on a 24 x 18 crop at a random place, or
  (one in four) a 48 x 36 rectangle at stride 2. Runs whose grid holds >= 16 sub-samples of
  page 4's glass blob (lens-centre rays, ``sides.object_labels``) are counted apart: the known
  pooled-object failure on the blob.
* ``--spp-sweep``: every distinct scene at spp 16, 64, 256 and 1024, seed 0: page 4 (bundled
  and the tutorial's) on the blob crop of harness-power.md and on a crop of the marble sphere,
  pages 1-3 on one 32 x 24 crop.

    python benchmarks/false_alarm.py [--runs N] [--cluster ADDRESS] [--write-results [PATH]]
    python benchmarks/false_alarm.py --spp-sweep [--sweep-seeds N] [--write-results [PATH]]
    python benchmarks/false_alarm.py --merge PART.json ... [--write-results [PATH]]

Writes a Markdown table (``--out``) and every run's record as JSON beside it (``.json``),
rewritten after each run, so that an interrupted benchmark keeps what it measured (parts of
one benchmark, ``--first K --limit N``, are joined by ``--merge``). ``--write-results`` writes
the summary and the table to docs/results/false-alarm.md (section ``runs``, or ``sweep`` with
``--spp-sweep``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = Path(os.environ.get("CODERMIND_TUTORIAL", ROOT.parent / "shared" / "tutorial"))
PAGE = "false-alarm.md"

W, H = 640, 480                 #: every tutorial scene's image size
CROP = (24, 18)                 #: crop size in pixels
STRIP = 10                      #: rows y < 10: the calibration strip (pages 2 and 4)


def scenes() -> tuple[list[Path], list[Path]]:
    """(random scenes, scenes without randomness), bundled then original."""
    bundled = sorted((ROOT / "scenes").glob("page*.txt")) + sorted((ROOT / "scenes").glob("page*.xml"))
    original = sorted(TUTORIAL.glob("*/scene*.txt"))
    rnd, det = [], []
    for p in bundled + original:
        (rnd if "page4" in str(p) else det).append(p)
    return rnd, det


def rel(p: Path) -> str:
    for base, name in ((ROOT, ""), (TUTORIAL, "tutorial/")):
        try:
            return name + str(p.relative_to(base))
        except ValueError:
            pass
    return str(p)


def false_alarm_runs(n_random: int) -> list[dict]:
    """The run list: the scenes without randomness on three grids each (a strided full frame,
    a strided frame offset by one pixel, a 64 x 48 crop), then ``n_random`` page-4 runs
    (scenes in turn; three in four a 24 x 18 crop, one in four a 48 x 36 rectangle at stride 2;
    spp 64, but every 6th run 16 and every 6th 256 on a 12 x 9 crop)."""
    import numpy as np
    rng = np.random.default_rng(16)
    rnd, det = scenes()
    out = []
    for scene in det:
        x0 = int(rng.integers(0, W - 64 + 1))
        y0 = int(rng.integers(STRIP, H - 48 + 1))
        for rect, stride in ((None, 4), ((1, 1, W, H), 3), ((x0, y0, x0 + 64, y0 + 48), 1)):
            out.append(dict(scene=scene, seed=0, rect=rect, stride=stride, spp=None))
    for k in range(n_random):
        scene = rnd[k % len(rnd)]
        spp = {1: 16, 4: 256}.get(k % 6)
        cw, ch, stride = ((12, 9, 1) if spp == 256 else (48, 36, 2) if k % 4 == 3
                          else (CROP[0], CROP[1], 1))
        x0 = int(rng.integers(0, W - cw + 1))
        y0 = int(rng.integers(STRIP, H - ch + 1))
        out.append(dict(scene=scene, seed=10 * k, rect=(x0, y0, x0 + cw, y0 + ch),
                        stride=stride, spp=spp))
    return out


#: --spp-sweep grids: page 4's glass blob (the crop of benchmarks/harness_power.py) and
#: the marble sphere with the floor; the scenes without randomness on one 32 x 24 crop.
SWEEP_RANDOM = ((300, 250, 332, 274), (400, 140, 432, 164))
SWEEP_DET = (200, 200, 232, 224)


def sweep_runs(spps=(16, 64, 256, 1024), seeds: int = 1) -> list[dict]:
    """Every distinct scene at every spp (the cheap spp first), seed 0 (with ``seeds`` > 1 the
    random scenes also with seeds 10, 20, ...: one seed is one draw of the verdict). The twins
    are left out: ``scenes/pageN.xml`` is what ``scenes/pageN.txt`` converts to, and the
    tutorial's page-1 and page-2 files are the bundled ones (their runs give the same
    numbers)."""
    rnd, det = scenes()
    rnd = [s for s in rnd if s.suffix == ".txt"]
    det = [s for s in det if s.suffix == ".txt" and s.parent == ROOT / "scenes"]
    return [dict(scene=s, seed=seed, rect=rect, stride=1, spp=spp)
            for spp in spps
            for s, rect, n in [(s, r, seeds) for s in rnd for r in SWEEP_RANDOM]
            + [(s, SWEEP_DET, 1) for s in det]
            for seed in range(0, 10 * n, 10)]


def which(failures: list[str]) -> str:
    """The sub-tests that failed, in short (as benchmarks/harness_power.py)."""
    keys = (("z-test", "z-test"), ("pooled z over tiles", "tiles"),
            ("pooled z over objects", "objects"), ("mean FLIP", "FLIP"),
            ("auto exposure", "exposure"))
    return ", ".join(short for key, short in keys if any(f.startswith(key) for f in failures))


def blob_sub_samples(rec: dict, case) -> int:
    """Sub-samples of the grid whose lens-centre ray meets a blob first (0 off page 4).
    The labels come from Mitsuba's intersection, which sees a blob only as a mesh: the
    converted scene's analytic blob (``blob_tessellate`` false) is meshed for them."""
    if rec["page"] != 4:
        return 0
    from codermind_harness import sides
    xml = Path(rec["xml"])
    defines = dict(rec["defines"])
    if 'name="blob_tessellate"' in xml.read_text(encoding="utf-8"):
        defines["blob_tessellate"] = "true"
    lab, names = sides.object_labels(xml, case.grid, defines)
    blobs = [k for k, n in enumerate(names) if "blob" in n.lower()]
    return int(sum((lab == k).sum() for k in blobs))


_LABELS = threading.Lock()


def one(k: int, run: dict, work: Path, runner) -> dict:
    from codermind_harness.compare import Options, compare_scene, prepare
    opt = Options(spp=run["spp"], seed=run["seed"], rect=run["rect"], stride=run["stride"],
                  out_dir=work / f"run{k}", progress=False, workers=2)
    t0 = time.perf_counter()
    case = prepare(run["scene"], opt)
    rec = compare_scene(case, opt, f"run{k}", runner)
    with _LABELS:
        blob = blob_sub_samples(rec, case)
    pooled = rec.get("pooled") or {}
    return {"run": k, "scene": rel(Path(run["scene"])), "page": rec["page"],
            "seed": run["seed"], "rect": rec["rect"], "stride": rec["stride"],
            "pixels": rec["pixels"], "spp": rec["spp"], "random": rec["random"],
            "blob_sub_samples": blob, "passed": rec["passed"],
            "failed": which(rec["failures"]), "failures": rec["failures"],
            "pass_rate": rec["z_test"]["pass_rate"], "max_abs_z": rec["z_test"]["max_abs_z"],
            "max_abs_score": rec["z_test"].get("max_abs_score"),
            "z_gross": rec["z_test"].get("z_gross"),
            "pooled_max": {kk: v["max_abs_z"] for kk, v in pooled.items()},
            "pooled_crit": {kk: v["z_critical"] for kk, v in pooled.items()},
            "flip": rec["flip_mean"], "flip_limit": rec["flip_limit"],
            "flip_noise": rec["flip_noise"],
            "exposure_p": (rec["exposure_test"] or {}).get("p"),
            "seconds": time.perf_counter() - t0}


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    from scipy.stats import beta
    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k))
    return lo, hi


def rate(rows: list[dict]) -> str:
    n = len(rows)
    if n == 0:
        return "no runs"
    k = sum(not r["passed"] for r in rows)
    lo, hi = clopper_pearson(k, n)
    return f"{k} / {n} = {100 * k / n:.1f} % (95 % interval {100 * lo:.1f}-{100 * hi:.1f} %)"


def summary(rows: list[dict]) -> list[tuple[str, str]]:
    rnd = [r for r in rows if r["random"]]
    det = [r for r in rows if not r["random"]]
    blob = [r for r in rnd if r["blob_sub_samples"] >= 16]
    out = [("all runs", rate(rows)),
           ("all runs but those on page 4's blob", rate([r for r in rows if r not in blob])),
           ("page 4 (random), all", rate(rnd)),
           ("page 4, grids without the blob", rate([r for r in rnd if r not in blob])),
           ("page 4, grids with >= 16 blob sub-samples", rate(blob)),
           ("pages 1-3 (no randomness)", rate(det))]
    for spp in sorted({r["spp"] for r in rnd}):
        out.append((f"page 4 at {spp} spp", rate([r for r in rnd if r["spp"] == spp])))
    gross = [r for r in rnd if r.get("max_abs_score") is not None and r.get("z_gross")]
    if gross:
        worst = max(gross, key=lambda r: r["max_abs_score"] / r["z_gross"])
        out.append(("page 4: the gross bound (t-aware score beyond Sidak at 1e-6)",
                    f"{sum(r['max_abs_score'] > r['z_gross'] for r in gross)} / {len(gross)} "
                    f"runs beyond it; largest score / bound {worst['max_abs_score']:.3g} / "
                    f"{worst['z_gross']:.3g} (run {worst['run']})"))
    return out


def _g(x, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def line(r: dict) -> str:
    pooled = "/".join(_g(v, ".2g") for v in r["pooled_max"].values()) or "-"
    rect = "full" if r["rect"] == [0, 0, W, H] else ",".join(map(str, r["rect"]))
    return (f"{r['run']:3d} {r['scene']:28s} seed {r['seed']:4d} {rect:17s} /{r['stride']:<2d} "
            f"{r['spp']:4d} spp blob {r['blob_sub_samples']:5d} "
            f"{'pass' if r['passed'] else 'FAIL'} {r['failed'] or '-':16s} "
            f"z {r['pass_rate']:.5f} pooled {pooled:9s} FLIP {r['flip']:.4f}/{r['flip_limit']:.4f}"
            f" E p {'-' if r['exposure_p'] is None else format(r['exposure_p'], '.2g')}"
            f" ({r['seconds']:.0f} s)")


def markdown(rows: list[dict], argv: str, seconds: float) -> str:
    head = ["| run | scene | seed | rect | stride | pixels | spp | blob sub-samples | verdict "
            "| failed | z pass rate | max \\|z\\| | pooled max \\|Z\\| tiles / objects (crit) "
            "| FLIP / limit | exposure p |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- "
            "| --- |"]
    for r in rows:
        rect = "full" if r["rect"] == [0, 0, W, H] else ",".join(map(str, r["rect"]))
        pooled = (" / ".join(_g(v, ".3g") for v in r["pooled_max"].values())
                  + " (" + " / ".join(_g(v, ".3g") for v in r["pooled_crit"].values()) + ")"
                  if r["pooled_max"] else "-")
        head.append(
            f"| {r['run']} | `{r['scene']}` | {r['seed']} | {rect} | {r['stride']} | "
            f"{r['pixels']} | {r['spp']} | {r['blob_sub_samples']} | "
            f"{'pass' if r['passed'] else '**FAIL**'} | {r['failed'] or '-'} | "
            f"{r['pass_rate']:.5f} | {'-' if r['max_abs_z'] is None else format(r['max_abs_z'], '.3g')} | "
            f"{pooled} | {r['flip']:.4f} / {r['flip_limit']:.4f} | "
            f"{'-' if r['exposure_p'] is None else format(r['exposure_p'], '.2g')} |")
    lines = pivot(rows) or ["| runs | false alarms |", "| --- | --- |"] + [
        f"| {a} | {b} |" for a, b in summary(rows)]
    fails = [r for r in rows if not r["passed"]]
    if fails:
        lines += ["", "Failures:", ""]
        lines += [f"- run {r['run']} (`{r['scene']}`, seed {r['seed']}, {r['spp']} spp): "
                  + "; ".join(r["failures"]) for r in fails]
    return "\n".join(lines + [""] + head) + "\n"


def pivot(rows: list[dict]) -> list[str]:
    """One line per scene and grid, one column per spp (the sweep), or [] when no grid has
    more than one spp."""
    grids: dict = {}
    for r in rows:
        grids.setdefault((r["scene"], tuple(r["rect"]), r["stride"]), {}).setdefault(
            r["spp"], []).append(r)
    if all(len(v) < 2 for v in grids.values()):
        return []
    spps = sorted({r["spp"] for r in rows})
    out = ["| scene | rect | blob sub-samples | " + " | ".join(f"{s} spp" for s in spps) + " |",
           "| --- | --- | --- | " + " | ".join("---" for _ in spps) + " |"]
    for (scene, rect, stride), by in grids.items():
        cells = []
        for s in spps:
            runs = by.get(s)
            if runs is None:
                cells.append("not run")
                continue
            if len(runs) > 1:       # several seeds: how many fail, and which
                bad = [r for r in runs if not r["passed"]]
                cells.append(f"{len(bad)} / {len(runs)} seeds fail" + (
                    " (" + ", ".join(f"{r['seed']}: {r['failed']}" for r in bad) + ")"
                    if bad else ""))
                continue
            r = runs[0]
            pooled = "/".join(_g(v, ".2g") for v in r["pooled_max"].values())
            cells.append(("pass" if r["passed"] else f"**FAIL** ({r['failed']})")
                         + f", z {r['pass_rate']:.4f}" + (f", Z {pooled}" if pooled else "")
                         + f", FLIP {r['flip']:.4f}/{r['flip_limit']:.4f}")
        blob = max(r["blob_sub_samples"] for runs in by.values() for r in runs)
        out.append(f"| `{scene}` | {','.join(map(str, rect))}"
                   + ("" if stride == 1 else f" /{stride}") + f" | {blob} | " + " | ".join(cells)
                   + " |")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="/tmp/false-alarm.md",
                    help="the table and, beside it, every run's record (.json)")
    ap.add_argument("--runs", type=int, default=96, metavar="N",
                    help="page-4 (random) runs (default 96; the scenes without randomness add "
                         "three grids each)")
    ap.add_argument("--spp-sweep", action="store_true",
                    help="every scene at spp 16, 64, 256, 1024 on one strided full frame")
    ap.add_argument("--sweep-spp", type=int, nargs="*", default=[16, 64, 256, 1024])
    ap.add_argument("--sweep-seeds", type=int, default=1, metavar="N",
                    help="--spp-sweep: the random scenes with seeds 0, 10, ..., 10 (N - 1)")
    ap.add_argument("--first", type=int, default=0, metavar="K", help="skip the first K runs")
    ap.add_argument("--limit", type=int, metavar="N", help="only the first N runs (after --first)")
    ap.add_argument("--only", nargs="*", help="scene path substrings to run")
    ap.add_argument("--merge", nargs="+", metavar="JSON",
                    help="render no run: the rows of these JSON files (earlier runs, parts of "
                         "one benchmark) written as one table to --out")
    ap.add_argument("--cluster", metavar="ADDRESS",
                    help="tcp://HOST:PORT or local:N: each run's port tiles and Mitsuba renders "
                         "run as Dask tasks (docs/cluster.md), up to 8 runs in flight together")
    ap.add_argument("--write-results", nargs="?", const=str(ROOT / "docs" / "results" / PAGE),
                    metavar="PATH", help=f"write docs/results/{PAGE} (or PATH, a copy)")
    args = ap.parse_args(argv)
    if args.merge:
        rows = {r["run"]: r for f in args.merge for r in json.loads(Path(f).read_text())}
        rows = [rows[k] for k in sorted(rows)]
        out = Path(args.out)
        out.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")
        out.write_text(markdown(rows, " ".join(sys.argv[1:]), sum(r["seconds"] for r in rows)))
        for a, b in summary(rows):
            print(f"{a}: {b}")
        results(args, rows, sum(r["seconds"] for r in rows))
        return 0
    from codermind_harness.cluster import open_runner
    with open_runner(args.cluster, progress=False) as runner:
        return run(args, runner)


def run(args: argparse.Namespace, runner) -> int:
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401
    todo = (sweep_runs(tuple(args.sweep_spp), args.sweep_seeds) if args.spp_sweep
            else false_alarm_runs(args.runs))
    todo = list(enumerate(todo))[args.first:]
    if args.only:
        todo = [(k, r) for k, r in todo if any(o in str(r["scene"]) for o in args.only)]
    if args.limit is not None:
        todo = todo[:args.limit]
    work = Path(tempfile.mkdtemp(prefix="false_alarm_"))
    out = Path(args.out)
    rows: list[dict] = []
    t0 = time.perf_counter()
    argv = " ".join(sys.argv[1:])
    lock = threading.Lock()

    def done(row: dict) -> None:
        with lock:
            rows.append(row)
            rows.sort(key=lambda r: r["run"])
            print(line(row), flush=True)
            out.with_suffix(".json").write_text(json.dumps(rows, indent=2) + "\n")
            out.write_text(markdown(rows, argv, time.perf_counter() - t0))

    if not runner.remote:
        for k, r in todo:
            done(one(k, r, work, runner))
    else:
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(min(len(todo), 8) or 1) as pool:
            for f in [pool.submit(one, k, r, work, runner) for k, r in todo]:
                done(f.result())
    for a, b in summary(rows):
        print(f"{a}: {b}")
    results(args, rows, time.perf_counter() - t0)
    return 0


def results(args: argparse.Namespace, rows: list[dict], seconds: float) -> None:
    """The section of docs/results/false-alarm.md (``--write-results``)."""
    if not args.write_results:
        return
    import _results            # benchmarks/_results.py, beside this script
    _results.write(args.write_results, markdown(rows, "", seconds),
                   section="sweep" if args.spp_sweep else "runs", seconds=seconds)


if __name__ == "__main__":
    sys.exit(main())
