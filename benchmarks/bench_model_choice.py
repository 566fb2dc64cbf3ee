"""Does the minimal model pay? For each bundled tutorial scene, the time of the model that
``codermind convert`` chose against a maximal one (path depth 10, many samples, a fine blob
mesh), measured side by side, with the difference between their images.

For each scene (scenes/page1..4, plus page 1 and 2 with weak mirrors, Reflection 0.1, where
the depth bound cuts the paths short):

* chosen: the XML's defaults (max_depth, spp, blob max_error);
* maximal: max_depth 11 (the tutorial's 10 segments), ``--max-spp`` samples per sub-sample
  where the scene is deterministic (the extra samples are identical, so the images agree up
  to rounding), the scene's Complexity where it is not (a different count would change the
  expected image: facts.md F6), and blob max_error = chosen / 4;
* depth 10: the chosen model with max_depth 11 (what the depth choice alone saves);
* all with the tutorial's pipeline (lights summed, the same fixed exposure, the same seed);
  timed from loading (the blob mesh is built then) to the 8-bit image, wall and CPU, medians
  of ``--runs`` interleaved runs after one warm-up each (JIT compilation).

"equal error": max |difference| of the images before truncation, in 8-bit levels, and the
count of differing bytes; for the deterministic scenes it must be within the convert target
(0.5 levels); for the stochastic page 4 the two differ by noise and by the blob mesh, and the
mean difference of the chosen model at two seeds (the noise floor) is printed next to it.

A timing: run it on a quiet machine. ``--write-results`` writes the table to
docs/results/model-choice.md.

    python benchmarks/bench_model_choice.py [--runs 3] [--max-spp 64] [--write-results [PATH]]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import _results

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def defaults(xml: Path) -> dict[str, str]:
    return dict(re.findall(r'<default name="(\w+)" value="([^"]+)"/>', xml.read_text()))


def weak_mirror(name: str, folder: Path) -> Path:
    """scenes/NAME.txt with Reflection 0.1, converted into ``folder``."""
    from codermind.tutorial.convert import convert_scene
    from codermind_ref import parse_scene as parse
    source = folder / f"{name}_weak.txt"
    source.write_text((SCENES / f"{name}.txt").read_text().replace("Reflection = 0.5;",
                                                                    "Reflection = 0.1;"))
    xml = folder / f"{name}_weak.xml"
    xml.write_text(convert_scene(parse(source), xml).xml)
    return xml


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--max-spp", type=int, default=64)
    _results.add_argument(p, "model-choice.md")
    args = p.parse_args(argv)
    floors = {}

    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401
    from codermind.tutorial import render as tr
    from codermind.tutorial.image import srgb_encode

    folder = Path(tempfile.mkdtemp(prefix="bench_model_"))
    cases = [(f"page{k}", SCENES / f"page{k}.xml") for k in (1, 2, 3, 4)]
    cases += [(f"page{k} Reflection 0.1", weak_mirror(f"page{k}", folder)) for k in (1, 2)]

    def run(xml: Path, defines: dict, spp: int, exposure) -> tuple[np.ndarray, float, float]:
        t, c = time.perf_counter(), cpu()
        scene, settings = tr.load(xml, **defines)
        res = tr.render(scene, settings, spp=spp, seed=1, exposure=exposure)
        dr.sync_thread()
        tone = res.image.tonemapped
        value = 255 * (tone if settings.page == 1 else srgb_encode(tone))
        return (value, res.image.rgb8), time.perf_counter() - t, cpu() - c

    print(f"{os.getloadavg()} load average; {dr.thread_count()} Dr.Jit threads")
    rows = []
    for name, xml in cases:
        d = defaults(xml)
        scene, settings = tr.load(xml)
        exposure = tr.probe_exposure(tr.light_scenes(scene), settings) \
            if settings.page == 4 else None
        deterministic = '<sampler type="stratified">' in xml.read_text()
        chosen = ({k: v for k, v in d.items()}, int(d["spp"]))
        maximal = dict(d, max_depth="11")
        for key in d:
            if key.endswith("_max_error"):
                maximal[key] = f"{float(d[key]) / 4:.6g}"
        max_spp = args.max_spp if deterministic else int(d["spp"])
        models = {"chosen": chosen, "depth 10": (dict(d, max_depth="11"), int(d["spp"])),
                  "maximal": (maximal, max_spp)}
        for label, (defines, spp) in models.items():   # warm-up: compile the kernels
            run(xml, dict(defines, spp=1), 1, exposure)
        times = {label: [] for label in models}
        images = {}
        for _ in range(args.runs):
            for label, (defines, spp) in models.items():
                images[label], wall, c = run(xml, defines, spp, exposure)
                times[label].append((wall, c))
        med = {label: (statistics.median(w for w, _ in t), statistics.median(c for _, c in t))
               for label, t in times.items()}
        diff = np.abs(images["chosen"][0] - images["maximal"][0])
        level = (diff.max(), diff.mean(), int((diff.max(-1) > 0.5).sum()))
        nbytes = int((images["chosen"][1] != images["maximal"][1]).sum())
        if not deterministic:   # the noise floor: the chosen model at another seed
            scene, settings = tr.load(xml)
            other = tr.render(scene, settings, seed=2, exposure=exposure).image
            tone = 255 * srgb_encode(other.tonemapped)
            floor = np.abs(tone - images["chosen"][0]).mean()
            floors[name] = floor
            print(f"{name}: mean |diff| chosen vs maximal {level[1]:.4f} levels; chosen at "
                  f"two seeds (the noise) {floor:.4f}")
        rows.append((name, chosen, (maximal, max_spp), med, level, nbytes))
        print(f"{name}: chosen {med['chosen'][0]:.2f} s, maximal {med['maximal'][0]:.2f} s",
              flush=True)

    print()
    print(f"Minimal vs maximal model, medians of {args.runs} runs (load + render + pipeline); "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"{'scene':22s} {'chosen depth/spp/blob':22s} {'maximal':22s} {'chosen s':>9s} "
          f"{'depth10 s':>9s} {'maximal s':>9s} {'ratio':>6s} {'CPU ratio':>9s} {'max diff':>9s} "
          f"{'mean diff':>9s} {'px > 0.5':>8s} {'bytes':>7s}")
    for name, (cd, cs), (md, ms), med, level, nbytes in rows:
        def model(d, s):
            blob = next((v for k, v in d.items() if k.endswith("_max_error")), "-")
            return f"{int(d['max_depth']) - 1}/{s}/{blob}"
        print(f"{name:22s} {model(cd, cs):22s} {model(md, ms):22s} {med['chosen'][0]:9.2f} "
              f"{med['depth 10'][0]:9.2f} {med['maximal'][0]:9.2f} "
              f"{med['maximal'][0] / med['chosen'][0]:6.1f} "
              f"{med['maximal'][1] / med['chosen'][1]:9.1f} {level[0]:9.3f} {level[1]:9.4f} "
              f"{level[2]:8d} {nbytes:7d}")
    if args.write_results:
        table = []
        for name, (cd, cs), (md, ms), med, level, nbytes in rows:
            def model(d, s):
                blob = next((v for k, v in d.items() if k.endswith("_max_error")), "-")
                return f"{int(d['max_depth']) - 1}/{s}/{blob}"
            table.append([name, model(cd, cs), f"{med['chosen'][0]:.2f} s",
                          f"{med['depth 10'][0]:.2f} s", model(md, ms),
                          f"{med['maximal'][0]:.2f} s",
                          f"{med['maximal'][0] / med['chosen'][0]:.1f}",
                          f"{level[0]:.3g} / {level[1]:.2g}", level[2], nbytes,
                          f"{floors[name]:.3g}" if name in floors else "-"])
        _results.write(args.write_results, _results.table(
            ["scene", "chosen: depth/spp/blob max_error", "time", "chosen with depth 10",
             "maximal", "time", "maximal / chosen", "max / mean difference, levels",
             "pixels > 0.5 levels", "bytes differing", "noise: chosen at two seeds, mean"],
            table))
    print("depth = path depth (Mitsuba max_depth - 1); diffs in 8-bit levels before truncation "
          "(px > 0.5: pixels differing by more than the convert target); bytes: differing "
          "bytes of the 640x480x3 image. Page 1-2 pixels on the mirror plane x = 320 hit two "
          "spheres at exactly the same distance: which one Embree reports can change with the "
          "sample count (up to ~50 levels there).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
