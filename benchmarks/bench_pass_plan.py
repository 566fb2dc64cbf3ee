"""Page 4's film rendered with ``tutorialpath`` in passes of a given size, side by side.

    nice python benchmarks/bench_pass_plan.py [--spp 256] [--runs 2] [--plans 16,default]

Each plan ("default": codermind's pass plan, ``codermind.render.sampler_plan`` where the code
has it; a number: passes of at most that many spp) renders the converted
``page4/derived_scene_complexity256.txt`` (1280 x 960 film, multijitter) at ``--spp`` samples
per sub-sample; the plans are interleaved and each is timed ``--runs`` times (wall and process
CPU seconds, medians). The script uses only ``render_linear``'s ``pass_spp``, so it also runs
against an older checkout of the code (``PYTHONPATH=OLD/plugins:OLD/reference``), which is
how the speed of the host is compared between days.

``--vector-width 8`` compiles Dr.Jit's LLVM kernels 8 wide without AVX-512 (through
``jit_llvm_set_target``, which the Python module does not expose: ctypes on
libdrjit-core.so), to see what the host's AVX-512 gives against an AVX2 host of the same
scalar speed; one width per process, so alternate processes for a side-by-side comparison.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT.parent / "shared" / "tutorial" / "page4" / "derived_scene_complexity256.txt"


AVX512 = ("avx512f", "avx512vl", "avx512dq", "avx512bw", "avx512cd", "avx512vnni",
          "avx512bf16", "avx512vbmi", "avx512vbmi2", "avx512bitalg", "avx512vpopcntdq",
          "avx512ifma", "avx512fp16")


def llvm_width(dr, width: int) -> int:
    """Dr.Jit's LLVM vector width, after setting it to 8 without AVX-512 if ``width`` is 8."""
    import ctypes
    lib = ctypes.CDLL(str(Path(dr.__file__).parent / "libdrjit-core.so"))
    cpu = lib._Z19jit_llvm_target_cpuv
    cpu.restype = ctypes.c_char_p
    get = lib._Z21jit_llvm_vector_widthv
    get.restype = ctypes.c_uint32
    if width == 8:
        features = ",".join(["-" + f for f in AVX512] + ["+avx2", "+fma", "+f16c"])
        lib._Z19jit_llvm_set_targetPKcS0_j(cpu(), features.encode(), ctypes.c_uint32(8))
    return int(get())


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", type=Path, default=SCENE)
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--runs", type=int, default=2)
    p.add_argument("--plans", default="16,default")
    p.add_argument("--vector-width", type=int, choices=(0, 8), default=0,
                   help="0: the host's (16 with AVX-512); 8: AVX2 only")
    args = p.parse_args()
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    width = llvm_width(dr, args.vector_width)
    import codermind
    from codermind.tutorial.render import render_linear
    from codermind_harness import sides

    scene_txt = sides.parse(args.scene)
    grid = sides.Grid.of(scene_txt.width, scene_txt.height, scene_txt.page)
    xml = sides.convert_xml(args.scene, scene_txt, Path(tempfile.mkdtemp()), name="page4.xml")
    scene, _ = sides.load_mitsuba(xml, grid, {"spp": "1"})
    plans = {name: None if name == "default" else int(name) for name in args.plans.split(",")}
    print(f"{codermind.__file__}; LLVM vector width {width}; load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    for n in plans.values():
        render_linear(scene, 16, 1, pass_spp=n)            # compile outside the timing
    out = {name: [] for name in plans}
    for run in range(args.runs):
        for name, n in plans.items():
            dr.sync_thread()
            c0, w0 = os.times(), time.perf_counter()
            _, _, _, times = render_linear(scene, args.spp, run, pass_spp=n)
            dr.sync_thread()
            c1 = os.times()
            out[name].append((time.perf_counter() - w0,
                              c1.user + c1.system - c0.user - c0.system))
            print(f"  run {run + 1} plan {name}: {len(times)} passes, {out[name][-1][0]:.2f} s "
                  f"wall, {out[name][-1][1]:.2f} CPU s", flush=True)
    base = None
    for name, v in out.items():
        wall = statistics.median(w for w, _ in v)
        base = base or wall
        print(f"plan {name:8s}: {wall:7.2f} s wall, {statistics.median(c for _, c in v):7.2f} "
              f"CPU s (medians of {args.runs}), {wall / base:.3f}x the first plan's wall")
    print(f"load average {'%.2f %.2f %.2f' % os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
