"""Render a tutorial scene file (versions 1.0, 1.1, 1.3) with the standalone numpy port of the
tutorial programs, writing OUT.tga (the original's bytes), OUT.png, OUT.exr (linear radiance
per sub-sample, float32) and OUT.variance.exr (variance of that mean over the Complexity rays),
replaced as a set with OUT.manifest.json (:mod:`codermind_cli.outputs`).
--mode strict reproduces the original programs, quirks included; clean removes the quirks that
are plain bugs (see README). Scene errors print one line "file:line: message" and exit 2."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from .. import limits, outputs, signals
from ..args import positive_float, positive_int, seed, tutorial_scene
from ..limits import worker_count

NAME = "reference"
HELP = "render a tutorial scene.txt with the standalone port (TGA, PNG, EXR)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", metavar="SCENE.txt", help="tutorial scene file")
    p.add_argument("-o", "--output", metavar="OUT",
                   help="output name, kept whole: OUT.tga, OUT.png, OUT.exr, "
                        "OUT.variance.exr, OUT.manifest.json; a trailing .tga/.png/.exr is "
                        "dropped; a folder (or OUT/): the scene's name in it; default: the "
                        "scene's name here")
    p.add_argument("--mode", choices=("strict", "clean"), default="strict",
                   help="strict: the original programs (default); clean: quirks removed")
    p.add_argument("--seed", type=seed, default=0, help="random seed (page 4; default 0)")
    p.add_argument("--complexity", type=positive_int, metavar="N",
                   help="rays per sub-sample (page 4; default: the scene's Complexity)")
    p.add_argument("--exposure", type=positive_float, metavar="E",
                   help="fixed exposure instead of the page-4 auto exposure (page 2: default 1)")
    p.add_argument("--workers", type=worker_count, metavar="N",
                   help="worker processes (default: one per core for large renders); "
                        "the image does not depend on it")
    p.add_argument("--cluster", metavar="ADDRESS",
                   help="run on a Dask cluster: tcp://HOST:PORT (a `dask scheduler`) or local:N "
                        "(N worker processes here); default: this machine")
    p.add_argument("--allow-files", metavar="DIR", action="append", default=[],
                   help="with --cluster: files the scene names (cube-map faces) travel to the "
                        "workers only from the scene's folder; this allows DIR too (repeatable)")
    limits.add_max_memory(p)

def run(args: argparse.Namespace) -> int:
    from codermind.errors import CodermindError
    import codermind_ref as ref
    from codermind_harness.progress import PortProgress

    scene_path = Path(args.scene)
    scene = tutorial_scene(scene_path)
    for warning in scene.warnings:
        print(f"codermind: warning: {warning}", file=sys.stderr)
    base = outputs.output_base(args.output, scene_path)
    outputs.check_outputs(base, [*ref.OUTPUT_SUFFIXES.values(), outputs.MANIFEST])
    from ..limits import check_reference
    check_reference(scene_path, scene, args.complexity, args.workers, args.max_memory)
    from codermind_harness.cluster import open_runner
    with contextlib.ExitStack() as stack:     # tiles of rows as units; same image
        with signals.spared_children():
            runner = stack.enter_context(open_runner(args.cluster, allow=args.allow_files))
        result = ref.render(scene, args.mode, args.seed, args.complexity,
                            exposure=args.exposure, workers=args.workers,
                            progress=None if runner.remote else PortProgress(scene_path.name),
                            tile_map=runner.tile_map,
                            # this process has imported Mitsuba: fork would copy Dr.Jit's
                            # pool locked, and a worker could hang
                            start_method="forkserver")
    for warning in result.warnings[len(scene.warnings):]:     # found while rendering
        print(f"codermind: warning: {warning}", file=sys.stderr)
    try:
        paths = outputs.write_set(base, ref.output_writers(result))
    except OSError as e:
        raise CodermindError(f"{e.filename or base}: cannot write: {e.strerror or e}") from None
    exposure = "" if result.exposure is None else f", exposure {result.exposure:.6g}"
    print(f"wrote {', '.join(str(p) for p in paths)} ({result.mode}, page "
          f"{scene.page}, seed {result.seed}, complexity {result.complexity}{exposure}, "
          f"{result.seconds:.2f} s)")
    return 0
