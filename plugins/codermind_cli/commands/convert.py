"""Convert a tutorial scene file (versions 1.0, 1.1 and 1.3: pages 1, 2 and 4) to a readable,
commented Mitsuba XML scene that uses this package's plugins and its tutorialpath integrator
(the tutorial's transport: all lights at every hit; --integrator path: the built-in path
tracer, the same expectation, one light per hit; --quirks strict: the original's quirks).

The model is chosen here and baked into the XML as <default> values (path depth from a bound
of what deeper segments can add against --target; one sample per sub-sample when nothing is
random, else the scene's Complexity; blob tessellation from the pixel footprint); each choice
can be overridden here or at render time (-D max_depth=11). What the XML cannot reproduce
exactly is listed at its top and printed as warnings. `codermind render` then applies the
tutorial's image pipeline."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import outputs
from ..args import positive_float, positive_int, tutorial_scene

NAME = "convert"
HELP = "convert a tutorial scene file to Mitsuba XML"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", metavar="SCENE.txt", help="tutorial scene file")
    p.add_argument("-o", "--output", metavar="SCENE.xml",
                   help="output XML, the name kept whole and .xml appended unless it ends so; "
                        "a folder (or OUT/): the scene's name in it; default: the scene's "
                        "name with .xml, in the current folder")
    p.add_argument("--target", type=positive_float, default=None,
                   help="pixel-error target of the model choice, in 8-bit levels (default 0.5)")
    p.add_argument("--max-depth", type=positive_int, help="Mitsuba max_depth (path depth + 1; the "
                                                 "tutorial's 10 segments: 11) instead of the choice")
    p.add_argument("--spp", type=positive_int, help="samples per sub-sample instead of the choice")
    p.add_argument("--blob-max-error", type=positive_float,
                   help="blob tessellation error in world units instead of the choice")
    p.add_argument("--exposure", type=positive_float,
                   help="page 4: the exposure E to assume in the depth bound (default: traced "
                        "through Mitsuba's probe grid when the bound needs it)")
    p.add_argument("--lights", choices=("sum", "sample"),
                   help="how codermind render adds the lights: 'sum' (default: one render per "
                        "light, as the tutorial sums its lights at every hit) or 'sample' "
                        "(Mitsuba picks one light per hit; a deterministic scene then gets N^2 "
                        "samples, so that the plain mitsuba command is exact too)")
    p.add_argument("--integrator", choices=("tutorialpath", "path"), default="tutorialpath",
                   help="tutorialpath (default: every light with its own shadow ray at every "
                        "hit, one render) or Mitsuba's built-in path (one light per hit)")
    p.add_argument("--quirks", choices=("clean", "strict"), default="clean",
                   help="tutorialpath: clean (default; path's expectation) or strict (the "
                        "original programs' quirks, facts.md F7-F8)")
    p.add_argument("-q", "--quiet", action="store_true", help="print neither model nor notes")


def _command_line(args: argparse.Namespace, scene: Path, out: Path) -> str:
    """How to regenerate the XML; options as NAME=VALUE (an XML comment cannot hold '--')."""
    options = [f"{flag.replace('_', '-')}={getattr(args, flag):g}"
               for flag in ("target", "max_depth", "spp", "blob_max_error", "exposure")
               if getattr(args, flag) is not None]
    if getattr(args, "lights", None):
        options.append(f"lights={args.lights}")
    for flag, default in (("integrator", "tutorialpath"), ("quirks", "clean")):
        if getattr(args, flag, default) != default:
            options.append(f"{flag}={getattr(args, flag)}")
    text = f"codermind convert {scene.name} -o {out.name}"
    return text + (f" with the options {' '.join(options)}" if options else "")


def run(args: argparse.Namespace) -> int:
    from codermind.tutorial.convert import convert_file

    from codermind.errors import CodermindError
    if args.quirks == "strict" and args.integrator == "path":
        raise CodermindError("--quirks strict needs --integrator tutorialpath (path has no "
                             "quirks)")
    if args.lights and args.integrator != "path":
        raise CodermindError("--lights applies to --integrator path (tutorialpath adds every "
                             "light at every hit)")
    scene_path = Path(args.scene)
    base = outputs.output_base(args.output, scene_path, (".xml",))
    out = outputs.check_outputs(base, (".xml",))[0]
    result = convert_file(tutorial_scene(scene_path), out, target=args.target, max_depth=args.max_depth,
                          spp=args.spp, blob_max_error=args.blob_max_error,
                          exposure=args.exposure, lights=args.lights,
                          command=_command_line(args, scene_path, out),
                          integrator=args.integrator, quirks=args.quirks)
    if not args.quiet:
        for w in result.parse_warnings:
            print(f"codermind: warning: {w}", file=sys.stderr)
        for note in result.conversion.notes:
            if note.startswith("The parser reported"):
                continue    # printed above as warnings
            print(f"codermind: note: {note}", file=sys.stderr)
        print(f"wrote {out} (page {result.conversion.settings.page}); model:")
        for line in result.conversion.model.summary():
            print(f"  {line}")
    return 0
