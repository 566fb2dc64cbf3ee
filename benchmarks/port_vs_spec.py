"""Statistics of the port's page-4 renders next to what facts.md F14 states about the original.

    python benchmarks/port_vs_spec.py [--seeds N] [--stride K] [--write-results [PATH]]

1. Auto exposure over N seeds (facts.md F13: "about 0.8 % sd for the bundled scene"; the
   Corrections paragraph: mean 2.1295, sd 0.016, range 2.091-2.168 over 200 sequences).
2. Mean 8-bit brightness at Complexity 256 minus at Complexity 1 (facts.md F14.7: about 2.7/255 brighter), both on every K-th pixel (default 4) of rows y >= 10 and with the same exposure
   (seed 0's auto exposure; the exposure's own spread would otherwise shift the means by about
   half a level): Complexity 1 averaged over 16 seeds, Complexity 256 (the derived scene
   file) with seed 0.
Both in strict mode (the original programs) and clean mode. ``--write-results`` writes the
table to docs/results/port.md (section ``spec``).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import codermind_ref as ref
from codermind_ref import driver
from codermind_ref.quirks import resolve
from codermind_ref.world import World

import _results

PAGE = "port.md"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200)
    parser.add_argument("--stride", type=int, default=4)
    parser.add_argument("--tutorial", type=_results.Path, default=_results.TUTORIAL)
    parser.add_argument("--modes", nargs="+", default=["strict", "clean"])
    _results.add_argument(parser, PAGE)
    args = parser.parse_args(argv)
    scene = ref.parse_scene(args.tutorial / "page4" / "scene.txt")
    dense = ref.parse_scene(args.tutorial / "page4" / "derived_scene_complexity256.txt")
    world = World(scene)
    cells: dict[str, list[str]] = {}
    for mode in args.modes:
        quirks = resolve(mode)
        e = np.array([driver.auto_exposure(scene, world, quirks, s) for s in range(args.seeds)])
        print(f"{mode}: auto exposure over {args.seeds} seeds: mean {e.mean():.4f}, "
              f"sd {e.std(ddof=1):.4f} ({100 * e.std(ddof=1) / e.mean():.2f} % of the mean), "
              f"range {e.min():.3f}-{e.max():.3f}", flush=True)

        def mean_byte(result):
            return result.rgb8_tga[result.ys >= 10].mean()

        low = np.mean([mean_byte(ref.render(scene, mode, seed=s, stride=args.stride,
                                            exposure=e[0])) for s in range(16)])
        high = mean_byte(ref.render(dense, mode, seed=0, stride=args.stride, exposure=e[0]))
        print(f"{mode}: mean byte (stride {args.stride}, rows y >= 10): Complexity 1 {low:.2f} "
              f"(16 seeds), Complexity 256 {high:.2f}; difference {high - low:+.2f}/255",
              flush=True)
        cells[mode] = [f"{e.mean():.4f} ({e.std(ddof=1):.4f}), range {e.min():.3f}-{e.max():.3f}",
                       f"{e[0]:.4f}",
                       f"{100 * e.std(ddof=1) / e.mean():.2f} %",
                       f"{high - low:+.2f}"]
    quantities = [f"auto exposure, mean (sd) over {args.seeds} seeds",
                  "auto exposure, seed 0",
                  f"auto exposure sd over {args.seeds} seeds, % of the mean",
                  f"mean byte, Complexity 256 minus Complexity 1 (same exposure, every "
                  f"{args.stride}th pixel)"]
    spec = ["2.1295 (0.016), range 2.091-2.168", "in 2.091-2.168", "about 0.8 %",
            "about +2.7"]
    rows = [[q, s] + [cells[m][i] for m in args.modes]
            for i, (q, s) in enumerate(zip(quantities, spec))]
    table = _results.table(["quantity", "the original (facts.md F14)"] + args.modes, rows)
    print(table)
    if args.write_results:
        _results.write(args.write_results, table, section="spec")
    return 0


if __name__ == "__main__":
    sys.exit(main())
