"""Tutorial scene files to Mitsuba XML (``codermind convert``).

:func:`convert` turns a scene parsed by the port's parser (``codermind_ref.parse_scene``:
the tutorial's reading of every value, with source lines) into a readable Mitsuba scene that
uses this package's plugins and, by default, its ``tutorialpath`` integrator:

* world units and axes are the tutorial's (pixels; x right, y up, z into the screen); the
  left-handed frame is shown as the tutorial shows it by mirroring x in the camera's
  ``to_world``;
* pages 1 and 2: ``tutorialortho`` (rays from z = -1000 along +z, t < 2000) on a W x H
  (page 1) or 2W x 2H (page 2: the 2x2 sub-samples) film with ``pixel_offset`` (0, 1), a
  ``stratified`` sampler without jitter; page 4: ``conic`` with the ``tutorial`` lens (FOV,
  ClearPoint, Dispersion) on a 2W x 2H film, ``independent`` sampler, plus a second sensor
  ``probes`` (no pixel offset, no aperture, a W x H film) whose rays are the auto-exposure
  probes; page 4's orthographic mode as the original (rays from z = -10000, probes from
  z = -1000);
* materials: ``tutorial`` BSDFs (``page`` 1, 2 or 4), ``turbulence``/``marble`` textures
  (color0 = Diffuse, color1 = Diffuse2), ``noisebump`` around them when Bumplevel != 0;
* spheres: built-in ``sphere``; blobs: ``blob`` with the tutorial's zone field and exactly the
  three centres the original reads; lights: ``tutorialpoint`` (no falloff); the cube map:
  ``cubemap`` in ``background`` mode with the faces named relative to the XML's folder;
* ``tutorialpath`` (default; ``quirks`` clean, or strict for the original's quirks) with
  ``max_depth`` = path depth + 1 (11 for the tutorial's 10 segments): every light at every
  hit, as the tutorial, in one render; or (``integrator="path"``) the built-in ``path`` with
  the same ``max_depth`` and no Russian roulette, which has the same expectation as clean
  ``tutorialpath`` and samples one light per hit.

The model (depth, samples, blob tessellation) is :func:`codermind.tutorial.model.choose`'s,
baked in as ``<default>`` values that ``-D name=value`` overrides at render time. The
tutorial's image settings go into a ``codermind-tutorial`` comment block
(:mod:`codermind.tutorial.image`). Every element carries a comment naming the tutorial
section and line it came from; what cannot be reproduced exactly is listed at the top of the
file (and returned as ``notes``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import CodermindError
from .finite import check_finite
from .image import ToneSettings, format_block, format_number
from .model import Model

#: Length of every segment in the tutorial (t starts at 2000).
T_MAX = 2000.0
#: The tutorial's noise frequencies per pixel (its world unit): turbulence (and marble's
#: turbulence), marble's stripes along x + y, and the bump's noise. The plugins' defaults
#: are for scenes in larger units, so these are written out.
TURBULENCE_FREQUENCY = 0.05
STRIPE_FREQUENCY = 0.05
BUMP_FREQUENCY = 0.1
CUBEMAP_KEYS = {"up": "Up", "down": "Down", "right": "Right", "left": "Left",
                "forward": "Forward", "backward": "Backward"}


@dataclass
class Conversion:
    xml: str
    notes: list[str]          #: what the XML does not reproduce exactly (one line each)
    settings: ToneSettings
    model: Model


def _comment_text(text: str) -> str:
    return text.replace("--", "- -")


class _Writer:
    """Indented XML lines with trailing comments."""

    def __init__(self):
        self.lines: list[str] = []
        self.level = 0

    def _add(self, text: str, note: str | None) -> None:
        line = "    " * self.level + text
        if note:
            line = f"{line}  <!-- {_comment_text(note)} -->"
        self.lines.append(line)

    @staticmethod
    def _tag(tag: str, attrs: dict) -> str:
        return " ".join([tag] + [f"{k}={quoteattr(str(v))}" for k, v in attrs.items()])

    def comment(self, text: str) -> None:
        self.lines.append("    " * self.level + f"<!-- {_comment_text(text)} -->")

    def blank(self) -> None:
        self.lines.append("")

    def open(self, tag: str, note: str | None = None, **attrs) -> None:
        self._add(f"<{self._tag(tag, attrs)}>", note)
        self.level += 1

    def close(self, tag: str) -> None:
        self.level -= 1
        self._add(f"</{tag}>", None)

    def leaf(self, tag: str, note: str | None = None, **attrs) -> None:
        self._add(f"<{self._tag(tag, attrs)}/>", note)

    # typed properties
    def float(self, name: str, value: float, note: str | None = None) -> None:
        self.leaf("float", note, name=name, value=format_number(value))

    def integer(self, name: str, value, note: str | None = None) -> None:
        self.leaf("integer", note, name=name, value=value)

    def boolean(self, name: str, value: bool, note: str | None = None) -> None:
        self.leaf("boolean", note, name=name, value="true" if value else "false")

    def string(self, name: str, value: str, note: str | None = None) -> None:
        self.leaf("string", note, name=name, value=value)

    def rgb(self, name: str, value, note: str | None = None) -> None:
        self.leaf("rgb", note, name=name, value=", ".join(format_number(v) for v in value))

    def point(self, name: str, value, note: str | None = None) -> None:
        x, y, z = (format_number(v) for v in value)
        self.leaf("point", note, name=name, x=x, y=y, z=z)


class _Source:
    """Where values came from: 'Material1.Reflection, line 72' or '... (default)'."""

    def __init__(self, scene):
        self.scene = scene
        self.name = Path(scene.path).name

    def has(self, section: str, key: str) -> bool:
        return key in self.scene.sections[section].entries

    def line(self, section: str, key: str | None = None) -> int:
        return self.scene.line_of(section, key)

    def note(self, section: str, key: str) -> str:
        if self.has(section, key):
            return f"{key}, line {self.line(section, key)}"
        return f"{key}: default"

    def where(self, section: str, key: str | None = None) -> str:
        return f"{self.scene.path}:{self.line(section, key)}"

    def error(self, section: str, key: str | None, message: str) -> CodermindError:
        return CodermindError(f"{self.where(section, key)}: {message}")


def settings_of(scene, lights: str = "sum") -> ToneSettings:
    tm = scene.tonemap
    return ToneSettings(page=scene.page, width=scene.width, height=scene.height,
                        midpoint=tm.midpoint, power=tm.power, black=tm.black, lights=lights)


# -- checks of what the plugins can express ----------------------------------------------

def _check_scene(scene, src: _Source) -> None:
    check_finite(scene)
    page = scene.page
    for m in scene.materials:
        sec = f"Material{m.index}"
        for key, value in (("Reflection", m.reflection), ("Refraction", m.refraction)):
            if not 0 <= value <= 1:
                raise src.error(sec, key, f"{key} = {value:g}: the Mitsuba 'tutorial' material "
                                          "needs a value in [0, 1]")
        if m.power < 0:
            raise src.error(sec, "Power", f"Power = {m.power:g}: must be >= 0 for Mitsuba")
        if m.density < 0:
            raise src.error(sec, "Density", f"Density = {m.density:g}: must be >= 0 for Mitsuba")
        if page == 4 and not 0 <= m.bumplevel <= 1:
            raise src.error(sec, "Bumplevel", f"Bumplevel = {m.bumplevel:g}: 'noisebump' "
                                              "needs a value in [0, 1]")
        textured = page == 4 and m.type in ("turbulence", "marble")
        for key, value in (("Diffuse", m.diffuse), ("Specular", m.specular)):
            if min(value) < 0 and not (textured and key == "Diffuse"):
                raise src.error(sec, key, f"{key} = {value}: negative colours cannot be "
                                          "expressed (Mitsuba rejects them)")
    for light in scene.lights:
        if min(light.intensity) < 0:
            raise src.error(f"Light{light.index}", "Intensity",
                            f"Intensity = {light.intensity}: negative light cannot be expressed")
    if page == 4:
        cam = scene.camera
        if cam.type == "conic":
            if not cam.fov < 180:
                raise src.error("Scene", "Perspective.FOV", f"Perspective.FOV = {cam.fov:g}: "
                                "the 'conic' camera needs a field of view below 180 degrees")
            if cam.dispersion < 0:
                raise src.error("Scene", "Perspective.Dispersion",
                                f"Perspective.Dispersion = {cam.dispersion:g}: a negative "
                                "aperture (the square [D, 0]^2) cannot be expressed")
            if cam.dispersion > 0 and not cam.clear_point > 0:
                raise src.error("Scene", "Perspective.ClearPoint",
                                f"Perspective.ClearPoint = {cam.clear_point:g}: the focus "
                                "distance must be > 0 with a Dispersion")
        if scene.cubemap.faces and not scene.cubemap.exposure > 0:
            raise src.error("Scene", "Cubemap.Exposure", f"Cubemap.Exposure = "
                            f"{scene.cubemap.exposure:g}: 'cubemap' needs an exposure > 0")


# -- notes: what is not reproduced exactly -------------------------------------------------

def _extent(scene) -> float:
    """Bound of the largest distance between two points of the scene's objects (a blob lies
    within sqrt(10) R of its centres)."""
    pts = [(np.array(s.center), abs(s.size)) for s in scene.spheres if s.size != 0]
    pts += [(np.array(c), math.sqrt(10.0) * b.size) for b in scene.blobs for c in b.centers]
    best = 0.0
    for i, (p, r) in enumerate(pts):
        for q, s in pts[i + 1:]:
            best = max(best, float(np.linalg.norm(p - q)) + r + s)
    return best


def _notes(scene, model: Model, integrator: str = "tutorialpath",
           quirks: str = "clean") -> list[str]:
    page = scene.page
    strict = quirks == "strict"
    used = {o.material_id for o in list(scene.spheres) + list(scene.blobs)}
    mats = [scene.materials[i] for i in sorted(used)]
    continues = any(m.reflection > 0 or (page == 4 and m.refraction > 0) for m in mats)
    notes = []
    if page in (2, 4) and scene.lights and not strict:
        notes.append("Shadow rays are tested up to the light (the strict original tests up to "
                     "the SQUARED distance, so objects beyond a light can cast shadows there).")
    if page == 4:
        textured = any(m.type in ("turbulence", "marble") for m in mats)
        if textured and continues and not strict:
            notes.append("Turbulence and marble lighting is weighted by the path coefficient "
                         "once (the strict original applies it twice after a reflection or "
                         "refraction).")
        if continues and not strict:
            notes.append("After the 10th segment the next ray is traced and adds the cube map "
                         "only if it escapes (the strict original adds the cube map along it "
                         "unconditionally).")
        if any(m.refraction > 0 and m.density != 0 for m in mats) and not strict:
            notes.append("A 'diffuse' roulette draw inside an object is redrawn among reflect "
                         "and refract without using a segment (the strict original re-traces "
                         "the segment, each try using one of the 10).")
        if scene.camera.type != "conic":
            notes.append("Perspective.Type is not 'conic': page 4's orthographic mode, "
                         "reproduced as the original (rays from z = -10000 with t < 2000 hit "
                         "nothing: one cube-map texel); its auto-exposure probes start at "
                         "z = -1000 and do hit the objects.")
        for b in scene.blobs:
            missing = [f"Center{k}" for k in range(3)
                       if f"Center{k}" not in scene.sections[f"Blob{b.index}"].entries]
            if missing:
                notes.append(f"Blob{b.index}: {', '.join(missing)} not set: the original puts "
                             "the missing centre(s) at the origin, and so does this scene.")
        if scene.blobs:
            notes.append("Blobs are triangle meshes within max_error of the zone-field surface "
                         "(exact gradient normals at the vertices, interpolated between)"
                         + (" where blob_tessellate is true; by default tutorialpath "
                            "intersects the zone field itself." if integrator == "tutorialpath"
                            else "."))
        stochastic = model.stochastic
        notes.append("The auto exposure traces the 16x16 probe grid through Mitsuba with its "
                     "own random numbers" + (" (the tutorial's sd over random sequences is "
                                             "about 0.8 %)." if stochastic else " (nothing "
                                             "random here: it is exact)."))
        if stochastic:
            notes.append("Random numbers are Mitsuba's, not the original's rand() sequence: "
                         "the same distribution, other noise.")
        notes.append("Noise, textures and bump are computed in float32 (the original's Perlin "
                     "noise is double precision).")
        if strict:
            notes.append("Strict quirks not reproduced: the original's stop at a zero normal "
                         "(Mitsuba's shapes have none), its float32 blob bound (the blob is "
                         "a mesh) and its refracted directions' length at near-normal "
                         "incidence (taken as unit by its next intersection; Mitsuba's rays "
                         "are unit).")
    if len(scene.lights) > 1 and integrator == "path":
        notes.append("The tutorial shades every hit with all its lights; Mitsuba's path "
                     "integrator samples one light per hit. " + (
                         "codermind render therefore renders once per light and adds the "
                         "images (exact); the plain mitsuba command on this file gives the same "
                         "expectation with more noise." if model.lights == "sum" else
                         "This file samples them (lights=sample): " + (
                             "the N^2 stratified samples make that exact here." if not
                             model.stochastic else "the same expectation with more noise "
                             "than the tutorial's.")))
    for s in scene.spheres:
        if s.size == 0:
            notes.append(f"Sphere{s.index} has Size 0 (invisible in the original); left out.")
    if continues and _extent(scene) > T_MAX:
        notes.append(f"The scene is larger than {T_MAX:g}: the original cuts every segment at "
                     f"t = {T_MAX:g}; here only camera rays are cut.")
    if integrator == "path":
        notes.append("Self-intersections are avoided by Mitsuba's ray offsets, not the "
                     "tutorial's 0.1 (spheres) / 0.01 (blobs) minimum distance; arithmetic is "
                     "float32.")
    else:
        notes.append(f"Rays leave hit points from {MIN_DISTANCE:g} along their own direction "
                     "(tutorialpath's min_distance: the tutorial's sphere epsilon"
                     + (", which also stands in for its 0.01 blob epsilon where a ray leaves "
                        "the blob's mesh; rays leaving exact blob points keep the 0.01"
                        if scene.blobs else "")
                     + "); of two spheres at exactly the same distance the first in the file "
                     "is hit, as in the tutorial (tutorialpath traces the spheres itself"
                     + ("; with blob_tessellate true Embree does, in its BVH's order"
                        if scene.blobs else "")
                     + "); arithmetic is float32.")
    if scene.warnings:
        notes.append(f"The parser reported {len(scene.warnings)} warning(s) (values kept as the "
                     "original reads them): " + "; ".join(scene.warnings))
    return notes


# -- writers --------------------------------------------------------------------------------

def _material(w: _Writer, src: _Source, m, page: int, used: bool) -> None:
    sec = f"Material{m.index}"
    label = f"{sec} ({src.name}:{src.line(sec)})" + ("" if used else ", not used by any object")
    bump = page == 4 and m.bumplevel != 0
    if bump:
        w.open("bsdf", label, type="noisebump", id=f"material{m.index}")
        w.float("bumplevel", m.bumplevel, src.note(sec, "Bumplevel"))
        w.float("frequency", BUMP_FREQUENCY, "the tutorial's, per pixel")
        w.open("bsdf", None, type="tutorial")
    else:
        w.open("bsdf", label, type="tutorial", id=f"material{m.index}")
    w.integer("page", page, f"the page-{page} program's transport")
    kind = m.type if page == 4 else "gouraud"
    if kind in ("turbulence", "marble"):
        w.open("texture", f"Type = {m.type_text}, line {src.line(sec, 'Type')}", type=kind,
               name="diffuse")
        w.rgb("color0", m.diffuse, src.note(sec, "Diffuse"))
        w.rgb("color1", m.diffuse2, src.note(sec, "Diffuse2"))
        w.float("frequency", TURBULENCE_FREQUENCY, "the tutorial's, per pixel")
        if kind == "marble":
            w.float("stripe_frequency", STRIPE_FREQUENCY, "the tutorial's, per pixel")
        w.close("texture")
    else:
        note = src.note(sec, "Diffuse")
        if page == 4 and m.type_text and m.type_text != "gouraud":
            note += (f"; Type = {m.type_text} shades as gouraud" if m.type == "noise" else
                     f"; unknown Type '{m.type_text}' shades as gouraud")
        w.rgb("diffuse", m.diffuse, note)
    if page >= 2:
        w.rgb("specular", m.specular, src.note(sec, "Specular"))
        w.float("power", m.power, src.note(sec, "Power"))
    w.float("reflection", m.reflection, src.note(sec, "Reflection"))
    if page == 4:
        w.float("refraction", m.refraction, src.note(sec, "Refraction"))
        w.float("density", m.density, src.note(sec, "Density") + (" (0: metal, no Fresnel)"
                                                                    if m.density == 0 else ""))
    w.close("bsdf")
    if bump:
        w.close("bsdf")


def _film(w: _Writer, width: int, height: int, note: str) -> None:
    w.open("film", note, type="hdrfilm")
    w.integer("width", width)
    w.integer("height", height)
    w.leaf("rfilter", None, type="box")
    w.close("film")


def _clip_and_offset(w: _Writer, near_note: str | None, far_note: str, offset: bool) -> None:
    w.float("near_clip", 0, near_note)
    w.float("far_clip", T_MAX, far_note)
    if offset:
        w.float("pixel_offset_x", 0, "every sample at the film pixel's bottom-left corner")
        w.float("pixel_offset_y", 1)


def _sampler_film_end(w: _Writer, sampler: str, film: tuple[int, int], film_note: str,
                      spp: int | None = None) -> None:
    _sampler(w, sampler, spp)
    _film(w, film[0], film[1], film_note)
    w.close("sensor")


def _ortho_sensor(w: _Writer, scene, sid: str, z0: float, film: tuple[int, int],
                  offset: bool, sampler: str, film_note: str, note: str) -> None:
    half_w, half_h = scene.width / 2.0, scene.height / 2.0
    w.open("sensor", note, type="tutorialortho", id=sid)
    _clip_and_offset(w, "rays start at the film plane", "t < 2000", offset)
    w.open("transform", "film [-1, 1] x [-1/a, 1/a] -> world [0, W] x [0, H], x mirrored",
           name="to_world")
    w.leaf("scale", "-W/2, W/2, 1", x=format_number(-half_w), y=format_number(half_w), z="1")
    w.leaf("translate", f"W/2, H/2, z = {format_number(z0)}", x=format_number(half_w),
           y=format_number(half_h), z=format_number(z0))
    w.close("transform")
    _sampler_film_end(w, sampler, film, film_note)


def _conic_sensor(w: _Writer, src: _Source, scene, sid: str, film: tuple[int, int],
                  offset: bool, aperture: bool, sampler: str, film_note: str, note: str,
                  spp: int | None = None) -> None:
    cam = scene.camera
    w.open("sensor", note, type="conic", id=sid)
    w.string("lens", "tutorial", "square aperture [0, D]^2, focus sphere (facts.md F5)")
    w.float("fov", cam.fov, "horizontal; " + src.note("Scene", "Perspective.FOV"))
    if aperture and cam.dispersion > 0:
        w.float("aperture", cam.dispersion, src.note("Scene", "Perspective.Dispersion"))
        w.float("focus_distance", cam.clear_point, src.note("Scene", "Perspective.ClearPoint"))
    elif aperture:
        w.comment("Perspective.Dispersion is 0: a pinhole (no depth of field)")
    _clip_and_offset(w, None, "t < 2000 along each ray", offset)
    w.open("transform", "eye at (W/2, H/2, 0) looking along +z; x mirrored (left-handed world)",
           name="to_world")
    w.leaf("scale", None, x="-1")
    w.leaf("translate", None, x=format_number(scene.width / 2.0),
           y=format_number(scene.height / 2.0), z="0")
    w.close("transform")
    _sampler_film_end(w, sampler, film, film_note, spp)


#: The camera's sampler where its draws are random (lens, roulette), chosen from measurement
#: (docs/results/integrator.md, equal error); used where the sample count suits it (Mitsuba
#: rounds other counts up), else ``independent``. Stratifying the Complexity rays of a
#: sub-sample is legitimate: the tone curve acts on their mean.
#: Page 4's whole image (benchmarks/bench_samplers.py --pairs --rect 0,0,640,480 --spp 16,64,
#: Complexity 256 scene, 2026-12-04), wall seconds to the strict port's error at Complexity
#: 256: independent 19.5, stratified 6.26, multijitter 5.76, ldsampler 6.22, orthogonal 6.14
#: (docs/results/integrator.md).
RANDOM_SAMPLER = "multijitter"


def sampler_fits(kind: str, spp: int) -> bool:
    """Whether Mitsuba's sampler ``kind`` takes exactly ``spp`` samples per pixel."""
    root = math.isqrt(spp)
    square = root * root == spp
    if kind in ("stratified", "multijitter"):
        return square
    if kind == "ldsampler":
        return square and root & (root - 1) == 0
    if kind == "orthogonal":
        return square and root > 1 and all(root % k for k in range(2, math.isqrt(root) + 1))
    return True


