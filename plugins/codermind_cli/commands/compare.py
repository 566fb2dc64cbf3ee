"""Render tutorial scenes with the Mitsuba plugins (the converted XML through its
integrator, the converter's `tutorialpath`) and with the standalone port in clean mode, at the
same sub-sample positions and sample counts (a random scene's Mitsuba side with the
`independent` sampler, as the port's rays are independent; a scene without randomness's port
side with either sphere where a ray meets two at exactly the same distance), and compare them: a two-sample z-test per sub-sample and channel
of the linear radiance (Sidak-corrected alpha 0.01; pixels without noise on either side must
agree within rtol 1e-3 + atol 1e-4), mean FLIP on the displayed images at the same exposure,
relative MSE. On page 4 the two sides' own auto exposures (each side's probe grid, over 8
seeds by default) are compared by Welch's t-test (alpha 0.001), whatever exposure the images
use. Writes OUT/compare.json, OUT/compare.txt (the tables, also printed) and
OUT/SCENE.compare.png (images, FLIP map, |z| map; SCENE is the file's stem, prefixed with its
folder where two scenes share it). Exit status 0 when every scene passes (pass rate >= 0.99,
mean FLIP <= 0.01 and the exposure test by default), 1 when one fails, 2 on bad input.

SCENE is a tutorial scene file (.txt: converted with the full model into
OUT/SCENE.mitsuba.xml) or a converted
Mitsuba XML (.xml: rendered as it is, against the scene file its converter header names, or
the .txt of the same name next to it).

--reference IMAGE compares the Mitsuba side with a render made elsewhere instead of the port:
a .tga/.png on the displayed bytes, an .exr on the linear film; exactly for scenes without
randomness (bytes within one level, or the float tolerance, on >= the pass rate), else a
Gaussian-blurred difference and a mean difference against the noise floor of our side with
two seeds (see docs/harness.md).

Any other Mitsuba XML (an ordinary scene, no tutorial twin) is compared with another render
of it: --against OTHER.xml (both rendered here, with the same -D defines and samples) or
--reference IMAGE.exr (with IMAGE.variance.exr next to it or --reference-variance FILE, the
variance of each pixel's mean; without one the reference is taken to be as noisy as our
side). Each render's per-pixel variance comes from >= 16 passes; the tests are the per-pixel
two-sample z-test (pass rate, and no |z| beyond twice its Sidak bound), the pooled
difference over 16 x 16 tiles, objects and the whole image, and FLIP against SCENE's own
noise floor (SCENE again with another seed)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..args import define, fraction, level, positive_float, positive_int, rect, seed
from ..limits import worker_count

NAME = "compare"
HELP = ("compare the Mitsuba plugins with the port on tutorial scenes, or any Mitsuba scene "
        "with another render of it (z-test, pooled tests, FLIP, relMSE, auto exposure)")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenes", nargs="+", metavar="SCENE",
                   help="tutorial scene .txt or converted .xml; any other Mitsuba .xml with "
                        "--against or --reference")
    p.add_argument("-o", "--output", metavar="DIR", default="compare",
                   help="output folder (default ./compare)")
    p.add_argument("--spp", type=positive_int, metavar="N",
                   help="samples per sub-sample on both sides (port Complexity = Mitsuba spp); "
                        "default 1 for scenes without randomness, else the scene's Complexity, "
                        "at least 64 (FLIP needs the noise of both sides below its threshold); "
                        "an ordinary scene: its sampler's count, at least 32")
    p.add_argument("--seed", type=seed, default=0, help="seed of both sides (default 0)")
    p.add_argument("--stride", type=positive_int, default=1, metavar="K",
                   help="compare every K-th pixel in x and y (faster for the port; an "
                        "ordinary scene renders the whole --rect; default 1)")
    p.add_argument("--rect", type=rect, metavar="x0,y0,x1,y1",
                   help="compare only these pixels (half-open, tutorial coordinates, y up; "
                        "an ordinary scene: film pixels, y up from the bottom row)")
    p.add_argument("--exposure", type=positive_float, metavar="E",
                   help="exposure of both sides (default: page 4 the port's auto exposure for "
                        "the seed, page 2: 1)")
    p.add_argument("--blob-max-error", type=positive_float, metavar="E",
                   help="blob tessellation error in world units (default: the converter's)")
    p.add_argument("--port-mode", choices=("clean", "strict"), default="clean",
                   help="port mode (default clean, which Mitsuba reproduces; strict shows the "
                        "quirks the test detects)")
    p.add_argument("--quirks", choices=("clean", "strict"), default="clean",
                   help="strict: the Mitsuba side's tutorialpath integrator with the original's "
                        "quirks against the port in strict mode (default clean: both clean)")
    p.add_argument("-D", "--define", metavar="NAME=VALUE", type=define, action="append", default=[],
                   help="XML <default> override on the Mitsuba side (both scenes with "
                        "--against), e.g. -D max_depth=5")
    p.add_argument("--min-pass-rate", type=fraction, default=0.99, metavar="R",
                   help="smallest z-test pass rate (default 0.99)")
    p.add_argument("--max-flip", type=fraction, default=0.01, metavar="F",
                   help="largest mean FLIP (default 0.01)")
    p.add_argument("--exposure-seeds", type=positive_int, default=8, metavar="N",
                   help="page 4: auto exposures per side for the exposure test, seeds SEED.."
                        "SEED+N-1 (default 8)")
    p.add_argument("--exposure-alpha", type=level, default=0.001, metavar="A",
                   help="level of the exposure test (Welch's t, two-sided; default 0.001)")
    p.add_argument("--noise-floor", action="store_true",
                   help="also render the port with seed + 1 and report FLIP and the z-test of "
                        "the port against itself (noise alone), to tell noise from disagreement")
    p.add_argument("--reference", metavar="IMAGE",
                   help="compare the Mitsuba side with this render (.tga or .png: the displayed "
                        "image; .exr: the linear film, as codermind render writes them) instead "
                        "of the port; one SCENE. Scenes without randomness must agree exactly "
                        "(bytes within one level, or the float tolerance), random ones "
                        "statistically against our side's noise floor (default --spp: the "
                        "scene's Complexity, the sample count the reference must have). An "
                        "ordinary Mitsuba scene takes an .exr of its film")
    p.add_argument("--reference-variance", metavar="FILE",
                   help="ordinary scene: the variance of each reference pixel's mean (.exr; "
                        "default IMAGE.variance.exr next to the reference, as codermind render "
                        "--variance writes it; without one the reference is taken to be as "
                        "noisy as our side)")
    p.add_argument("--against", metavar="OTHER.xml",
                   help="compare SCENE (any Mitsuba XML) with OTHER, the same scene rendered "
                        "another way (another integrator, a built-in stand-in, an edited copy): "
                        "both rendered here in passes, their per-pixel variances estimated; one "
                        "SCENE")
    p.add_argument("--workers", type=worker_count, metavar="N", help="port worker processes")
    p.add_argument("--variant", help="Mitsuba variant (default llvm_ad_rgb)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    p.add_argument("--cluster", metavar="ADDRESS",
                   help="run on a Dask cluster: tcp://HOST:PORT (a `dask scheduler`) or local:N "
                        "(N worker processes here); default: this machine")
    p.add_argument("--allow-files", metavar="DIR", action="append", default=[],
                   help="with --cluster: files the scene names (cube-map faces) travel to the "
                        "workers only from each SCENE's folder; this allows DIR too (repeatable)")


def run(args: argparse.Namespace) -> int:
    from codermind.errors import CodermindError
    from codermind_harness.cluster import open_runner
    from codermind_harness.compare import Options, Thresholds, format_table, run as compare
    from codermind_harness.sides import HarnessError

    defines = dict(args.define)
    if args.quirks == "strict" and args.port_mode != "clean":
        raise CodermindError("--quirks strict sets the port's mode (strict): drop --port-mode")
    if "spp" in defines:
        raise CodermindError("-D spp=...: use --spp (it sets both sides)")
    if args.against is not None:
        if len(args.scenes) != 1:
            raise CodermindError(f"--against {args.against}: give one SCENE, got "
                                 f"{len(args.scenes)}")
        if args.reference is not None:
            raise CodermindError("--against and --reference: give one other side")
    if args.reference_variance is not None and args.reference is None:
        raise CodermindError("--reference-variance: give it with --reference IMAGE.exr")
    if args.reference is not None:
        if len(args.scenes) != 1:
            raise CodermindError(f"--reference {args.reference}: give one SCENE, got "
                                 f"{len(args.scenes)}")
        if args.noise_floor:
            raise CodermindError("--noise-floor renders the port, which --reference replaces "
                                 "(the noise floor is then our side with seed + 1)")
    opt = Options(spp=args.spp, seed=args.seed, rect=args.rect, stride=args.stride,
                  exposure=args.exposure, blob_max_error=args.blob_max_error,
                  port_mode="strict" if args.quirks == "strict" else args.port_mode,
                  quirks=args.quirks, out_dir=Path(args.output), defines=defines,
                  thresholds=Thresholds(args.min_pass_rate, args.max_flip,
                                        exposure_alpha=args.exposure_alpha),
                  progress=not args.quiet, workers=args.workers,
                  noise_floor=args.noise_floor, exposure_seeds=args.exposure_seeds,
                  reference=None if args.reference is None else Path(args.reference),
                  against=None if args.against is None else Path(args.against),
                  reference_variance=(None if args.reference_variance is None
                                      else Path(args.reference_variance)))
    try:
        allow = [Path(s).parent for s in args.scenes] + args.allow_files
        with open_runner(args.cluster, progress=not args.quiet, allow=allow) as runner:
            records, status = compare(args.scenes, opt, args.variant, runner)
    except HarnessError as e:
        raise CodermindError(str(e)) from None
    except OSError as e:        # the output folder or a file in it cannot be written
        raise CodermindError(f"{e.filename or opt.out_dir}: {e.strerror or e}") from None
    print(format_table(records))
    for r in records:
        if r["failures"]:
            print(f"{r['label']}: FAIL: {'; '.join(r['failures'])}")
    print(f"wrote {opt.out_dir / 'compare.json'}, {opt.out_dir / 'compare.txt'} and "
          f"{len(records)} heat map{'s' if len(records) != 1 else ''} "
          f"({', '.join(Path(r['heatmap']).name for r in records)})")
    return status
