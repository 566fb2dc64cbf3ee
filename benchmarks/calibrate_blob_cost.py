"""The blob mesher's cost against its estimate (``codermind.blobmesh.estimate_cost``): for
spheres, pairs, the page-4 blob and random blobs (2-6 sources, centres within about 1.5 R
of each other, max_error R/5000 to R/100, both fields) it builds the mesh and prints the
real triangle count over the estimate, the time per triangle and the peak memory per
triangle (numpy's allocations, by tracemalloc), then their ranges per field. The constants
of ``codermind/blobmesh/cost.py`` come from this (minutes, not a test); the times are
timings (a quiet machine). ``--write-results`` writes the ranges per field to
docs/results/blob.md (section ``cost``).

    python benchmarks/calibrate_blob_cost.py [--seed 1] [--count 12] [--write-results [PATH]]
"""

from __future__ import annotations

import argparse
import sys
import time
import tracemalloc

import numpy as np

from codermind.blobmesh import build_blob_mesh, estimate_cost

import _results

PAGE4 = [(160, 290, 320), (400, 290, 480), (250, 140, 400)]


def cases(seed: int, count: int):
    for field in ("tutorial", "exact"):
        for e in (1e-2, 1e-3, 2e-4):
            yield f"sphere R/{1 / e:g}", [[0, 0, 0]], 1.0, field, e
        for dist in (1.0, 1.6, 2.2):
            yield f"pair at {dist} R", [[0, 0, 0], [dist, 0, 0]], 1.0, field, 1e-3
        yield "page 4, 0.15", PAGE4, 80.0, field, 0.15
    rng = np.random.default_rng(seed)
    for k in range(count):
        n = int(rng.integers(2, 7))
        r = float(rng.uniform(0.5, 2.0))
        c = (rng.uniform(-1.5, 1.5, (n, 3)) * r).tolist()
        e = float(r * 10 ** rng.uniform(-3.7, -2.0))
        for field in ("tutorial", "exact"):
            yield f"random {k}: {n} sources, R/{r / e:.0f}", c, r, field, e


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=12)
    _results.add_argument(ap, "blob.md")
    args = ap.parse_args(argv)
    summary = []
    rows = {"tutorial": [], "exact": []}
    for name, c, r, field, e in cases(args.seed, args.count):
        t0 = time.perf_counter()
        cost = estimate_cost(c, r, field, e)
        t_est = time.perf_counter() - t0
        tracemalloc.start()
        t0 = time.perf_counter()
        n = len(build_blob_mesh(c, r, field, e).faces)
        seconds = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        rows[field].append((n / cost.triangles, seconds / n, peak / n))
        print(f"{field:8s} {name:34s} {n:8d} triangles, estimate {cost.triangles:9.0f} "
              f"(real/estimate {n / cost.triangles:.3f}, {1e3 * t_est:.0f} ms), "
              f"{1e6 * seconds / n:5.1f} us and {peak / n:4.0f} B per triangle", flush=True)
    for field, r in rows.items():
        a = np.array(r)
        print(f"{field}: real/estimate {a[:, 0].min():.3f}-{a[:, 0].max():.3f} "
              f"(median {np.median(a[:, 0]):.3f}); us per triangle median "
              f"{1e6 * np.median(a[:, 1]):.1f}; bytes per triangle median "
              f"{np.median(a[:, 2]):.0f}, max {a[:, 2].max():.0f}")
        summary.append([field, len(a), f"{a[:, 0].min():.3f}-{a[:, 0].max():.3f}",
                        f"{np.median(a[:, 0]):.3f}", f"{1e6 * np.median(a[:, 1]):.1f}",
                        f"{np.median(a[:, 2]):.0f} / {a[:, 2].max():.0f}"])
    if args.write_results:
        _results.write(args.write_results, _results.table(
            ["field", "meshes", "real / estimated triangles", "median", "us per triangle, median",
             "bytes per triangle, median / max"], summary), section="cost")
    return 0


if __name__ == "__main__":
    sys.exit(main())
