"""Standalone numpy port of the Codermind ray-tracing tutorial (pages 1, 2 and 4).

The reference that the Mitsuba plugins are checked against; it uses numpy and the standard
library only and never imports mitsuba, drjit or ``codermind``.

>>> import codermind_ref as ref
>>> scene = ref.parse_scene("page4/scene.txt")      # raises ref.SceneError("file:line: ...")
>>> result = ref.render(scene, mode="clean", seed=1, complexity=16)
>>> result.rgb8            # uint8 (H, W, 3), display order; result.rgb8_tga: TGA row order
>>> result.linear          # float32 (2H, 2W, 3) radiance per sub-sample; result.variance
>>> ref.write_outputs(result, "out")   # out.tga, out.png, out.exr, out.variance.exr

Modules, one concept each: ``syntax`` (comments, sections, keys with lines), ``cnumbers``
(atof/atol/sscanf reading), ``scene`` (dataclasses, ``parse_scene``), ``tga`` / ``png`` /
``exr`` / ``files`` (image files, atomic writes), ``vec``, ``camera``, ``sphere``, ``blob``
(zone method), ``perlin``, ``materials`` (colours, bump), ``cubemap``, ``world`` (objects),
``shading`` (lights), ``transport`` (paths, Fresnel, roulette), ``quirks`` (strict vs clean),
``rng`` (random streams and draw order), ``tonemap`` (exposure, tone curve, sRGB, bytes),
``driver`` (render: tiles, workers, result), ``outputs``.
"""

from .errors import SceneError
from .outputs import OUTPUT_SUFFIXES, output_paths, output_writers, write_outputs
from .quirks import CLEAN, STRICT, Quirks
from .driver import RenderResult, render
from .scene import Scene, parse_scene

__all__ = ["SceneError", "Scene", "parse_scene", "render", "RenderResult", "Quirks", "STRICT",
           "CLEAN", "write_outputs", "output_paths",
           "output_writers", "OUTPUT_SUFFIXES"]
