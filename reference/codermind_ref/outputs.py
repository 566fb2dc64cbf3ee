"""Files of a render: ``OUT.tga`` (the original's bytes), ``OUT.png`` (same pixels, display
order), ``OUT.exr`` (linear radiance per sub-sample, float32, display order, 2x resolution on
pages 2 and 4) and ``OUT.variance.exr`` (variance of that mean). Each file is written
atomically."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

from . import exr, png, tga
from .driver import RenderResult


#: The files of a render by kind: the suffix appended to the base name (kept whole).
OUTPUT_SUFFIXES = {"tga": ".tga", "png": ".png", "exr": ".exr", "variance": ".variance.exr"}


def output_paths(base: str | os.PathLike) -> dict[str, Path]:
    base = Path(base)
    return {kind: base.with_name(base.name + suffix) for kind, suffix in OUTPUT_SUFFIXES.items()}


def output_writers(result: RenderResult) -> dict[str, Callable[[Path], None]]:
    """How to write each file, by its suffix after the base name (each write atomic)."""
    return {".tga": lambda path: tga.write(path, result.rgb8_tga),
            ".png": lambda path: png.write(path, result.rgb8),
            ".exr": lambda path: exr.write(path, result.linear),
            ".variance.exr": lambda path: exr.write(path, result.variance)}


def write_outputs(result: RenderResult, base: str | os.PathLike) -> dict[str, Path]:
    """Write the four files next to each other; returns their paths by kind."""
    paths = output_paths(base)
    for path, write in zip(paths.values(), output_writers(result).values()):
        write(path)
    return paths
