"""The page-4 scene through Mitsuba at Complexity 256 (640 x 480, 2 x 2 sub-samples x 256 =
1024 samples per pixel), next to the port's time for the same work, and where the time goes.

The scene is the tutorial's ``page4/derived_scene_complexity256.txt`` (from
../shared/tutorial, read in place) or ``--scene``; it is converted in memory with
``codermind convert``'s model (spp = Complexity, full depth, blob max_error from the
footprint). Timed, each as wall-clock and process CPU time (all threads; steadier when other
processes share the machine), medians over ``--runs`` interleaved runs:

* load: scene loading (the blob mesh is built here) and the light scenes;
* first render: JIT compilation of the kernel (or loading it from Dr.Jit's kernel cache in
  ~/.drjit: run twice to see both);
* probes: the auto exposure (256 probe rays);
* render, at ``--complexity`` (default 256: 1024 samples per pixel) and each of
  ``--also`` (default 64: 256 samples per pixel): the ``tutorialpath`` integrator (the
  converter's default: every light with its own shadow ray at every hit, one render, the
  blob intersected analytically: ``tessellate`` false), the same on the blob's mesh with hits
  moved onto the exact surface (``blob_tessellate`` true: what the mesh costs), the same
  with ``exact_hits`` false (the mesh's hits: what the refinement costs), and the
  built-in ``path`` with ``--lights sum`` (one render per light, added: the tutorial's
  all-lights estimate) and ``sample`` (Mitsuba picks one light per hit: the same expectation,
  more noise); the ratios to the original program's time and between the integrators are
  printed, and the mean byte difference of each image from tutorialpath's;
* the port (clean, all cores) at ``--port-complexity`` (default 4), scaled linearly to 256.

``--breakdown`` adds the CPU cost per sample of the scene with parts removed (blob, its
refraction, its bump, the textures, the lens, the lights, depths, blob tessellation, pass
size), with ``tutorialpath`` (and ``path``, one light scene), ``--breakdown-spp`` samples each.

``--only-tutorialpath`` times tutorialpath alone (as converted); ``--vector-width 8``
compiles Dr.Jit's kernels 8 wide without AVX-512, as on an AVX2 host (:func:`llvm_width`;
Embree keeps its own kernels).

A timing: run it on a quiet machine. ``--write-results`` writes the table to
docs/results/integrator.md (section ``speed``, or ``speed-w8`` with ``--vector-width 8``).

    nice python benchmarks/bench_page4_c256.py [--runs 3] [--breakdown] [--complexity 256]
        [--also 64] [--only-tutorialpath] [--vector-width 8] [--write-results [PATH]]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import _results

ROOT = _results.ROOT
SHARED = _results.TUTORIAL / "page4"
#: The original program, Complexity 256 (1024 samples per pixel), one core: measured on this
#: machine class next to `codermind render` (issue 14; facts.md F14.2 says about 148 s).
ORIGINAL_SECONDS = 145.7


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


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def load_text() -> str:
    return "load average %.2f %.2f %.2f" % os.getloadavg()


def timed(fn):
    import drjit as dr
    t, c = time.perf_counter(), cpu()
    out = fn()
    dr.sync_thread()
    return out, time.perf_counter() - t, cpu() - c


def edit(text: str, section: str, key: str, value: str) -> str:
    """Set ``key`` in ``section`` of a tutorial scene text (added if missing)."""
    m = re.search(rf"(^|\n)\s*{section}\s*\{{(?P<body>[^}}]*)\}}", text)
    if not m:
        raise SystemExit(f"no section {section}")
    body = m["body"]
    pattern = rf"(?m)^(\s*){re.escape(key)}\s*=[^;]*;"
    new = re.sub(pattern, lambda k: f"{k[1]}{key} = {value};", body) if re.search(pattern, body) \
        else body + f"\n  {key} = {value};\n"
    return text[:m.start("body")] + new + text[m.end("body"):]


def convert(source: Path, folder: Path, name: str, edits=(), **options) -> Path:
    """Convert ``source`` with ``edits`` ((section, key, value), ...) into ``folder``; the
    cube-map faces are linked next to the edited copy."""
    from codermind.tutorial.convert import convert_scene
    from codermind_ref import parse_scene as parse
    text = source.read_text()
    for section, key, value in edits:
        text = edit(text, section, key, value)
    for face in re.findall(r"Cubemap\.\w+\s*=\s*([^;\s]+\.tga)", text):
        link = folder / face
        if not link.exists() and (source.parent / face).is_file():
            link.parent.mkdir(parents=True, exist_ok=True)
            link.symlink_to((source.parent / face).resolve())
    scene_txt = folder / f"{name}.txt"
    scene_txt.write_text(text)
    xml = folder / f"{name}.xml"
    xml.write_text(convert_scene(parse(scene_txt), xml, **options).xml)
    return xml


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", type=Path, default=SHARED / "derived_scene_complexity256.txt")
    p.add_argument("--complexity", type=int, default=256)
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--port-complexity", type=int, default=4)
    p.add_argument("--also", default="64", help="further Complexities, comma-separated")
    p.add_argument("--lights", default="sum,sample", help="path's light modes")
    p.add_argument("--breakdown", action="store_true")
    p.add_argument("--breakdown-spp", type=int, default=16)
    p.add_argument("--only-tutorialpath", action="store_true",
                   help="time only tutorialpath as converted (no mesh variants, no path)")
    p.add_argument("--vector-width", type=int, choices=(0, 8), default=0,
                   help="0: the host's (16 with AVX-512); 8: as an AVX2 host "
                        "(llvm_width)")
    _results.add_argument(p, "integrator.md")
    args = p.parse_args(argv)
    if not args.scene.is_file():
        print(f"no scene {args.scene} (../shared/tutorial missing?); pass --scene", file=sys.stderr)
        return 1

    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    width = llvm_width(dr, args.vector_width)
    import codermind  # noqa: F401
    from codermind.tutorial import render as tr

    folder = Path(tempfile.mkdtemp(prefix="bench_c256_"))
    print(f"scene {args.scene}, Complexity {args.complexity}, {load_text()}, "
          f"{dr.thread_count()} Dr.Jit threads, LLVM vector width {width}")
    xml = convert(args.scene, folder, "page4", spp=args.complexity)
    xml_path = convert(args.scene, folder, "page4_path", spp=args.complexity, integrator="path")
    model = dict(re.findall(r'<default name="(\w+)" value="([^"]+)"', xml.read_text()))
    print(f"model: {model}")

    (scene, settings), t_load, c_load = timed(lambda: tr.load(xml))
    # the same transport with the blob as a mesh, hits moved onto the exact surface
    (scene_tess, _), t_tess, c_tess = timed(lambda: tr.load(xml, blob_tessellate="true"))
    scene_path, _ = tr.load(xml_path)
    # the same transport on the blob's mesh hits (exact_hits false): the refinement's cost
    tag = '<integrator type="tutorialpath">'
    xml_mesh = folder / "page4_mesh.xml"
    xml_mesh.write_text(re.sub(r'<boolean name="exact_hits" value="\w+"/>', "",
                               xml.read_text()).replace(
        tag, tag + '<boolean name="exact_hits" value="false"/>', 1))
    scene_mesh, _ = tr.load(xml_mesh, blob_tessellate="true")
    lights = [m for m in args.lights.split(",") if m]
    configs = {"tutorialpath": (scene, "sum"), "tutorialpath, blob mesh": (scene_tess, "sum"),
               "tutorialpath, mesh hits": (scene_mesh, "sum")}
    configs.update({f"path, lights={m}": (scene_path, m) for m in lights})
    first = [scene, scene_tess, scene_mesh] + tr.light_scenes(scene_path) + [scene_path]
    if args.only_tutorialpath:
        configs, first = {"tutorialpath": configs["tutorialpath"]}, [scene]
    _, t_first, c_first = timed(lambda: [np.array(mi.render(s, spp=1)) for s in first])
    e, t_probe, c_probe = timed(lambda: tr.probe_exposure(scene, settings, seed=0))
    print(f"load {t_load:.2f} s wall / {c_load:.2f} s CPU (with the blob mesh: {t_tess:.2f} / "
          f"{c_tess:.2f}); first renders (JIT "
          f"compile or cache) {t_first:.2f} / {c_first:.2f}; probes {t_probe:.2f} / "
          f"{c_probe:.2f}; exposure {e:.4f}")

    complexities = [args.complexity] + [int(c) for c in args.also.split(",") if c]
    results = {(c, name): [] for c in complexities for name in configs}
    images = {}
    for run in range(args.runs):
        for c in complexities:
            for name, (sc, mode) in configs.items():
                res, wall, cpu_s = timed(lambda: tr.render(sc, settings, spp=c, seed=run,
                                                           exposure=e, lights=mode))
                results[(c, name)].append((wall, cpu_s))
                images[(c, name)] = res.image.rgb8
                print(f"  run {run + 1} C={c} {name}: {wall:.2f} s wall, {cpu_s:.2f} s CPU, "
                      f"{len(res.pass_times)} passes; {load_text()}", flush=True)

    # the port: the same work at a lower Complexity, scaled
    import codermind_ref as ref
    port_scene = ref.parse_scene(args.scene)
    workers = len(os.sched_getaffinity(0))
    port_times = []
    for run in range(args.runs):
        _, wall, _ = timed(lambda: ref.render(port_scene, mode="clean", seed=run,
                                              complexity=args.port_complexity, workers=workers))
        port_times.append(wall)
    port = statistics.median(port_times)

    print()
    print(f"Page 4, 640x480, medians of {args.runs}; {load_text()}; the original: "
          f"{ORIGINAL_SECONDS} s at Complexity 256 on one core (scaled linearly)")
    table = []
    print(f"{'':28s} {'C':>4s} {'spp/px':>6s} {'wall s':>8s} {'CPU s':>8s} {'vs original':>12s} "
          f"{'vs tutorialpath':>16s} {'|byte diff|':>11s}")
    for c in complexities:
        original = ORIGINAL_SECONDS * c / 256
        base = statistics.median(w for w, _ in results[(c, "tutorialpath")])
        for name in configs:
            wall = statistics.median(w for w, _ in results[(c, name)])
            cs = statistics.median(x for _, x in results[(c, name)])
            diff = np.abs(images[(c, name)].astype(int)
                          - images[(c, "tutorialpath")].astype(int)).mean()
            print(f"{name:28s} {c:4d} {4 * c:6d} {wall:8.2f} {cs:8.2f} {original / wall:11.2f}x "
                  f"{wall / base:15.2f}x {diff:11.3f}")
            table.append([f"`{name}`", c, 4 * c, f"{wall:.1f}", f"{cs:.1f}",
                          f"{original / wall:.2f}x", f"{wall / base:.2f}", f"{diff:.3f}"])
        print(f"{'original program, 1 core':28s} {c:4d} {4 * c:6d} {original:8.2f}")
        p_c = port * c / args.port_complexity
        print(f"{'port (clean, %d workers)' % workers:28s} {c:4d} {4 * c:6d} {p_c:8.2f} "
              f"{'':8s} {original / p_c:11.2f}x   (timed at C={args.port_complexity}, scaled)")
        table.append([f"the port (clean, {workers} workers; timed at C = "
                      f"{args.port_complexity}, scaled)", c, 4 * c, f"{p_c:.1f}", "-",
                      f"{original / p_c:.2f}x", "-", "-"])
        table.append(["the original program, 1 core (scaled from C = 256)", c, 4 * c,
                      f"{original:.1f}", "-", "1", "-", "-"])
    print(f"fixed costs: load {t_load:.2f} s, first renders {t_first:.2f} s, probes {t_probe:.2f} s")

    if args.write_results:
        body = (f"Page 4 at 640 x 480, medians of {args.runs} runs; LLVM vector width {width}, "
                f"{dr.thread_count()} Dr.Jit threads; fixed costs besides: load {t_load:.2f} s, "
                f"first renders (JIT or kernel cache) {t_first:.2f} s, probes {t_probe:.2f} s.\n\n"
                + _results.table(["", "Complexity", "samples per pixel", "wall s", "CPU s",
                                  "speed-up vs the original", "time / tutorialpath",
                                  "mean \\|byte difference\\| from tutorialpath"], table))
        _results.write(args.write_results, body,
                       section="speed" if args.vector_width == 0 else f"speed-w{args.vector_width}")
    if args.breakdown:
        breakdown(args, folder, tr, mi, dr)
    shutil.rmtree(folder, ignore_errors=True)
    return 0


def breakdown(args, folder: Path, tr, mi, dr) -> None:
    """CPU seconds per sample per pixel with parts of the scene removed, per integrator."""
    spp = args.breakdown_spp
    variants = {
        "as converted": ((), {}),
        "no blob": ((("Scene", "NumberOfBlobs", "0"),), {}),
        "blob without refraction": ((("Material3", "Refraction", "0.0"),), {}),
        "blob without bump": ((("Material3", "Bumplevel", "0.0"),), {}),
        "no textures (gouraud)": ((("Material0", "Type", "gouraud"),
                                   ("Material2", "Type", "gouraud")), {}),
        "no lens (Dispersion 0)": ((("Scene", "Perspective.Dispersion", "0.0"),), {}),
        "one light (Light1 off)": ((("Light1", "Intensity", "0.0 0.0 0.0"),), {}),
        "max_depth 2 (1 segment)": ((), {"max_depth": 2}),
        "max_depth 5": ((), {"max_depth": 5}),
        "blob max_error 0.5": ((), {"blob_max_error": 0.5}),
        "blob max_error 0.02": ((), {"blob_max_error": 0.02}),
    }
    for integrator in ("tutorialpath", "path"):
        loaded = {}
        for name, (edits, options) in variants.items():
            xml = convert(args.scene, folder, f"v{len(loaded)}_{integrator}", edits=edits,
                          spp=spp, integrator=integrator, **options)
            scene, _ = tr.load(xml)
            one = tr.light_scenes(scene)[0]     # tutorialpath: the scene (all lights)
            mi.render(one, spp=1)
            dr.sync_thread()
            loaded[name] = one
        costs = {name: [] for name in loaded}
        for run in range(args.runs):
            for name, one in loaded.items():
                _, _, c = timed(lambda: np.array(mi.render(one, spp=spp, seed=run)))
                costs[name].append(c / spp)
        base = statistics.median(costs["as converted"])
        print()
        print(f"Where the time goes, {integrator}"
              + (" (all lights)" if integrator == "tutorialpath" else " (light scene 1 of 2)")
              + f": CPU s per spp (1280x960 film), medians; {load_text()}")
        for name, c in costs.items():
            m = statistics.median(c)
            print(f"  {name:28s} {m:7.3f}  ({m / base:5.2f} of the full scene)")
        one = loaded["as converted"]
        for per in (1, 6, 27, 64):
            if per > spp:
                break
            _, _, c = timed(lambda: [np.array(mi.render(one, spp=per, seed=9 + k))
                                     for k in range(max(1, spp // per))])
            print(f"  passes of {per:3d} spp: {c / (per * max(1, spp // per)):.3f} CPU s per spp")

if __name__ == "__main__":
    sys.exit(main())
