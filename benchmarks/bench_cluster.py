"""The port's page-4 render on a Dask LocalCluster (1 and 2 worker processes) against the
port's own process pool (1 and 2 processes), side by side in one run.

    python benchmarks/bench_cluster.py [--runs 3] [--complexity 1] [--per-task 1 2 4]
                                       [--write-results [PATH]]

Prints the median wall time per configuration (the configurations interleaved in each run,
rotated, after one untimed warm-up run each; the clusters are started before the timing, their
start-up reported apart), the speed-up against one process, the overhead per task (cluster of
one worker against one process, divided by the tasks), the round trip of an empty task and the
smallest task that pays on 2 workers: a task of t seconds with an overhead o is worth sending
when t > o / (workers - 1). Every image is checked bit-identical to the one-process render.
A timing: run it on a quiet machine. ``--write-results`` writes the table to
docs/results/cluster.md.
"""

from __future__ import annotations

import argparse
import functools
import os
import pickle
import statistics
import sys
import time
from pathlib import Path

import distributed
import numpy as np

import codermind_ref as ref
from codermind_harness.cluster import Cluster
from codermind_ref.driver import TILE_RAYS, _Job

import _results

ROOT = Path(__file__).resolve().parents[1]


def _noop(x):
    return x


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--complexity", type=int, default=1)
    parser.add_argument("--per-task", type=int, nargs="+", default=[1, 2, 4],
                        help="tiles per task on the 2-worker cluster")
    _results.add_argument(parser, "cluster.md")
    args = parser.parse_args(argv)
    scene = ref.parse_scene(ROOT / "scenes" / "page4.txt")
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} on "
          f"{os.cpu_count()} cores; page 4 {scene.width}x{scene.height}, Complexity "
          f"{args.complexity}, seed = run index, {args.runs} runs")
    t0 = time.perf_counter()
    one = Cluster("local:1", progress=False)
    two = Cluster("local:2", progress=False)
    print(f"cluster start-up (local:1 and local:2 together): {time.perf_counter() - t0:.1f} s")
    configs = {"process pool, 1 process": dict(workers=1),
               "process pool, 2 processes": dict(workers=2),
               f"cluster local:1, 1 tile/task": dict(tile_map=functools.partial(one.tile_map,
                                                                                 per_task=1))}
    for k in args.per_task:
        configs[f"cluster local:2, {k} tile(s)/task"] = dict(
            tile_map=functools.partial(two.tile_map, per_task=k))
    times: dict[str, list[float]] = {name: [] for name in configs}
    names = list(configs)
    tiles = None
    try:
        for run in range(-1, args.runs):          # run -1: warm-up (imports, JIT-free port)
            order = names[run % len(names):] + names[:run % len(names)] if run >= 0 else names
            images = {}
            for name in order:
                t = time.perf_counter()
                result = ref.render(scene, "clean", max(run, 0), args.complexity,
                                    progress=lambda done, total: None, **configs[name])
                if run >= 0:
                    times[name].append(time.perf_counter() - t)
                images[name] = result.linear
            base = images[names[0]]
            assert all(np.array_equal(base, im) for im in images.values()), "images differ"
        tiles = len(_Job(scene, None, None, 0, args.complexity, np.arange(scene.width),
                         np.arange(scene.height)).tiles())
        captured = {}
        ref.render(scene, "clean", 0, args.complexity,
                   tile_map=lambda job, tiles: captured.update(job=job) or map(job.trace, tiles))
        sends = []
        for _ in range(3):          # the job's trip to a worker, once per render
            t = time.perf_counter()
            distributed.wait(two.client.submit(_noop, captured["job"], pure=False))
            sends.append(time.perf_counter() - t)
        job_mb = len(pickle.dumps(captured["job"])) / 2 ** 20
        trip = []
        for _ in range(20):
            t = time.perf_counter()
            two.client.submit(_noop, 0, pure=False).result()
            trip.append(time.perf_counter() - t)
        t = time.perf_counter()
        futures = two.client.map(_noop, range(400), pure=False)
        two.client.gather(futures)
        throughput = (time.perf_counter() - t) / 400
    finally:
        one.close()
        two.close()
    med = {name: statistics.median(ts) for name, ts in times.items()}
    p1 = med[names[0]]
    print(f"\n{'configuration':34} {'median s':>9} {'vs 1 process':>13} {'runs'}")
    for name in names:
        print(f"{name:34} {med[name]:9.2f} {p1 / med[name]:12.2f}x  "
              + " ".join(f"{t:.2f}" for t in times[name]))
    per_tile = p1 / tiles
    overhead = (med[names[2]] - p1) / tiles
    print(f"\n{tiles} tiles of <= {TILE_RAYS} rays; one tile in one process: {per_tile:.3f} s "
          f"({per_tile / TILE_RAYS * 1e6:.2f} us per ray)")
    print(f"overhead per task (local:1 at 1 tile/task against 1 process, per task): "
          f"{overhead * 1e3:.1f} ms")
    print(f"empty task: round trip {statistics.median(trip) * 1e3:.1f} ms (median of 20), "
          f"{throughput * 1e3:.2f} ms per task when 400 are in flight on 2 workers")
    print(f"the job (scene, faces, world: {job_mb:.1f} MiB pickled) sent to a worker: "
          f"{statistics.median(sends):.2f} s per render (median of 3), "
          f"{statistics.median(sends) / tiles * 1e3:.1f} ms per tile of this render")
    pays = max(overhead, statistics.median(trip))
    print(f"smallest task that pays on 2 workers: t > o / (2 - 1) = {pays * 1e3:.1f} ms, about "
          f"{pays / per_tile * TILE_RAYS:,.0f} rays of this render "
          f"(o = the larger of the two overheads above)")
    print(f"load average at the end {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if args.write_results:
        body = (_results.table(["configuration", "median s", "vs 1 process"],
                               [[n, f"{med[n]:.2f}", f"{p1 / med[n]:.2f}x"] for n in names])
                + f"\nOne tile ({tiles} tiles of <= {TILE_RAYS} rays) in one process: "
                f"{per_tile:.3f} s; overhead per task (local:1 against one process): "
                f"{overhead * 1e3:.0f} ms; an empty task's round trip "
                f"{statistics.median(trip) * 1e3:.1f} ms; the render's job "
                f"({job_mb:.1f} MiB pickled) sent to a worker {statistics.median(sends):.2f} s; "
                f"smallest task that pays on 2 workers: {pays * 1e3:.0f} ms, about "
                f"{pays / per_tile * TILE_RAYS:,.0f} rays. Load average at the end "
                f"{os.getloadavg()[0]:.1f}.\n")
        _results.write(args.write_results, body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
