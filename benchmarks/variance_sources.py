"""Where page 4's noise comes from: the variance per sample with parts of the scene removed.

    nice python benchmarks/variance_sources.py [--spp 16]

Each variant of ``page4/derived_scene_complexity256.txt`` (the same edits as
``bench_page4_c256.py --breakdown``) is converted and rendered twice at ``--spp`` with
different seeds (the converter's sampler, ``tutorialpath``); its error is that of
``bench_samplers.py --pairs``, mean((X1 - X2)^2 / 2 / (N^2 + eps)), here with N the two
renders' mean, times spp: the relative variance of one sample, on the whole film and on a
box over the blob's left lobes. A part whose removal lowers it is a source of the noise;
the variants remove more than noise (they change the image), so the numbers say where to
look, not how much a better estimator would save.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

VARIANTS = {
    "as converted": (),
    "no lens (Dispersion 0)": (("Scene", "Perspective.Dispersion", "0.0"),),
    "blob without bump": (("Material3", "Bumplevel", "0.0"),),
    "blob without refraction": (("Material3", "Refraction", "0.0"),),
    # no mirror event at the glass: no sky reflection in front, no internal reflection
    "blob without reflection": (("Material3", "Reflection", "0.0"),),
    "no lens, blob without bump": (("Scene", "Perspective.Dispersion", "0.0"),
                                   ("Material3", "Bumplevel", "0.0")),
}
BLOB_BOX = (slice(200, 780), slice(100, 700))     # film rows, columns (sub-samples)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--spp", type=int, default=16)
    args = p.parse_args()
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401
    import bench_page4_c256 as bench
    from codermind.tutorial import render as tr
    from codermind.tutorial.render import render_linear
    from codermind_harness.metrics import REL_MSE_EPS

    source = bench.SHARED / "derived_scene_complexity256.txt"
    folder = Path(tempfile.mkdtemp(prefix="variance_sources_"))
    print(f"relative variance x spp ({args.spp} spp, two seeds)")
    for k, (name, edits) in enumerate(VARIANTS.items()):
        xml = bench.convert(source, folder, f"v{k}", edits=edits, spp=args.spp)
        scene, _ = tr.load(xml)
        x1, x2 = (render_linear(scene, args.spp, seed)[0].astype(np.float64) for seed in (7, 8))
        c = (np.square(x1 - x2) / 2 / (np.square((x1 + x2) / 2) + REL_MSE_EPS)).mean(-1)
        print(f"  {name:28s} whole film {c.mean() * args.spp:.4f}, blob box "
              f"{c[BLOB_BOX].mean() * args.spp:.4f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
