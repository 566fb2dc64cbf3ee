"""``codermind compare`` on the bundled scenes at its defaults: Mitsuba with the plugins
against the port, per sub-sample.

    python benchmarks/compare_scenes.py [--page4-stride K] [--page4-spp N] [--only TEXT ...]
                                        [--write-results [PATH]]

Runs ``compare_scene`` exactly as the command line does (its default thresholds, exposure
seeds, pooled tests), seed 0: pages 1-3 (``scenes/pageN.txt``, no randomness) on the whole
frame; ``scenes/page4.xml`` and, where present, the tutorial's ``page4/scene.txt`` on every
K-th pixel (default 4) with the noise floor (the port against itself with seed 1). One row
per scene; ``--write-results`` writes the table to docs/results/compare.md (section
``scenes``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import _results

ROOT = _results.ROOT


def which(failures: list[str]) -> str:
    keys = (("z-test", "z-test"), ("pooled z over tiles", "tiles"),
            ("pooled z over objects", "objects"), ("mean FLIP", "FLIP"),
            ("auto exposure", "exposure"))
    return ", ".join(short for key, short in keys if any(f.startswith(key) for f in failures))


def _g(x, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def row(name: str, rec: dict) -> list:
    z = rec["z_test"]
    pooled = rec.get("pooled") or {}
    pooled_text = (" / ".join(f"{v['max_abs_z']:.3g}" for v in pooled.values()) + " ("
                   + " / ".join(f"{v['z_critical']:.3g}" for v in pooled.values()) + ")"
                   if pooled else "-")
    e = rec.get("exposure_test")
    exposure = "-" if not e or e.get("p") is None else f"p = {e['p']:.2g}"
    flip = f"{rec['flip_mean']:.5f} / {_g(rec['flip_limit'], '.5f')}"
    if rec.get("flip_noise") is not None:
        flip += f" (noise alone {rec['flip_noise']:.5f})"
    verdict = "pass" if rec["passed"] else f"**FAIL** ({which(rec['failures'])})"
    where = "full frame" if rec["stride"] == 1 and rec["rect"] == [0, 0, rec["width"],
                                                                    rec["height"]] \
        else f"every {rec['stride']}th pixel"
    return [name, where, f"{rec['sub_samples']:,}", rec["spp"],
            f"{z['pass_rate']:.5f} ({z['failing_sub_samples']})", _g(z["max_abs_z"], ".3g"),
            pooled_text, flip, f"{rec['rel_mse']:.3g}"
            + ("" if rec.get("rel_mse_noise") is None else f" ({rec['rel_mse_noise']:.3g})"),
            exposure, verdict]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--page4-stride", type=int, default=4)
    ap.add_argument("--page4-spp", type=int, default=None, help="default: compare's")
    ap.add_argument("--only", nargs="+", help="scene path substrings to run")
    _results.add_argument(ap, "compare.md")
    args = ap.parse_args(argv)
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401  (registers the plugins)
    from codermind_harness.compare import Options, compare_scene, prepare
    runs = [(f"`scenes/page{n}.txt`", ROOT / "scenes" / f"page{n}.txt", 1, None, False)
            for n in (1, 2, 3)]
    runs.append(("`scenes/page4.xml`", ROOT / "scenes" / "page4.xml", args.page4_stride,
                 args.page4_spp, True))
    original = _results.TUTORIAL / "page4" / "scene.txt"
    if original.is_file():
        runs.append(("the tutorial's `page4/scene.txt`", original, args.page4_stride,
                     args.page4_spp, True))
    if args.only:
        runs = [r for r in runs if any(o in str(r[1]) for o in args.only)]
    rows = []
    t0 = time.time()
    with tempfile.TemporaryDirectory(prefix="compare_scenes_") as tmp:
        for k, (name, path, stride, spp, floor) in enumerate(runs):
            opt = Options(spp=spp, seed=0, stride=stride, noise_floor=floor,
                          out_dir=Path(tmp) / f"run{k}", progress=False, workers=2)
            rec = compare_scene(prepare(path, opt), opt, f"run{k}")
            rows.append(row(name, rec))
            print(" | ".join(map(str, rows[-1])), flush=True)
    table = _results.table(
        ["scene", "grid", "sub-samples", "spp", "z-test pass rate (failing)", "max |z|",
         "pooled max Z, tiles / objects (critical)", "mean FLIP / limit",
         "rel MSE (noise alone)", "exposure test", "verdict"], rows)
    if args.write_results:
        _results.write(args.write_results, table.replace("max |z|", "max \\|z\\|"),
                       section="scenes", seconds=time.time() - t0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
