"""Time the standalone port on the tutorial scenes at 640x480 (page 4 at Complexity 1).

    python benchmarks/bench_port.py [--runs N] [--workers 1 2] [--write-results [PATH]]

Prints, per scene and worker count, the median wall time over the runs (and the median CPU
time of this process, which counts worker processes' work only for workers=1), and for page 4
the ratio to the original program's 1.3 s on one core (facts.md F14.2). A timing: run it on a
quiet machine. ``--write-results`` writes the table to docs/results/port.md (section
``speed``).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import codermind_ref as ref

import _results

ORIGINAL_PAGE4_SECONDS = 1.3
PAGE = "port.md"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--tutorial", type=_results.Path, default=_results.TUTORIAL)
    _results.add_argument(parser, PAGE)
    args = parser.parse_args(argv)
    rows = []
    for page in (1, 2, 4):
        scene = ref.parse_scene(args.tutorial / f"page{page}" / "scene.txt")
        for workers in args.workers:
            walls, cpus = [], []
            for run in range(args.runs):
                w0, c0 = time.perf_counter(), time.process_time()
                ref.render(scene, "strict", seed=run, workers=workers)
                walls.append(time.perf_counter() - w0)
                cpus.append(time.process_time() - c0)
            wall = statistics.median(walls)
            ratio = f"{wall / ORIGINAL_PAGE4_SECONDS:.2f}x" if page == 4 else "-"
            cpu = f"{statistics.median(cpus):.2f} s" if workers == 1 else "-"
            rows.append([f"page {page}", workers, f"{wall:.2f} s", cpu, ratio])
            print(" | ".join(map(str, rows[-1])), flush=True)
    table = _results.table(["scene", "workers", f"wall, median of {args.runs}",
                            "CPU of this process", "page 4 / the original's 1.3 s"], rows)
    if args.write_results:
        _results.write(args.write_results, table, section="speed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
