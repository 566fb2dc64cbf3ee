"""Scene files of the tutorial programs (facts.md F1) as plain dataclasses.

``parse_scene(path) -> Scene`` accepts the versions of pages 1, 2 and 4:

========  ====  ===========================================================================
version   page  program
========  ====  ===========================================================================
1.0       1     orthographic, Lambert, mirror reflection, page-1 byte output
1.1       2     + Blinn specular, 2x2 supersampling, exposure, sRGB, calibration strip
1.3       4     + conic camera with depth of field, procedural materials, bump, Fresnel
                refraction with Russian roulette, blobs, cube map, tone curve, auto exposure
========  ====  ===========================================================================

Version 1.2 (page 3) is rejected: its program is not available, so what it computed cannot be
stated exactly (a 1.3 file has every page-3 feature).

Every value keeps the program's reading (``atof``/``atol``, first value of a repeated key wins,
silent defaults), and nothing below changes a value: the parser only *reports* what a user
would want to know, as ``Scene.warnings`` (``"file:line: message"``): unknown keys (for the
file's version), unknown sections and sections beyond the counts, repeated keys, numbers that
do not read cleanly (``90.0f`` reads cleanly as 90), and nested blocks. Errors raise
:class:`~codermind_ref.errors.SceneError` (``"file:line: message"``): syntax errors, a missing
``Scene`` or counted section, a bad version, negative counts, an image size < 1, a
``Material.Id`` outside ``[0, NumberOfMaterials)``, ``Perspective.FOV`` outside (0, 189),
tone-map parameters outside their ranges (``0 < Midpoint < 1``, ``Power >= 2``, ``Black >=
0``), ``Complexity < 1``, a blob ``Size <= 0``, and a cube map that cannot be loaded (the
original then renders a black background; the port stops instead, naming the face).

Cube-map face names are resolved against the scene file's folder first, then the current
directory (the original uses the current directory only). The faces are loaded by the parser
(``Scene.cubemap.faces``) so that a bad face is reported with its line.

Every object keeps its source: ``obj.section`` is the :class:`~codermind_ref.syntax.Section`
(``.line``, ``.entries[key].value/.line``, ``.line_of(key)``), and ``Scene.sections`` holds all
sections as written. Colours and points are float tuples; the renderer builds its own arrays.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import checks, cnumbers, tga
from .errors import SceneError
from .syntax import Section, read_sections

Vec3 = tuple[float, float, float]

PAGES = {(1, 0): 1, (1, 1): 2, (1, 3): 4}
FACES = ("Up", "Down", "Right", "Left", "Forward", "Backward")  # +y -y +x -x +z -z, load order

_SCENE_KEYS = {
    1: ("Version.Major", "Version.Minor", "Image.Width", "Image.Height",
        "NumberOfMaterials", "NumberOfSpheres", "NumberOfLights"),
}
_SCENE_KEYS[2] = _SCENE_KEYS[1]
_SCENE_KEYS[4] = _SCENE_KEYS[1] + (
    "NumberOfBlobs", "Perspective.Type", "Perspective.FOV", "Perspective.ClearPoint",
    "Perspective.Dispersion", "Tonemap.Midpoint", "Tonemap.Power", "Tonemap.Black",
    "Complexity", "Cubemap.Exposed", "Cubemap.sRGB", "Cubemap.Exposure",
) + tuple(f"Cubemap.{f}" for f in FACES)
_MATERIAL_KEYS = {1: ("Diffuse", "Reflection"), 2: ("Diffuse", "Reflection", "Specular", "Power")}
_MATERIAL_KEYS[4] = _MATERIAL_KEYS[2] + ("Type", "Diffuse2", "Bumplevel", "Density", "Refraction")
_OBJECT_KEYS = {"Sphere": ("Center", "Size", "Material.Id"),
                "Blob": ("Center0", "Center1", "Center2", "Size", "Material.Id"),
                "Light": ("Position", "Intensity")}
_KINDS = {1: ("Material", "Sphere", "Light"), 2: ("Material", "Sphere", "Light"),
          4: ("Material", "Sphere", "Blob", "Light")}
_INDEXED = re.compile(r"(Material|Sphere|Blob|Light)(0|[1-9][0-9]*)$")
MATERIAL_TYPES = ("gouraud", "turbulence", "marble", "noise")


@dataclass
class Material:
    """``MaterialN``. ``type`` is one of MATERIAL_TYPES (anything unknown is ``gouraud``;
    ``noise`` shades exactly like gouraud); ``type_text`` is the value as written."""
    index: int
    section: Section
    diffuse: Vec3 = (0.0, 0.0, 0.0)
    reflection: float = 0.0
    specular: Vec3 = (0.0, 0.0, 0.0)
    power: float = 0.0
    type: str = "gouraud"
    type_text: str = ""
    diffuse2: Vec3 = (0.0, 0.0, 0.0)
    bumplevel: float = 0.0
    density: float = 0.0
    refraction: float = 0.0


@dataclass
class Sphere:
    index: int
    section: Section
    center: Vec3 = (0.0, 0.0, 0.0)
    size: float = 0.0
    material_id: int = 0


@dataclass
class Blob:
    """``BlobN``: exactly three sources (a missing ``CenterK`` is the origin), radius R."""
    index: int
    section: Section
    centers: tuple[Vec3, Vec3, Vec3] = ((0.0,) * 3,) * 3
    size: float = 0.0
    material_id: int = 0


@dataclass
class Light:
    """``LightN``: a point light without distance falloff."""
    index: int
    section: Section
    position: Vec3 = (0.0, 0.0, 0.0)
    intensity: Vec3 = (0.0, 0.0, 0.0)


@dataclass
class Camera:
    """Page 4 ``Perspective.*``; pages 1-2 are always orthographic (``type`` "orthographic").
    ``fov`` is the horizontal field of view in degrees; ``clear_point`` the focus distance
    along each ray; ``dispersion`` the side of the square aperture [0, D]^2."""
    type: str = "orthographic"
    type_text: str = ""
    fov: float = 45.0
    clear_point: float = 1.0
    dispersion: float = 0.0


@dataclass
class Tonemap:
    midpoint: float = 0.6
    power: float = 3.0
    black: float = 0.1


@dataclass
class Cubemap:
    """``Cubemap.*``. ``names`` as written (by face: Up Down Right Left Forward Backward),
    ``paths`` the resolved files, ``faces`` the loaded pixels (float64, stored row order, RGB)
    or None when no face is named (black background)."""
    names: dict[str, str] = field(default_factory=dict)
    paths: dict[str, Path] = field(default_factory=dict)
    faces: dict[str, np.ndarray] | None = None
    exposed: bool = False
    srgb: bool = False
    exposure: float = 1.0


@dataclass
class Scene:
    """A parsed scene. ``page`` (1, 2 or 4) selects the program whose behaviour applies."""
    path: str
    version: tuple[int, int]
    page: int
    width: int = 640
    height: int = 480
    materials: list[Material] = field(default_factory=list)
    spheres: list[Sphere] = field(default_factory=list)
    blobs: list[Blob] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    camera: Camera = field(default_factory=Camera)
    tonemap: Tonemap = field(default_factory=Tonemap)
    complexity: int = 1
    cubemap: Cubemap = field(default_factory=Cubemap)
    sections: dict[str, Section] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def line_of(self, section: str, key: str | None = None) -> int:
        """Source line of a section (or of one of its keys, else of the section)."""
        s = self.sections[section]
        return s.line if key is None else s.line_of(key)


class _Values:
    """Typed reading of one section's keys, collecting warnings with lines."""

    def __init__(self, path: str, section: Section, warnings: list[str]):
        self.path, self.section, self.warnings = path, section, warnings

    def _get(self, key, reader, default):
        entry = self.section.entries.get(key)
        if entry is None:
            return default
        value, problem = reader(entry.value)
        if problem:
            self.warnings.append(f"{self.path}:{entry.line}: {key}: {problem}")
        return value

    def float(self, key: str, default: float) -> float:
        return self._get(key, cnumbers.read_float, default)

    def int(self, key: str, default: int) -> int:
        return self._get(key, cnumbers.read_int, default)

    def bool(self, key: str, default: bool) -> bool:
        return self._get(key, cnumbers.read_bool, default)

    def colour(self, key: str) -> Vec3:
        return self._get(key, cnumbers.read_colour, (0.0, 0.0, 0.0))

    def point(self, key: str) -> Vec3:
        return self._get(key, cnumbers.read_point, (0.0, 0.0, 0.0))

    def str(self, key: str, default: str = "") -> str:
        entry = self.section.entries.get(key)
        return default if entry is None else entry.value

    def error(self, key: str | None, message: str) -> SceneError:
        line = self.section.line if key is None else self.section.line_of(key)
        return SceneError(self.path, line, message)


