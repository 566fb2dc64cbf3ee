"""Random blobs against the tests' independent solvers (slow, not a test).

For each random blob (1-4 sources, R in [20, 100], max_error R/1000, R/300 or R/100, both
fields) it prints the measured error and the sampled distance both ways, as fractions of
max_error, and the smallest angle; ``--write-results`` writes the summary per seed to
docs/results/blob.md (section ``random``).

    python benchmarks/check_blob_random.py [--seeds 1 2 ...] [--count 30] [--write-results [PATH]]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from codermind.blobmesh import build_blob_mesh

import _results

ref = _results.tests_module("blob_reference")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--count", type=int, default=30, help="blobs per seed")
    _results.add_argument(ap, "blob.md")
    args = ap.parse_args(argv)
    rows = [check(seed, args.count) for seed in args.seeds]
    total = [sum(r[1] for r in rows), max(r[2] for r in rows), min(r[3] for r in rows),
             sum(r[4] for r in rows)]
    table = _results.table(
        ["seed", "blobs", "largest distance / max_error (both ways, and measured)",
         "smallest angle, degrees", "blobs above max_error"],
        [[r[0], r[1], f"{r[2]:.3f}", f"{r[3]:.2f}", r[4]] for r in rows]
        + [["all", total[0], f"{total[1]:.3f}", f"{total[2]:.2f}", total[3]]])
    print(table)
    if args.write_results:
        _results.write(args.write_results, table, section="random")
    return 0


def check(seed: int, count: int) -> tuple:
    """(seed, blobs, worst distance / max_error, smallest angle, blobs above max_error)."""
    rng = np.random.default_rng(seed)
    worst, smallest, above = 0.0, 180.0, 0
    for trial in range(count):
        n, radius = int(rng.integers(1, 5)), rng.uniform(20, 100)
        centers = rng.normal(size=(n, 3)) * radius * 1.2
        kind = ("tutorial", "exact")[trial % 2]
        e = radius * rng.choice([0.001, 0.003, 0.01])
        t0 = time.perf_counter()
        m = build_blob_mesh(centers, radius, kind, e)
        seconds = time.perf_counter() - t0
        to_surface = ref.mesh_to_surface(m.vertices, m.faces, centers, radius, kind, e, 2, rng)
        samples = ref.surface_samples(centers, radius, kind, 200, rng)
        to_mesh = ref.distance_to_mesh(samples, m.vertices, m.faces)
        ratio = max(to_surface.max(), to_mesh.max(), m.achieved_error) / e
        above += ratio > 1
        worst, smallest = max(worst, ratio), min(smallest, m.info["min_angle_deg"])
        print(f"{trial:3d} n={n} {kind:8s} R={radius:5.1f} e/R={e / radius:.3f} "
              f"T={len(m.faces):6d} {seconds:5.2f}s passes={m.info['refine_passes']:2d} "
              f"measured/e={m.achieved_error / e:.3f} mesh->surface/e={to_surface.max() / e:.3f} "
              f"surface->mesh/e={to_mesh.max() / e:.3f} min angle={m.info['min_angle_deg']:.2f}"
              + ("  <-- above max_error" if ratio > 1 else ""), flush=True)
    print(f"seed {seed}: worst distance / max_error {worst:.4f}, smallest angle "
          f"{smallest:.2f} degrees", flush=True)
    return seed, count, worst, smallest, above


if __name__ == "__main__":
    sys.exit(main())
