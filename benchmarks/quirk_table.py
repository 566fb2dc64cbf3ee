"""How much each quirk that ``clean`` removes changes the 8-bit image of each tutorial scene.

    python benchmarks/quirk_table.py [--seed S] [--complexity N] [--stride K] [--pages 1 2 4]
                                     [--write-results [PATH]]

For each scene, renders strict, strict with one quirk removed (each quirk the page's program
has: page 1 none, page 2 the shadow distance, page 4 all seven), and clean,
all with the same seed (the same random numbers; page 4 auto-exposes per render, as a user
would see it), and prints the mean and max absolute difference of the 8-bit output (all
channels, calibration strip included) from strict, plus the auto exposure. Prints a Markdown
table; ``--write-results`` writes it to docs/results/port.md (section ``quirks``, or
``quirks-cN`` with ``--complexity N``).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

import codermind_ref as ref

import _results

TUTORIAL = _results.TUTORIAL
PAGE = "port.md"
QUIRKS = {
    "shadow_squared": "shadow test to squared distance",
    "coef_squared": "coef^2 on turbulence/marble",
    "cubemap_at_limit": "cube map at the segment limit",
    "inside_retrace": "inside re-trace consumes segments",
    "path_index": "Fresnel index carried along the path",
    "refraction_length": "refracted direction not unit at cosI >= 0.999",
    "blob_float32": "blob bound in float32 (holes)",
}
APPLIES = {1: (), 2: ("shadow_squared",), 4: tuple(QUIRKS)}   # quirks each program has


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--complexity", type=int, help="page 4 rays per sub-sample (default: scene's)")
    parser.add_argument("--stride", type=int, default=1, help="render every K-th pixel")
    parser.add_argument("--pages", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--tutorial", type=Path, default=TUTORIAL)
    _results.add_argument(parser, PAGE)
    args = parser.parse_args(argv)

    lines = ["| scene | quirk removed | mean abs diff | max abs diff | exposure |",
             "| --- | --- | --- | --- | --- |"]
    print("\n".join(lines))

    def emit(line: str) -> None:
        lines.append(line)
        print(line, flush=True)
    for page in args.pages:
        scene = ref.parse_scene(args.tutorial / f"page{page}" / "scene.txt")
        complexity = args.complexity if page == 4 else None
        label = f"page {page}" + (f", C = {complexity or scene.complexity}, seed {args.seed}"
                                 f"{', stride %d' % args.stride if args.stride > 1 else ''}"
                                 if page == 4 else "")

        def run(quirks):
            return ref.render(scene, quirks, seed=args.seed, complexity=complexity,
                              stride=args.stride)

        strict = run(ref.STRICT)
        variants = [(QUIRKS[name], dataclasses.replace(ref.STRICT, **{name: False}))
                    for name in APPLIES[page]] + [("all (clean)", ref.CLEAN)]
        emit(f"| {label} | none (strict) | 0 | 0 | {_exposure(strict)} |")
        for text, quirks in variants:
            result = run(quirks)
            diff = np.abs(result.rgb8.astype(int) - strict.rgb8.astype(int))
            emit(f"| {label} | {text} | {diff.mean():.3f} | {diff.max()} | "
                 f"{_exposure(result)} |")
    if args.write_results:
        section = "quirks" if args.complexity is None else f"quirks-c{args.complexity}"
        _results.write(args.write_results, "\n".join(lines) + "\n", section=section)
    return 0


def _exposure(result) -> str:
    return "-" if result.exposure is None else f"{result.exposure:.4f}"


if __name__ == "__main__":
    sys.exit(main())
