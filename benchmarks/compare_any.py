"""The power and false alarms of `codermind compare` on an ordinary Mitsuba scene at its
defaults: ``scenes/user/room.xml`` (the project's plugins; lit mostly by its ceiling panel)
with the panel's radiance scaled by 1 + d against the unedited room (``--against``), for
d = +1, +2, +3, +5 % and several seeds; the unedited room against itself (OTHER another
seed) and ``scenes/default.xml`` through ``path`` against ``volpath`` (Mitsuba built-ins,
the same expectation) for the false alarms; the wall time of each default comparison.

    python benchmarks/compare_any.py [--seeds N] [--levels 1 2 3 5] [-D resx=80 ...]
                                     [--write-results [PATH]]

Every comparison is ``codermind_harness.compare.compare_scene`` at compare's defaults for an
ordinary scene (the scene's own sample count, at least 32; seeds S, S + 1 for OTHER, S + 2
for the noise floor), run here one after another.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import _results

PAGE = "compare-any.md"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=3, help="seeds per case (default 3)")
    p.add_argument("--levels", type=float, nargs="+", default=[1.0, 2.0, 3.0, 5.0],
                   help="light changes in percent (default 1 2 3 5)")
    p.add_argument("-D", "--define", action="append", default=[], metavar="NAME=VALUE",
                   help="XML defaults of the room (both sides), e.g. -D resx=80 -D resy=60")
    p.add_argument("--no-default-scene", action="store_true",
                   help="skip scenes/default.xml through path against volpath")
    _results.add_argument(p, PAGE)
    args = p.parse_args(argv)
    defines = dict(d.split("=", 1) for d in args.define)

    from codermind.variants import set_variant
    set_variant(None)
    import codermind  # noqa: F401  (registers the plugins)
    from codermind_harness.compare import Options, compare_scene
    plain = _results.tests_module("plain_scenes")

    rows, nulls = [], []
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        room = plain.room_copy(tmp, "room.xml")

        def run(scene: Path, other: Path, seed: int) -> tuple[dict, float]:
            opt = Options(seed=seed, out_dir=tmp / "out", progress=False, defines=defines,
                          against=other)
            t0 = time.perf_counter()
            rec = compare_scene(scene, opt)
            return rec, time.perf_counter() - t0

        for level in args.levels:
            bright = plain.room_copy(tmp, f"bright{level:g}.xml", light=1 + level / 100)
            recs = []
            for k in range(args.seeds):
                rec, sec = run(bright, room, 10 * k)
                recs.append((rec, sec))
                print(f"+{level:g} %: seed {10 * k}: {'pass' if rec['passed'] else 'FAIL'} "
                      f"{rec['failures']} ({sec:.1f} s)", file=sys.stderr)
            rows.append((f"room, panel +{level:g} %", recs))
        again = plain.room_copy(tmp, "again.xml")
        recs = []
        for k in range(args.seeds):
            rec, sec = run(room, again, 10 * k)
            recs.append((rec, sec))
            print(f"room null: seed {10 * k}: {'pass' if rec['passed'] else 'FAIL'} "
                  f"{rec['failures']} ({sec:.1f} s)", file=sys.stderr)
        nulls.append(("room against itself", recs))
        if not args.no_default_scene:
            d_path = plain.default_copy(tmp, "path.xml", width=320, height=240)
            d_vol = plain.default_copy(tmp, "volpath.xml", width=320, height=240,
                                       integrator="volpath")
            recs = []
            for k in range(args.seeds):
                opt = Options(seed=10 * k, out_dir=tmp / "out", progress=False, against=d_vol)
                t0 = time.perf_counter()
                rec = compare_scene(d_path, opt)
                recs.append((rec, time.perf_counter() - t0))
                print(f"default path vs volpath: seed {10 * k}: "
                      f"{'pass' if rec['passed'] else 'FAIL'} {rec['failures']}",
                      file=sys.stderr)
            nulls.append(("default.xml, path against volpath", recs))
    wall = time.perf_counter() - t_start

    head = ["case", "film", "spp", "runs", "failed", "caught by", "image pooled max abs Z, median",
            "tiles pooled Z sd, median", "z-test pass rate, min", "FLIP / limit, max",
            "seconds per comparison, median"]
    body = []
    for name, recs in rows + nulls:
        r0 = recs[0][0]
        failed = sum(not r["passed"] for r, _ in recs)
        by = sorted({_test(f) for r, _ in recs for f in r["failures"]})
        image_z = statistics.median(r["pooled"]["image"]["max_abs_z"] or 0.0 for r, _ in recs)
        body.append([name, f"{r0['width']}x{r0['height']}", r0["spp"], len(recs), failed,
                     ", ".join(by) or "-", f"{image_z:.1f}",
                     f"{statistics.median(r['pooled']['tiles']['z_sd'] or 0.0 for r, _ in recs):.2f}",
                     f"{min(r['z_test']['pass_rate'] for r, _ in recs):.4f}",
                     f"{max(r['flip_mean'] / r['flip_limit'] for r, _ in recs):.2f}",
                     f"{statistics.median(s for _, s in recs):.1f}"])
    crit = recs[0][0]["pooled"]["image"]["z_critical"]
    text = ("## Power and false alarms at the defaults\n\n"
            + _results.table(head, body)
            + f"\nThe whole image's pooled difference fails beyond abs Z {crit:.3g} (alpha 0.005, "
              "Sidak over the three channels). `caught by`: the failing tests' names.\n")
    print(text)
    if args.write_results:
        _results.write(args.write_results, text, section="power", title="compare on any scene",
                       seconds=wall)
    return 0


def _test(failure: str) -> str:
    """The test a failure sentence of ``verdict.scene_failures`` names."""
    for prefix, name in (("z-test pass rate", "z-test"), ("|z|", "far |z|"),
                         ("mean FLIP", "FLIP"), ("pooled z over tiles", "pooled tiles"),
                         ("pooled z over objects", "pooled objects"),
                         ("pooled z over image", "pooled image")):
        if failure.startswith(prefix):
            return name
    return failure


if __name__ == "__main__":
    sys.exit(main())
