"""Random blobs against the tests' independent solvers (run by hand; slow, not a test).

For each random blob (1-4 sources, R in [20, 100], max_error R/1000, R/300 or R/100, both
fields) it prints the measured error and the sampled distance both ways, as fractions of
max_error, and the smallest angle.

    python benchmarks/check_blob_random.py [--seed 1] [--count 30]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from support import blob_reference as ref  # noqa: E402

from codermind.blobmesh import build_blob_mesh  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=30)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    worst, smallest = 0.0, 180.0
    for trial in range(args.count):
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
        ratio = max(to_surface.max(), to_mesh.max()) / e
        worst, smallest = max(worst, ratio), min(smallest, m.info["min_angle_deg"])
        print(f"{trial:3d} n={n} {kind:8s} R={radius:5.1f} e/R={e / radius:.3f} "
              f"T={len(m.faces):6d} {seconds:5.2f}s passes={m.info['refine_passes']:2d} "
              f"measured/e={m.achieved_error / e:.3f} mesh->surface/e={to_surface.max() / e:.3f} "
              f"surface->mesh/e={to_mesh.max() / e:.3f} min angle={m.info['min_angle_deg']:.2f}"
              + ("  <-- above max_error" if ratio > 1 else ""), flush=True)
    print(f"worst distance / max_error {worst:.4f}, smallest angle {smallest:.2f} degrees")


if __name__ == "__main__":
    main()
