"""The converter's finite-value check of a parsed tutorial scene: every number it writes into
the XML must be finite in float32, the plugins' rule (:func:`codermind.params.check_float`),
so that a bad value is refused with the scene file and line (``FILE:LINE:
Light0.Position: must be finite in float32, got nan, 240, -100``) instead of by a plugin at
load time, without either. The converter's own check: the port's parser has its own
(``codermind_ref.checks``), and neither side imports the other's."""

from __future__ import annotations

import math

from ..errors import CodermindError
from ..params import FLOAT32_MAX


def scene_values(scene):
    """(section, key, value) of every number of the scene (tuples for colours and points)."""
    for m in scene.materials:
        sec = f"Material{m.index}"
        for key in ("Diffuse", "Reflection", "Specular", "Power", "Diffuse2", "Bumplevel",
                    "Density", "Refraction"):
            attr = key.lower()
            if hasattr(m, attr):
                yield sec, key, getattr(m, attr)
    for s in scene.spheres:
        yield f"Sphere{s.index}", "Center", s.center
        yield f"Sphere{s.index}", "Size", s.size
    for b in getattr(scene, "blobs", []):
        for k, c in enumerate(b.centers):
            yield f"Blob{b.index}", f"Center{k}", c
        yield f"Blob{b.index}", "Size", b.size
    for light in scene.lights:
        yield f"Light{light.index}", "Position", light.position
        yield f"Light{light.index}", "Intensity", light.intensity
    if scene.page == 4:
        cam, tm = scene.camera, scene.tonemap
        yield "Scene", "Perspective.FOV", cam.fov
        yield "Scene", "Perspective.ClearPoint", cam.clear_point
        yield "Scene", "Perspective.Dispersion", cam.dispersion
        yield "Scene", "Tonemap.Midpoint", tm.midpoint
        yield "Scene", "Tonemap.Power", tm.power
        yield "Scene", "Tonemap.Black", tm.black
        yield "Scene", "Cubemap.Exposure", scene.cubemap.exposure


def check_finite(scene) -> None:
    """CodermindError ``FILE:LINE: Section.Key: must be finite in float32, got ...`` at the
    first number that is NaN, infinite or beyond the float32 range."""
    for section, key, value in scene_values(scene):
        items = tuple(value) if isinstance(value, (tuple, list)) else (value,)
        if all(math.isfinite(float(v)) and abs(float(v)) <= FLOAT32_MAX for v in items):
            continue
        label = key if section == "Scene" else f"{section}.{key}"
        text = ", ".join(f"{float(v):g}" for v in items)
        raise CodermindError(f"{scene.path}:{scene.line_of(section, key)}: {label}: must be "
                             f"finite in float32, got {text}")
