"""Finite values and the plugins' ranges, checked on a parsed scene (called by
:func:`codermind_ref.parse_scene`; the port's own module: it imports nothing of the plugins).

**Errors.** Every number the programs compute with must be finite in float32 (the original
reads each one with ``atof`` into a C ``float``: ``nan``, ``inf`` and anything beyond
3.4028235e38 become NaN or infinity there). A non-finite light position, colour, reflection
... makes the original's result undefined (NaN reaches its float -> byte conversions), so
there is nothing faithful to reproduce: :class:`SceneError`, ``FILE:LINE: Light0.Position:
must be finite, got nan``.

**Warnings.** A finite value outside the range the Mitsuba plugins accept (a ``Reflection``
of 2, a negative colour, ...) is what the original renders, so the port renders it too (in
both modes) and says, in one warning line with file and line, that ``codermind convert``
refuses it.
"""

from __future__ import annotations

import math

from .errors import SceneError

#: Largest finite float32: the original's ``float``.
FLOAT32_MAX = 3.4028234663852886e38


def _finite(value: float) -> bool:
    return math.isfinite(value) and abs(value) <= FLOAT32_MAX


def _text(value) -> str:
    if isinstance(value, tuple):
        return ", ".join(f"{v:g}" for v in value)
    return f"{value:g}"


def _values(scene):
    """(section name, key, value) of every number the scene holds (tuples for colours and
    points), in file order of sections."""
    for m in scene.materials:
        name = f"Material{m.index}"
        yield name, "Diffuse", m.diffuse
        yield name, "Reflection", m.reflection
        if scene.page >= 2:
            yield name, "Specular", m.specular
            yield name, "Power", m.power
        if scene.page >= 4:
            yield name, "Diffuse2", m.diffuse2
            yield name, "Bumplevel", m.bumplevel
            yield name, "Density", m.density
            yield name, "Refraction", m.refraction
    for s in scene.spheres:
        yield f"Sphere{s.index}", "Center", s.center
        yield f"Sphere{s.index}", "Size", s.size
    for b in scene.blobs:
        for k, c in enumerate(b.centers):
            yield f"Blob{b.index}", f"Center{k}", c
        yield f"Blob{b.index}", "Size", b.size
    for light in scene.lights:
        yield f"Light{light.index}", "Position", light.position
        yield f"Light{light.index}", "Intensity", light.intensity
    if scene.page == 4:
        cam, tm = scene.camera, scene.tonemap
        for key, value in (("Perspective.FOV", cam.fov), ("Perspective.ClearPoint", cam.clear_point),
                           ("Perspective.Dispersion", cam.dispersion),
                           ("Tonemap.Midpoint", tm.midpoint), ("Tonemap.Power", tm.power),
                           ("Tonemap.Black", tm.black), ("Cubemap.Exposure", scene.cubemap.exposure)):
            yield "Scene", key, value


def check_finite(scene) -> None:
    """SceneError at the first value that is not finite in float32 (see the module doc)."""
    for section, key, value in _values(scene):
        items = value if isinstance(value, tuple) else (value,)
        bad = next((v for v in items if not _finite(v)), None)
        if bad is not None:
            label = key if section == "Scene" else f"{section}.{key}"
            extra = "" if not math.isfinite(bad) else " in float32 (the original's float)"
            raise SceneError(scene.path, scene.line_of(section, key),
                             f"{label}: must be finite{extra}, got {_text(value)}")


def range_warnings(scene) -> list[str]:
    """One ``FILE:LINE: ...`` line per value outside the plugins' ranges (what ``codermind
    convert`` refuses); the port renders them as the original does."""
    out: list[str] = []

    def warn(section, key, value, rule):
        label = key if section == "Scene" else f"{section}.{key}"
        out.append(f"{scene.path}:{scene.line_of(section, key)}: {label} = {_text(value)} "
                   f"{rule}: the port renders it as the original does, the Mitsuba plugins "
                   "(codermind convert) refuse it")

    page = scene.page
    for m in scene.materials:
        sec = f"Material{m.index}"
        keys = [("Reflection", m.reflection)] + ([("Refraction", m.refraction)] if page >= 4 else [])
        for key, value in keys:
            if not 0 <= value <= 1:
                warn(sec, key, value, "is outside [0, 1]")
        if page >= 2 and m.power < 0:
            warn(sec, "Power", m.power, "is negative")
        if page >= 4 and m.density < 0:
            warn(sec, "Density", m.density, "is negative")
        if page >= 4 and not 0 <= m.bumplevel <= 1:
            warn(sec, "Bumplevel", m.bumplevel, "is outside [0, 1]")
        textured = page >= 4 and m.type in ("turbulence", "marble")
        colours = [("Diffuse", m.diffuse)] if not textured else []
        if page >= 2:
            colours.append(("Specular", m.specular))
        for key, value in colours:
            if min(value) < 0:
                warn(sec, key, value, "has a negative channel")
    for light in scene.lights:
        if min(light.intensity) < 0:
            warn(f"Light{light.index}", "Intensity", light.intensity, "has a negative channel")
    if page == 4 and scene.camera.type == "conic":
        cam = scene.camera
        if cam.fov >= 180:
            warn("Scene", "Perspective.FOV", cam.fov, "is >= 180 degrees")
        if cam.dispersion < 0:
            warn("Scene", "Perspective.Dispersion", cam.dispersion, "is negative")
        if cam.dispersion > 0 and not cam.clear_point > 0:
            warn("Scene", "Perspective.ClearPoint", cam.clear_point,
                 "is not > 0 with a Dispersion")
    if page == 4 and scene.cubemap.faces and scene.cubemap.exposure < 0:
        warn("Scene", "Cubemap.Exposure", scene.cubemap.exposure, "is negative")
    return out


def check_scene(scene) -> None:
    """:func:`check_finite`, then the range warnings appended to ``scene.warnings``."""
    check_finite(scene)
    scene.warnings.extend(range_warnings(scene))