def _sampler(w: _Writer, kind: str, spp: int | None = None) -> None:
    if kind == "fixed":
        w.open("sampler", "no jitter: the fixed sample positions are exact", type="stratified")
        w.integer("sample_count", "$spp")
        w.boolean("jitter", False)
    elif kind == "probe":
        w.open("sampler", None, type="independent")
        w.integer("sample_count", 1)
    else:
        chosen = RANDOM_SAMPLER if spp is None or sampler_fits(RANDOM_SAMPLER, spp) \
            else "independent"
        w.open("sampler", "lens and roulette draws", type=chosen)
        w.integer("sample_count", "$spp")
    w.close("sampler")


def _cubemap(w: _Writer, src: _Source, scene, folder: Path | None) -> None:
    cm = scene.cubemap
    w.open("emitter", f"Cubemap.* ({src.name}:{src.line('Scene', 'Cubemap.Up')}): the "
           "background seen by escaping rays", type="cubemap")
    w.string("mode", "background", "the tutorial never samples the sky as a light")
    if not scene.lights:
        w.float("sampling_weight", 1, "the only emitter (never sampled: background mode)")
    for name, face in CUBEMAP_KEYS.items():
        path = Path(cm.paths[face]).resolve()
        text = path.as_posix() if folder is None else \
            Path(os.path.relpath(path, folder.resolve())).as_posix()
        w.string(name, text, src.note("Scene", f"Cubemap.{face}"))
    w.boolean("srgb", cm.srgb, src.note("Scene", "Cubemap.sRGB") + ": c^2.2")
    w.boolean("exposed", cm.exposed, src.note("Scene", "Cubemap.Exposed") + ": -ln(1.001 - c)")
    w.float("exposure", cm.exposure, src.note("Scene", "Cubemap.Exposure"))
    w.close("emitter")


