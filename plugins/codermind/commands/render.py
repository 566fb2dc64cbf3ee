"""Render a Mitsuba XML scene (built-in plugins and this package's) to a linear EXR and an
sRGB PNG written side by side, atomically. The samples are rendered in passes with distinct
seeds and accumulated; Ctrl-C stops after the current pass and writes what is done."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

NAME = "render"
HELP = "render a Mitsuba XML scene to EXR + PNG"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", metavar="SCENE.xml", help="Mitsuba XML scene")
    p.add_argument("-o", "--output", metavar="OUT",
                   help="output path without extension (OUT.exr and OUT.png); "
                        "default: the scene's name in the current folder")
    p.add_argument("--spp", type=int, help="samples per pixel (default: the scene's sampler)")
    p.add_argument("--variant", help="Mitsuba variant (default llvm_ad_rgb; scalar_rgb for "
                                     "debugging, cuda_ad_rgb with a GPU)")
    p.add_argument("--seed", type=int, default=0, help="base random seed (default 0)")
    p.add_argument("--pass-spp", type=int, help="samples per pixel per pass (default: from image size)")
    p.add_argument("--deterministic", action="store_true",
                   help="bit-identical output for a given seed: runs Dr.Jit on one thread, since "
                        "parallel film accumulation adds samples in a varying order")


def output_base(scene: Path, output: str | None) -> Path:
    if output is None:
        return Path.cwd() / scene.stem
    out = Path(output)
    return out.with_suffix("") if out.suffix.lower() in (".exr", ".png") else out


def run(args: argparse.Namespace) -> int:
    from ..errors import CodermindError
    scene_path = Path(args.scene)
    if not scene_path.is_file():
        raise CodermindError(f"{scene_path}: no such scene file")
    for name in ("spp", "pass_spp"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise CodermindError(f"--{name.replace('_', '-')}: must be >= 1, got {value}")
    if not 0 <= args.seed < 2**32:
        raise CodermindError(f"--seed: must be in [0, 2^32), got {args.seed}")

    from ..variants import set_variant
    set_variant(args.variant)
    from ..scene import load_scene
    from ..render import Progress, render_passes, scene_spp
    from ..imageio import write_exr, write_png_srgb

    scene = load_scene(scene_path)
    if not scene.sensors():
        raise CodermindError(f"{scene_path}: the scene has no sensor to render from")
    if scene.integrator() is None:
        raise CodermindError(f"{scene_path}: the scene has no integrator")
    import drjit as dr
    threads = dr.thread_count()
    if args.deterministic:
        # Only around rendering: Mitsuba's scene loading and EXR writing wait on tasks of
        # the same pool and deadlock when it has a single thread.
        dr.set_thread_count(1)
    spp = args.spp or scene_spp(scene)
    base = output_base(scene_path, args.output)

    stop = {"requested": False}

    def on_sigint(signum, frame):
        if stop["requested"]:
            raise KeyboardInterrupt
        stop["requested"] = True
        print("\ncodermind: Ctrl-C: stopping after the current pass (again to abort without "
              "writing)", file=sys.stderr, flush=True)

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        result = render_passes(scene, spp=spp, seed=args.seed, pass_spp=args.pass_spp,
                               progress=Progress(spp, label=scene_path.name),
                               should_stop=lambda: stop["requested"])
    except RuntimeError as e:   # e.g. a plugin rejecting its input at render time
        raise CodermindError(f"{scene_path}: rendering failed: {e}") from None
    finally:
        signal.signal(signal.SIGINT, previous)
        dr.set_thread_count(threads)

    if result.spp == 0:
        print("codermind: interrupted before the first pass finished; nothing written",
              file=sys.stderr)
        return 130
    exr, png = base.with_suffix(".exr"), base.with_suffix(".png")
    write_exr(exr, result.image, result.channel_names)
    write_png_srgb(png, result.image)
    if result.interrupted:
        print(f"codermind: interrupted: wrote the {result.spp} of {result.spp_requested} spp "
              f"finished to {exr} and {png}", file=sys.stderr)
        return 130
    print(f"wrote {exr} and {png} ({result.spp} spp, {result.seconds:.2f} s)")
    return 0
