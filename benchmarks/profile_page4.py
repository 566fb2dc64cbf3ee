"""Where ``tutorialpath``'s time goes on page 4: path lengths and SIMD divergence, the cost of
its parts (integrator variants side by side), and the blob mesh against analytic spheres.

    nice python benchmarks/profile_page4.py [--spp 8] [--runs 3] [--vector-width 8]

1. **Path lengths**: loop iterations per sample (16 one-sample renders), their histogram, and
   the mean of the longest path in a packet of 8 / 16 samples of one pixel (Mitsuba's render
   loop gives one pixel's samples consecutive lanes; a megakernel packet of the 8-wide AVX2
   vectors runs until its longest path ends).
2. **Parts**: CPU seconds per sample per pixel of the 1280 x 960 film for copies of
   ``tutorialpath`` with one part removed (patched source, registered under another name):
   no shadow ray traced, no delta lights at all, no emission looked up at hits, fewer ray
   flags. Rendered interleaved, medians of ``--runs``.
3. **The blob**: the scene as converted, the blob's three sources as three analytic glass
   spheres of the blob's radius, the blob meshed with ``--max-error``, and no blob.

The split between Embree (ray traversal) and the JIT-compiled megakernel comes from
``perf record -g python benchmarks/profile_page4.py`` then ``perf report --sort dso``.
"""

from __future__ import annotations

import argparse
import importlib
import re
import resource
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
INTEGRATOR = ROOT / "plugins" / "codermind" / "integrators" / "tutorialpath.py"

#: (old, new) source edits of tutorialpath.py, each one part removed
PARTS = {
    "as converted": [],
    "no shadow ray traced": [("blocked = scene.ray_test(shadow, lit)", "blocked = mi.Bool(False)")],
    "no delta lights": [("for k in range(len(deltas)):", "for k in range(0):")],
    "emission only on escape": [("L += beta * mis * emitter.eval(si, active)\n",
                                 "L += beta * mis * emitter.eval(si, active & ~si.is_valid())\n")],
    "ray flags without UV": [("ray_flags=mi.RayFlags.All",
                              "ray_flags=mi.RayFlags.Minimal | mi.RayFlags.ShadingFrame")],
}
ITERS = [("        while active:\n", "        iters = mi.UInt32(0)\n        while active:\n"
          "            iters += 1\n"),
         ("return L, valid_ray, []", "return mi.Spectrum(mi.Float(iters)), valid_ray, []")]


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def patched(name: str, edits, folder: Path) -> str:
    """Register a patched copy of tutorialpath as ``name`` (a module file: dr.syntax needs
    the source)."""
    src = INTEGRATOR.read_text()
    for old, new in edits:
        if old not in src:
            raise SystemExit(f"tutorialpath.py changed: cannot find {old!r}")
        src = src.replace(old, new)
    src = src.replace('mi.register_integrator("tutorialpath"', f'mi.register_integrator("{name}"')
    src = src.replace("from ..", "from codermind.")   # the copy is a top-level module
    (folder / f"{name}.py").write_text(src)
    importlib.import_module(name)
    return name


def costs(scenes: dict, spp: int, runs: int, mi) -> dict:
    for s in scenes.values():
        np.array(mi.render(s, spp=spp))          # compile outside the timing
    out = {n: [] for n in scenes}
    for run in range(runs):
        for n, s in scenes.items():
            c = cpu()
            np.array(mi.render(s, spp=spp, seed=run))
            out[n].append((cpu() - c) / spp)
    return {n: statistics.median(v) for n, v in out.items()}


def table(title: str, cost: dict) -> None:
    base = next(iter(cost.values()))
    print(f"\n{title}: CPU s per spp (1280 x 960 film)")
    for n, c in cost.items():
        print(f"  {n:28s} {c:7.4f}  ({c / base:5.3f})")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--spp", type=int, default=8)
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--max-error", type=float, default=0.0864865,
                   help="another blob max_error for the blob table (default: the rule before "
                        "2026-12-02)")
    p.add_argument("--vector-width", type=int, choices=(0, 8), default=0,
                   help="8: Dr.Jit's kernels 8 wide without AVX-512 (bench_pass_plan.llvm_width)")
    args = p.parse_args()
    import drjit as dr
    import mitsuba as mi
    from bench_pass_plan import llvm_width
    print(f"LLVM vector width {llvm_width(dr, args.vector_width)}")
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401
    from codermind.tutorial import render as tr
    import bench_page4_c256 as bench

    folder = Path(tempfile.mkdtemp(prefix="profile_page4_"))
    sys.path.insert(0, str(folder))
    source = bench.SHARED / "derived_scene_complexity256.txt"

    def scene(name: str, integrator: str = "tutorialpath", spp: int = args.spp, xml_edit=None,
              **options):
        xml = bench.convert(source, folder, name, spp=spp, **options)
        text = xml.read_text().replace('type="tutorialpath"', f'type="{integrator}"')
        xml.write_text(xml_edit(text) if xml_edit else text)
        return tr.load(xml)[0]

    # 1. path lengths
    s = scene("iters", patched("p_iters", ITERS, folder), spp=1)
    it = np.stack([np.array(mi.render(s, spp=1, seed=k))[..., 0] for k in range(16)])
    hist = np.bincount(np.rint(it).astype(int).ravel())
    print(f"loop iterations per sample: mean {it.mean():.3f}; histogram (1..): {hist[1:].tolist()}")
    for w in (8, 16):
        longest = it[:w].max(axis=0).mean()
        print(f"  longest of a packet of {w} samples of one pixel: {longest:.3f} "
              f"({longest / it[:w].mean():.3f} x the mean)")

    # 2. parts
    scenes = {n: scene(f"part{k}", patched(f"p_part{k}", edits, folder))
              for k, (n, edits) in enumerate(PARTS.items())}
    table("Parts of tutorialpath", costs(scenes, args.spp, args.runs, mi))

    # 3. the blob
    def spheres(text: str) -> str:
        blob = re.search(r'<shape type="blob">.*?</shape>', text, re.S).group(0)
        radius = re.search(r'name="radius" value="([^"]+)"', blob)[1]
        material = re.search(r'<ref id="(\w+)"/>', blob)[1]
        balls = "".join(f'<shape type="sphere"><point name="center" x="{x}" y="{y}" z="{z}"/>'
                        f'<float name="radius" value="{radius}"/><ref id="{material}"/></shape>'
                        for x, y, z in re.findall(
                            r'<point name="center\d+" x="([^"]+)" y="([^"]+)" z="([^"]+)"', blob))
        return text.replace(blob, balls)

    def no_blob(text: str) -> str:
        return re.sub(r'<shape type="blob">.*?</shape>', "", text, flags=re.S)

    blob = {"as converted (blob mesh)": scene("blob"),
            "3 analytic glass spheres": scene("spheres", xml_edit=spheres),
            f"blob max_error {args.max_error:g}": scene("coarse", blob_max_error=args.max_error),
            "no blob": scene("noblob", xml_edit=no_blob)}
    for sh in blob["as converted (blob mesh)"].shapes():
        if sh.is_mesh():
            print(f"\nblob mesh: {sh.face_count()} triangles")
    table("The blob", costs(blob, args.spp, args.runs, mi))
    return 0


if __name__ == "__main__":
    sys.exit(main())