INTEGRATORS = ("tutorialpath", "path")
#: tutorialpath's min_distance: the tutorial's sphere epsilon (facts.md F4.1)
MIN_DISTANCE = 0.1
QUIRKS = ("clean", "strict")


def _integrator(w: _Writer, integrator: str, page: int, blobs: bool = False) -> None:
    if integrator == "path":
        w.open("integrator", "Mitsuba's built-in path tracer (convert option integrator=path): "
               "the expectation of the clean tutorialpath"
               + (" with exact_hits false (blob hits on the mesh)" if blobs else "")
               + ", one light sampled per hit", type="path")
        w.integer("max_depth", "$max_depth")
        w.integer("rr_depth", "$max_depth", "no Russian roulette (the tutorial has none)")
        w.close("integrator")
        return
    w.open("integrator", "the default: the tutorial's transport, every light with its own "
           "shadow ray at every hit (one render; path picks one light per hit), then the "
           "material's roulette; clean has path's expectation at less cost", type="tutorialpath")
    w.integer("max_depth", "$max_depth")
    if blobs:
        w.boolean("exact_hits", True, "blob hits moved onto the tutorial's exact surface, rays "
                  "leaving them without Mitsuba's spawn offset, as the original's (false: the "
                  "mesh's hits, as path sees them)")
    w.leaf("float", "rays leave hits from the tutorial's sphere epsilon along their direction "
           "(facts.md F4.1), not by Mitsuba's normal offset: where two spheres meet, as page 1's at "
           "x = 320", name="min_distance", value="$min_distance")
    w.string("quirks", "$quirks", "clean: path's expectation; strict: the original's quirks"
             + (" (page 1 has none)" if page == 1 else ""))
    w.close("integrator")


