"""Render a Mitsuba XML scene (built-in plugins and this package's) to a linear EXR and an
sRGB PNG written side by side, replaced as a set with OUT.manifest.json
(:mod:`codermind_cli.outputs`). The samples are rendered in passes with distinct seeds and
accumulated (a film of more than ``codermind.passes.TILE_BUDGET`` pixels tile by tile within
each pass, in bounded memory); Ctrl-C or SIGTERM stops after the current pass and writes
what is done.

A scene converted from a tutorial scene file (`codermind convert`; it carries a
codermind-tutorial comment block) goes through the tutorial's image pipeline instead: the
PNG and TGA hold the tutorial's bytes (exposure, tone curve per sub-sample, sRGB, 2x2 mean,
calibration strip), the EXR the linear film of sub-samples (2W x 2H on pages 2 and 4)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import limits, outputs, signals
from ..args import define, exposure as exposure_option, positive_int, seed

NAME = "render"
HELP = "render a Mitsuba XML scene to EXR + PNG"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", metavar="SCENE.xml", help="Mitsuba XML scene, or the name of a "
                   "bundled scene (page1 .. page4, garden) when no such file exists here")
    p.add_argument("-o", "--output", metavar="OUT",
                   help="output name, kept whole: OUT.exr, OUT.png (+ OUT.tga, "
                        "OUT.manifest.json); a trailing .exr/.png/.tga is dropped; a folder "
                        "(or OUT/): the scene's name in it; default: the scene's name here")
    p.add_argument("--spp", type=positive_int, help="samples per pixel (default: the scene's sampler)")
    p.add_argument("--variant", help="Mitsuba variant (default llvm_ad_rgb; scalar_rgb for "
                                     "debugging, cuda_ad_rgb with a GPU)")
    p.add_argument("--seed", type=seed, default=0, help="base random seed (default 0)")
    p.add_argument("--pass-spp", type=positive_int, help="samples per pixel per pass (default: from image size)")
    p.add_argument("-D", "--define", metavar="NAME=VALUE", type=define, action="append",
                   default=[],
                   help="set an XML <default> parameter, e.g. -D max_depth=11 -D spp=4 "
                        "(repeatable)")
    p.add_argument("--exposure", metavar="probes|render|E", type=exposure_option, default="probes",
                   help="tutorial scenes, page 4: auto exposure from the probe grid traced "
                        "through Mitsuba (default, as the tutorial), from the render's own "
                        "sub-samples, or a fixed E (also page 2)")
    p.add_argument("--lights", choices=("sum", "sample"),
                   help="tutorial scenes: 'sum' renders once per light and adds (the "
                        "tutorial sums its lights at every hit), 'sample' lets Mitsuba pick "
                        "one light per hit (faster, noisier); default: the scene's block")
    p.add_argument("--variance", action="store_true",
                   help="also write OUT.variance.exr, the variance of each film pixel's mean "
                        "(tutorial scenes: each sub-sample's), estimated from >= 16 passes "
                        "(the reference variance codermind compare reads next to OUT.exr); an "
                        "ordinary scene's OUT.exr then holds RGB")
    p.add_argument("--plain", action="store_true",
                   help="ignore a codermind-tutorial block: plain EXR + sRGB PNG")
    p.add_argument("--deterministic", action="store_true",
                   help="bit-identical output for a given seed: runs Dr.Jit on one thread, since "
                        "parallel film accumulation adds samples in a varying order")
    limits.add_max_memory(p)


#: Every file a render may write, checked before it starts.
SUFFIXES = (".exr", ".png", ".tga", ".variance.exr", outputs.MANIFEST)


def run(args: argparse.Namespace) -> int:
    from codermind.errors import CodermindError, raised_inside
    scene_path = Path(args.scene)
    if not scene_path.is_file():
        from codermind.bundled import bundled_scene
        scene_path = bundled_scene(args.scene) or scene_path
    if not scene_path.is_file():
        raise CodermindError(f"{scene_path}: no such scene file")

    base = outputs.output_base(args.output, scene_path)
    outputs.check_outputs(base, SUFFIXES)
    defines = dict(args.define)
    from codermind.tutorial.render import read_settings
    settings = None if args.plain else read_settings(scene_path)

    from codermind.variants import set_variant
    set_variant(args.variant)
    from codermind.scene import load_scene
    from codermind.passes import Progress, render_passes, scene_spp
    from codermind.imageio import write_exr, write_png_srgb

    scene = load_scene(scene_path, **defines)
    if not scene.sensors():
        raise CodermindError(f"{scene_path}: the scene has no sensor to render from")
    if scene.integrator() is None:
        raise CodermindError(f"{scene_path}: the scene has no integrator")
    from codermind.scene import non_finite_parameters
    bad = non_finite_parameters(scene)
    if bad:
        raise CodermindError(f"{scene_path}: not finite: {', '.join(bad[:3])}"
                             f"{' ...' if len(bad) > 3 else ''}; nothing was rendered")
    import drjit as dr
    threads = dr.thread_count()
    if args.deterministic:
        # Only around rendering: Mitsuba's scene loading and EXR writing wait on tasks of
        # the same pool and deadlock when it has a single thread.
        dr.set_thread_count(1)
    spp = args.spp or scene_spp(scene)
    from ..limits import check_render
    check_render(scene_path, *scene.sensors()[0].film().crop_size(), spp, pass_spp=args.pass_spp,
                 max_memory=args.max_memory, variance=settings is not None and args.variance)

    if settings is not None:
        from codermind.tutorial import render as tutorial_render
        tutorial_render.check_film(scene, settings, scene_path)
    with signals.stop_requests() as should_stop:    # SIGINT, SIGTERM: after this pass
        try:
            if settings is not None:
                result = tutorial_render.render(
                    scene, settings, spp=spp, seed=args.seed, exposure=args.exposure,
                    lights=args.lights, pass_spp=args.pass_spp, variance=args.variance,
                    progress=Progress(spp, label=scene_path.name),
                    should_stop=should_stop)
            elif args.variance:
                result = _plain_with_variance(scene, spp, args.seed, args.pass_spp,
                                              Progress(spp, label=scene_path.name), should_stop)
            else:
                result = render_passes(scene, spp=spp, seed=args.seed, pass_spp=args.pass_spp,
                                       progress=Progress(spp, label=scene_path.name),
                                       should_stop=should_stop)
        except (RuntimeError, ValueError) as e:   # e.g. a plugin rejecting its scene
            cause = raised_inside(e)
            if not isinstance(cause, (RuntimeError, ValueError)):
                raise cause from None                 # a defect, not the user's: its traceback
            raise CodermindError(f"{scene_path}: rendering failed: {cause}") from None
        finally:
            dr.set_thread_count(threads)

    if settings is not None:
        return _finish_tutorial(result, base)

    if result.spp == 0:
        print("codermind: interrupted before the first pass finished; nothing written",
              file=sys.stderr)
        return 130
    _warn_non_finite(scene_path, result.image)
    exr, png = outputs.write_set(base, {
        ".exr": lambda path: write_exr(path, result.image, result.channel_names),
        ".png": lambda path: write_png_srgb(path, result.image),
        **_variance_writer(result)})[:2]
    if result.interrupted:
        print(f"codermind: interrupted ({signals.describe(signals.received())}): wrote the "
              f"{result.spp} of {result.spp_requested} spp finished to {exr} and {png}",
              file=sys.stderr)
        return 130
    also = "" if getattr(result, "variance", None) is None else \
        f", {base.parent / (base.name + '.variance.exr')}"
    print(f"wrote {exr}{also} and {png} ({result.spp} spp, {result.seconds:.2f} s)")
    return 0


def _variance_writer(result) -> dict:
    """``{".variance.exr": writer}`` where the render estimated its variance, else {}."""
    if getattr(result, "variance", None) is None:
        return {}
    from codermind.imageio import write_exr
    return {".variance.exr": lambda path: write_exr(path, result.variance)}


def _plain_with_variance(scene, spp: int, seed: int, pass_spp: int | None, progress,
                         should_stop):
    """An ordinary scene's RGB film and the variance of each pixel's mean from >= 16 pass
    means (``codermind.tutorial.render.render_linear``, which compare's renders use too), as
    a ``RenderResult`` with a ``variance`` attribute."""
    import time
    from codermind.passes import RenderResult
    from codermind.tutorial.render import render_linear
    t0 = time.perf_counter()
    mean, var, done, times = render_linear(scene, spp, seed, pass_spp, variance=True,
                                           progress=progress, should_stop=should_stop)
    if mean is None:
        mean = var = None
    result = RenderResult(mean if done else None, ["R", "G", "B"], done, spp,
                          time.perf_counter() - t0, times)
    result.variance = var if done else None
    return result


def _finish_tutorial(result, base: Path) -> int:
    from codermind.tutorial.render import output_writers
    if result is None:
        print("codermind: interrupted before the first pass finished; nothing written",
              file=sys.stderr)
        return 130
    _warn_non_finite(base, result.linear)
    paths = outputs.write_set(base, output_writers(result))
    names = ", ".join(str(p) for p in paths)
    exposure = "" if result.exposure is None else \
        f", exposure {result.exposure:.6g} ({result.exposure_source})"
    if result.interrupted:
        print(f"codermind: interrupted ({signals.describe(signals.received())}): wrote the "
              f"{result.spp} of {result.spp_requested} spp finished to {names}",
              file=sys.stderr)
        return 130
    print(f"wrote {names} (page-{result.settings.page} program, {result.spp} spp{exposure}, "
          f"{result.seconds:.2f} s)")
    return 0


def _warn_non_finite(source, image) -> None:
    """One warning line when the rendered film holds NaN or infinite values."""
    import numpy as np
    bad = int(np.count_nonzero(~np.isfinite(image)))
    if bad:
        print(f"codermind: warning: {source}: {bad} of {image.size} film values are not finite "
              "(NaN or infinite); they are written as they are", file=sys.stderr)
