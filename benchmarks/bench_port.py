"""Time the standalone port on the tutorial scenes at 640x480 (page 4 at Complexity 1).

    python benchmarks/bench_port.py [--runs N] [--workers 1 2]

Prints, per scene and worker count, the median wall time over the runs (and the median CPU
time of this process, which counts worker processes' work only for workers=1), and for page 4
the ratio to the original program's 1.3 s on one core (spec header). Not a test: the machine
may be shared, so read the medians together with the load printed at the start.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import codermind_ref as ref

TUTORIAL = Path(__file__).resolve().parents[2] / "shared" / "tutorial"
ORIGINAL_PAGE4_SECONDS = 1.3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--tutorial", type=Path, default=TUTORIAL)
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; "
          f"{args.runs} runs per line; seed = run index")
    print(f"{'scene':8} {'workers':>7} {'wall median':>12} {'cpu median':>11}  note")
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
            note = ""
            if page == 4:
                note = f"{wall / ORIGINAL_PAGE4_SECONDS:.2f}x the original's 1.3 s (target <= 3x)"
            cpu = f"{statistics.median(cpus):10.2f}s" if workers == 1 else f"{'-':>11}"
            print(f"page{page:<4} {workers:>7} {wall:11.2f}s {cpu}  {note}", flush=True)


if __name__ == "__main__":
    main()