def _warn_unknown_keys(path: str, section: Section, known, version, warnings) -> None:
    for key, entry in section.entries.items():
        if key not in known:
            warnings.append(f"{path}:{entry.line}: unknown key '{key}' in section "
                            f"'{section.name}' (ignored by the version {version[0]}.{version[1]} "
                            "program)")


def parse_scene(path: str | os.PathLike) -> Scene:
    """Read a tutorial scene file; see the module docstring. Raises SceneError."""
    path_str = str(path)
    try:
        text = Path(path).read_bytes().decode("latin-1")
    except OSError as e:
        raise SceneError(path_str, 1, f"cannot read the scene file: {e.strerror or e}") from None
    sections, warnings = read_sections(path_str, text)
    if "Scene" not in sections:
        raise SceneError(path_str, 1, "no 'Scene' section")
    top = _Values(path_str, sections["Scene"], warnings)

    version = (top.int("Version.Major", 0), top.int("Version.Minor", 0))
    if version not in PAGES:
        key = "Version.Minor" if "Version.Minor" in top.section.entries else "Version.Major"
        hint = ("version 1.2 (page 3) is not supported: its program is not available (use 1.3, "
                "which has every page-3 feature)" if version == (1, 2) else
                f"version {version[0]}.{version[1]} does not match a tutorial program; "
                "expected 1.0 (page 1), 1.1 (page 2) or 1.3 (page 4)")
        raise top.error(key, hint)
    page = PAGES[version]
    scene = Scene(path=path_str, version=version, page=page, sections=sections, warnings=warnings)
    _warn_unknown_keys(path_str, top.section, _SCENE_KEYS[page], version, warnings)

    scene.width, scene.height = top.int("Image.Width", 640), top.int("Image.Height", 480)
    for key, value in (("Image.Width", scene.width), ("Image.Height", scene.height)):
        if value < 1:
            raise top.error(key, f"{key} must be >= 1, got {value}")

    counts = {}
    for kind in _KINDS[page]:
        key = f"NumberOf{kind}s"
        counts[kind] = top.int(key, 0)
        if counts[kind] < 0:
            raise top.error(key, f"{key} must be >= 0, got {counts[kind]}")
        for i in range(counts[kind]):
            if f"{kind}{i}" not in sections:
                raise top.error(key, f"{key} = {counts[kind]} but there is no section "
                                f"'{kind}{i}'")
    for name, section in sections.items():
        m = _INDEXED.match(name)
        if name == "Scene":
            continue
        if not m or m.group(1) not in counts:
            warnings.append(f"{path_str}:{section.line}: unknown section '{name}' (ignored by "
                            f"the version {version[0]}.{version[1]} program)")
        elif int(m.group(2)) >= counts[m.group(1)]:
            warnings.append(f"{path_str}:{section.line}: section '{name}' is beyond "
                            f"NumberOf{m.group(1)}s = {counts[m.group(1)]}; ignored")

    def each(kind):
        for i in range(counts.get(kind, 0)):
            section = sections[f"{kind}{i}"]
            known = _MATERIAL_KEYS[page] if kind == "Material" else _OBJECT_KEYS[kind]
            _warn_unknown_keys(path_str, section, known, version, warnings)
            yield i, section, _Values(path_str, section, warnings)

    for i, section, v in each("Material"):
        m = Material(i, section, diffuse=v.colour("Diffuse"), reflection=v.float("Reflection", 0.0))
        if page >= 2:
            m.specular, m.power = v.colour("Specular"), v.float("Power", 0.0)
        if page >= 4:
            m.type_text = v.str("Type")
            m.type = m.type_text if m.type_text in MATERIAL_TYPES else "gouraud"
            m.diffuse2, m.bumplevel = v.colour("Diffuse2"), v.float("Bumplevel", 0.0)
            m.density, m.refraction = v.float("Density", 0.0), v.float("Refraction", 0.0)
        scene.materials.append(m)

    def material_id(v: _Values) -> int:
        mid = v.int("Material.Id", 0)
        if not 0 <= mid < counts["Material"]:
            raise v.error("Material.Id", f"Material.Id = {mid} is out of range: "
                          f"NumberOfMaterials = {counts['Material']}")
        return mid

    for i, section, v in each("Sphere"):
        scene.spheres.append(Sphere(i, section, v.point("Center"), v.float("Size", 0.0),
                                    material_id(v)))
    for i, section, v in each("Blob"):
        blob = Blob(i, section, tuple(v.point(f"Center{k}") for k in range(3)),
                    v.float("Size", 0.0), material_id(v))
        if not blob.size > 0:
            raise v.error("Size", f"blob Size must be > 0, got {blob.size:g}")
        scene.blobs.append(blob)
    for i, section, v in each("Light"):
        scene.lights.append(Light(i, section, v.point("Position"), v.colour("Intensity")))

    if page == 4:
        _read_page4(scene, top, Path(path).parent)
    checks.check_scene(scene)
    return scene