def convert(scene, xml_path: str | os.PathLike | None, model: Model,
            command: str | None = None, integrator: str = "tutorialpath",
            quirks: str = "clean") -> Conversion:
    """The Mitsuba XML of ``scene`` (a ``codermind_ref.Scene``) with ``model``.
    ``xml_path``: where it will be written (cube-map faces are named relative to its folder;
    None: absolute names). ``command``: how to regenerate it (for the header). ``integrator``:
    ``tutorialpath`` (default) or ``path``; ``quirks`` (tutorialpath): clean or strict."""
    if integrator not in INTEGRATORS:
        raise CodermindError(f"integrator must be one of {', '.join(INTEGRATORS)}, got "
                             f"{integrator!r}")
    if quirks not in QUIRKS or (quirks == "strict" and integrator == "path"):
        raise CodermindError(f"quirks must be 'clean' or 'strict' (strict needs the "
                             f"tutorialpath integrator), got {quirks!r} with {integrator}")
    src = _Source(scene)
    _check_scene(scene, src)
    page = scene.page
    settings = settings_of(scene, model.lights)
    notes = _notes(scene, model, integrator, quirks)
    folder = None if xml_path is None else Path(xml_path).parent
    conic = page == 4 and scene.camera.type == "conic"
    used = {o.material_id for o in list(scene.spheres) + list(scene.blobs)}

    w = _Writer()
    w.lines.append('<?xml version="1.0" encoding="utf-8"?>')
    head = [f"Converted by `codermind convert` from {src.name} (scene version "
            f"{scene.version[0]}.{scene.version[1]}: the page-{page} program).",
            f"Regenerate: {command}" if command else None,
            "Render with the tutorial's image pipeline: codermind render THIS.xml",
            "",
            "Units and axes are the tutorial's: pixels; x right, y up, z into the screen (a",
            "left-handed frame, shown as the tutorial shows it by the camera's mirrored x).",
            "",
            "Model (codermind convert's choice; override with -D name=value when rendering):"]
    head = [h for h in head if h is not None]
    head += ["  " + line for line in model.summary()]
    head += ["", "Not reproduced exactly:"] + ["  - " + n for n in notes]
    w.lines.append("<!--")
    w.lines.extend(("    " + _comment_text(h)).rstrip() for h in head)
    w.lines.append("-->")
    w.lines.append(format_block(settings))
    w.open("scene", None, version="3.0.0")
    w.leaf("default", "path depth + 1; 11 = the tutorial's 10 segments", name="max_depth",
           value=str(model.max_depth))
    if integrator == "tutorialpath":
        w.leaf("default", "clean (path's expectation) or strict (the original's quirks)",
               name="quirks", value=quirks)
        w.leaf("default", "the tutorial's sphere epsilon; 0: Mitsuba's ray offsets",
               name="min_distance", value=f"{MIN_DISTANCE:g}")
    w.leaf("default", "samples per sub-sample" + (" (the scene's Complexity)"
                                                  if page == 4 else ""),
           name="spp", value=str(model.spp))
    for i, e in enumerate(model.blob_max_error):
        w.leaf("default", f"Blob{i}: world units", name=f"blob{i}_max_error",
               value=f"{e:.6g}")
    if model.blob_max_error:
        w.leaf("default", "false: tutorialpath intersects the zone field itself (exact, "
               "faster); true: triangle meshes within max_error, what every integrator sees"
               if integrator == "tutorialpath" else "true: triangle meshes (path sees no "
               "untessellated blob)", name="blob_tessellate",
               value="false" if integrator == "tutorialpath" else "true")
    w.blank()

    _integrator(w, integrator, page, bool(model.blob_max_error))
    w.blank()

    size = settings.film_size
    film_note = ("W x H: one sample per pixel" if page == 1 else
                 "2W x 2H: film pixel (2x + a, 2H - 1 - 2y - b) is sub-sample (x + a/2, y + b/2)")
    scene_note = f"Scene ({src.name}:{src.line('Scene')})"
    if page < 4:
        _ortho_sensor(w, scene, "camera", -1000.0, size, True, "fixed", film_note,
                      f"{scene_note}: orthographic, pixel (x, y) fires from (x, y, -1000) along +z")
    elif conic:
        _conic_sensor(w, src, scene, "camera", size, True, True,
                      "random" if model.stochastic else "fixed", film_note,
                      f"{scene_note}: Perspective.Type = conic, line "
                      f"{src.line('Scene', 'Perspective.Type')}", spp=model.spp)
        w.blank()
        _conic_sensor(w, src, scene, "probes", (scene.width, scene.height), False, False,
                      "probe", "W x H: sample2 = (x / W, 1 - y / H) for tutorial pixel (x, y)",
                      "the auto-exposure probes (facts.md F6.3): pinhole rays, not rendered")
    else:
        _ortho_sensor(w, scene, "camera", -10000.0, size, True, "fixed", film_note,
                      f"{scene_note}: page 4's orthographic mode: rays from z = -10000, t < 2000")
        w.blank()
        _ortho_sensor(w, scene, "probes", -1000.0, (scene.width, scene.height), False, "probe",
                      "W x H: sample2 = (x / W, 1 - y / H) for tutorial pixel (x, y)",
                      "the auto-exposure probes (facts.md F6.3) start at z = -1000; not rendered")
    w.blank()

    for m in scene.materials:
        _material(w, src, m, page, m.index in used)
    w.blank()

    for light in scene.lights:
        sec = f"Light{light.index}"
        w.open("emitter", f"{sec} ({src.name}:{src.line(sec)}): no distance falloff",
               type="tutorialpoint")
        w.point("position", light.position, src.note(sec, "Position"))
        w.rgb("intensity", light.intensity, src.note(sec, "Intensity"))
        w.close("emitter")
    if page == 4 and scene.cubemap.faces:
        _cubemap(w, src, scene, folder)
    w.blank()

    for s in scene.spheres:
        sec = f"Sphere{s.index}"
        if s.size == 0:
            w.comment(f"{sec} ({src.name}:{src.line(sec)}): Size 0, left out")
            continue
        w.open("shape", f"{sec} ({src.name}:{src.line(sec)})", type="sphere")
        w.point("center", s.center, src.note(sec, "Center"))
        w.float("radius", abs(s.size), src.note(sec, "Size") +
                (" (the tutorial uses Size^2: the sign does not matter)" if s.size < 0 else ""))
        w.leaf("ref", f"Material.Id, line {src.line(sec, 'Material.Id')}",
               id=f"material{s.material_id}")
        w.close("shape")
    for b in scene.blobs:
        sec = f"Blob{b.index}"
        w.open("shape", f"{sec} ({src.name}:{src.line(sec)})", type="blob")
        for k, c in enumerate(b.centers):
            key = f"Center{k}"
            w.point(f"center{k}", c, src.note(sec, key) + ("" if src.has(sec, key)
                                                            else ": the origin, as the original"))
        w.float("radius", b.size, src.note(sec, "Size"))
        w.string("field", "tutorial", "the piecewise-linear zone field (facts.md F11)")
        w.leaf("float", "largest mesh-to-surface distance, world units", name="max_error",
               value=f"$blob{b.index}_max_error")
        w.leaf("boolean", "false: no mesh, only tutorialpath sees it", name="tessellate",
               value="$blob_tessellate")
        w.string("normals", "exact", "gradient of sum R^2/d^2, as the tutorial shades")
        w.leaf("ref", f"Material.Id, line {src.line(sec, 'Material.Id')}",
               id=f"material{b.material_id}")
        w.close("shape")
    w.close("scene")
    return Conversion("\n".join(w.lines) + "\n", notes, settings, model)
