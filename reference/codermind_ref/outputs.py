"""Files of a render: ``OUT.tga`` (the original's bytes), ``OUT.png`` (same pixels, display
order), ``OUT.exr`` (linear radiance per sub-sample, float32, display order, 2x resolution on
pages 2 and 4) and ``OUT.variance.exr`` (variance of that mean). Each file is written
atomically."""

from __future__ import annotations

import os
from pathlib import Path

from . import exr, png, tga
from .driver import RenderResult


def output_paths(base: str | os.PathLike) -> dict[str, Path]:
    base = Path(base)
    return {"tga": base.with_name(base.name + ".tga"), "png": base.with_name(base.name + ".png"),
            "exr": base.with_name(base.name + ".exr"),
            "variance": base.with_name(base.name + ".variance.exr")}


def write_outputs(result: RenderResult, base: str | os.PathLike) -> dict[str, Path]:
    """Write the four files next to each other; returns their paths by kind."""
    paths = output_paths(base)
    tga.write(paths["tga"], result.rgb8_tga)
    png.write(paths["png"], result.rgb8)
    exr.write(paths["exr"], result.linear)
    exr.write(paths["variance"], result.variance)
    return paths
