"""Build time and triangle count of the page-4 blob against max_error (medians).

The page-4 blob: R = 80, centres (160,290,320), (400,290,480), (250,140,400), seen by the
scene's conic camera (eye (320,240,0) looking along +z, horizontal FOV 90 over 640 px, so
the image plane is at PD = 320). A surface displacement e at a point p moves its image by
at most PD |p - eye| / z^2 * e pixels (radially; the largest factor over the blob's
vertices is used), so max_error = 0.25 px / that factor.

    python benchmarks/bench_blob.py [--repeat 7] [--field tutorial|exact|both]
                                    [--write-results [PATH]]

A timing: run it on a quiet machine. ``--write-results`` writes the table to
docs/results/blob.md (section ``build``).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
from skimage.measure import marching_cubes

from codermind.blobmesh import build_blob_mesh

import _results

CENTERS = np.array([(160, 290, 320), (400, 290, 480), (250, 140, 400)], float)
RADIUS = 80.0
EYE = np.array([320.0, 240.0, 0.0])
PD = 320.0  # (W/2) / tan(FOV/2) with W = 640, FOV = 90 degrees
TARGET_SECONDS = 0.3


def px_per_unit(vertices: np.ndarray) -> float:
    d = vertices - EYE
    return float((PD * np.linalg.norm(d, axis=1) / d[:, 2] ** 2).max())


def plain_marching_cubes(field: str, h: float) -> None:
    """The baseline: the field on the full grid at cell h and scikit-image's marching cubes,
    nothing else (no error bound). Timed in the same loop, so the ratio is fair on a busy
    machine."""
    lo = CENTERS.min(0) - 2.2 * RADIUS
    hi = CENTERS.max(0) + 2.2 * RADIUS
    axes = [np.arange(a, b + h, h) for a, b in zip(lo, hi)]
    shape = tuple(len(ax) for ax in axes)
    vol = np.zeros(shape)
    for c in CENTERS:
        x = sum((ax.reshape([-1 if j == k else 1 for j in range(3)]) - c[k]) ** 2
                for k, ax in enumerate(axes)) / RADIUS**2
        vol += 1.0 / x if field == "exact" else np.interp(x, XS, FS, right=0.0)
    marching_cubes(vol.astype(np.float32), 1.0, spacing=(h, h, h))


XS = np.array([0.0, 1.0, 10 / 9, 1.25, 10 / 7, 5 / 3, 2.0, 2.5, 10 / 3, 5.0, 10.0])
FS = np.array([1.9, 1.0, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2, 0.0])


def run(field: str, max_error: float, repeat: int):
    times, base, mesh = [], [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        mesh = build_blob_mesh(CENTERS, RADIUS, field, max_error)
        times.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        plain_marching_cubes(field, mesh.info["cell_size"])
        base.append(time.perf_counter() - t0)
    return statistics.median(times), min(times), statistics.median(base), mesh


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--field", default="both", choices=["tutorial", "exact", "both"])
    _results.add_argument(ap, "blob.md")
    args = ap.parse_args(argv)
    rows = []
    fields = ["tutorial", "exact"] if args.field == "both" else [args.field]
    build_blob_mesh(CENTERS, RADIUS, "exact", 1.0)  # warm-up (imports, caches)
    scale = px_per_unit(build_blob_mesh(CENTERS, RADIUS, "tutorial", 0.5).vertices)
    target = 0.25 / scale
    print(f"page-4 blob: {scale:.4f} px per world unit at most -> 0.25 px = "
          f"max_error {target:.4f}")
    print("(plain MC: the field on the whole grid at the same first cell size and scikit-image's"
          " marching cubes alone, no projection, no error bound)")
    print(f"{'field':9s} {'max_error':>9s} {'px':>6s} {'triangles':>9s} {'achieved':>9s} "
          f"{'median s':>9s} {'min s':>7s} {'/ 0.3 s':>7s} {'plain MC s':>10s} {'/ plain':>7s} "
          f"{'cell':>6s} {'passes':>6s}")
    for field in fields:
        for max_error in (4 * target, 2 * target, target, target / 2):
            med, best, base, m = run(field, max_error, args.repeat)
            print(f"{field:9s} {max_error:9.4f} {max_error * scale:6.3f} {len(m.faces):9d} "
                  f"{m.achieved_error:9.4f} {med:9.3f} {best:7.3f} {med / TARGET_SECONDS:7.2f} "
                  f"{base:10.3f} {med / base:7.2f} {m.info['cell_size']:6.2f} "
                  f"{m.info['refine_passes']:6d}")
            rows.append([field, f"{max_error:.3f}", f"{max_error * scale:.3g}",
                         f"{len(m.faces):,}", f"{m.achieved_error:.3f}", f"{med:.2f}",
                         f"{base:.3f}", f"{med / base:.0f}"])
    if args.write_results:
        body = (f"The page-4 blob is magnified at most {scale:.4f} px per world unit, so "
                f"0.25 px is max_error {target:.4f}; medians of {args.repeat} builds.\n\n"
                + _results.table(["field", "max_error", "px", "triangles", "measured error",
                                  "build s", "plain MC s", "build / plain MC"], rows))
        _results.write(args.write_results, body, section="build")
    return 0


if __name__ == "__main__":
    sys.exit(main())