def _read_page4(scene: Scene, top: _Values, folder: Path) -> None:
    cam = scene.camera
    cam.type_text = top.str("Perspective.Type")
    cam.type = "conic" if cam.type_text == "conic" else "orthographic"
    if cam.type != "conic":
        scene.warnings.append(
            f"{scene.path}:{top.section.line_of('Perspective.Type')}: Perspective.Type is not "
            "'conic': page 4's orthographic mode hits nothing and shows one cube-map texel")
    cam.fov = top.float("Perspective.FOV", 45.0)
    if not 0 < cam.fov < 189:
        raise top.error("Perspective.FOV", f"Perspective.FOV must be > 0 and < 189, got {cam.fov:g}")
    cam.clear_point = top.float("Perspective.ClearPoint", 1.0)
    cam.dispersion = top.float("Perspective.Dispersion", 0.0)

    tm = scene.tonemap
    tm.midpoint = top.float("Tonemap.Midpoint", 0.6)
    tm.power = top.float("Tonemap.Power", 3.0)
    tm.black = top.float("Tonemap.Black", 0.1)
    for key, ok, rule in (("Tonemap.Midpoint", 0 < tm.midpoint < 1, "strictly between 0 and 1"),
                          ("Tonemap.Power", tm.power >= 2, ">= 2"),
                          ("Tonemap.Black", tm.black >= 0, ">= 0")):
        if not ok:
            value = top.float(key, 0.0)
            raise top.error(key, f"{key} must be {rule}, got {value:g}")
    scene.complexity = top.int("Complexity", 1)
    if scene.complexity < 1:
        raise top.error("Complexity", f"Complexity must be >= 1, got {scene.complexity}")

    cm = scene.cubemap
    cm.exposed = top.bool("Cubemap.Exposed", False)
    cm.srgb = top.bool("Cubemap.sRGB", False)
    cm.exposure = top.float("Cubemap.Exposure", 1.0)
    if cm.exposure == 0:
        raise top.error("Cubemap.Exposure", "Cubemap.Exposure must not be 0 (it divides the "
                        "cube-map radiance)")
    cm.names = {face: top.str(f"Cubemap.{face}") for face in FACES}
    named = [face for face in FACES if cm.names[face]]
    if not named:
        return
    faces = {}
    for face in FACES:  # the original's load order; Up first, the others must match its size
        key = f"Cubemap.{face}"
        if not cm.names[face]:
            raise top.error(None, f"{key} is not set but other cube-map faces are "
                            f"({', '.join(named)}); the original would render a black background")
        name = Path(cm.names[face])
        candidates = [name] if name.is_absolute() else [folder / name, Path.cwd() / name]
        found = next((c for c in candidates if c.is_file()), None)
        if found is None:
            tried = " or ".join(f"'{c}'" for c in dict.fromkeys(candidates))
            raise top.error(key, f"{key}: cube-map face not found (tried {tried})")
        try:
            pixels, face_warnings = tga.read_face(found)
        except tga.TgaError as e:
            raise top.error(key, f"{key}: {e}") from None
        scene.warnings.extend(f"{scene.path}:{top.section.line_of(key)}: {w}" for w in face_warnings)
        if face != "Up" and pixels.shape != faces["Up"].shape:
            raise top.error(key, f"{key}: '{found}' is {pixels.shape[1]}x{pixels.shape[0]}, but "
                            f"the Up face is {faces['Up'].shape[1]}x{faces['Up'].shape[0]}")
        cm.paths[face] = found
        faces[face] = pixels
    cm.faces = faces
