"""Statistics of the port's page-4 renders next to what the spec states about the original.

    python benchmarks/port_vs_spec.py [--seeds N] [--stride K]

1. Auto exposure over N seeds (spec 3: "about 0.8 % sd for the bundled scene").
2. Mean 8-bit brightness at Complexity 256 minus at Complexity 1 (spec 2.5: "about 2.7/255
   brighter"), both on every K-th pixel (default 4) of rows y >= 10 and with the same exposure
   (seed 0's auto exposure; the exposure's own spread would otherwise shift the means by about
   half a level): Complexity 1 averaged over 16 seeds, Complexity 256 (the derived scene
   file) with seed 0.
Both in strict mode (the original programs) and clean mode.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import codermind_ref as ref
from codermind_ref import driver
from codermind_ref.quirks import resolve
from codermind_ref.world import World

TUTORIAL = Path(__file__).resolve().parents[2] / "shared" / "tutorial"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200)
    parser.add_argument("--stride", type=int, default=4)
    parser.add_argument("--tutorial", type=Path, default=TUTORIAL)
    parser.add_argument("--modes", nargs="+", default=["strict", "clean"])
    args = parser.parse_args()
    scene = ref.parse_scene(args.tutorial / "page4" / "scene.txt")
    dense = ref.parse_scene(args.tutorial / "page4" / "derived_scene_complexity256.txt")
    world = World(scene)
    for mode in args.modes:
        quirks = resolve(mode)
        e = np.array([driver.auto_exposure(scene, world, quirks, s) for s in range(args.seeds)])
        print(f"{mode}: auto exposure over {args.seeds} seeds: mean {e.mean():.4f}, "
              f"sd {100 * e.std(ddof=1) / e.mean():.2f} % of the mean (spec: about 0.8 %)",
              flush=True)
        t0 = time.perf_counter()
        def mean_byte(result):
            return result.rgb8_tga[result.ys >= 10].mean()

        low = np.mean([mean_byte(ref.render(scene, mode, seed=s, stride=args.stride,
                                            exposure=e[0])) for s in range(16)])
        high_mean = mean_byte(ref.render(dense, mode, seed=0, stride=args.stride, exposure=e[0]))
        print(f"{mode}: mean byte (stride {args.stride}, rows y >= 10): Complexity 1 {low:.2f} "
              f"(16 seeds), Complexity 256 {high_mean:.2f}; difference "
              f"{high_mean - low:+.2f}/255 (spec: about +2.7/255); {time.perf_counter() - t0:.0f} s",
              flush=True)


if __name__ == "__main__":
    main()
