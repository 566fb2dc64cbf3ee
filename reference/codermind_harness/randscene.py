"""Random scene files in the tutorial's own format (facts.md F1), as a user would write them,
for ``codermind compare`` on scenes nobody calibrated anything to
(benchmarks/random_compare.py, tests/harness/test_random_compare.py).

:func:`draw` turns a seed into one scene, the same text for the same arguments on every
machine (Python's ``random.Random``, whose ``random()`` sequence is fixed). A page-4 scene
(version 1.3) has:

- the conic camera (FOV 50-100 degrees), with depth of field one time in two (Dispersion
  2-10, ClearPoint the distance to one of the objects);
- one to four spheres and zero or one blob (three sources of radius R within 1.3 R of its
  middle, so that they merge) in front of the camera, at depths 250-650, none containing the
  eye or a light;
- one to three point lights, intensity 0.3-4 per channel;
- materials drawn per object among ``gouraud``, ``turbulence``, ``marble`` (Density 1,
  Reflection 0 or a little), a ``mirror`` (Density 0, Reflection 1, Specular), a partial
  ``metal`` (Density 0, Reflection 0.2-0.9: reflects or is lit, at random), a ``plastic``
  (gouraud with Density 1.2-2, Reflection 0.3-1: Fresnel reflection over a lit surface) and
  ``glass`` (Density 1.1-2.4, Reflection and Refraction drawn separately in 0.5-1, equal one
  time in four); Bumplevel 0.05-0.3 on a third of them;
- the cube map one time in two (``cubemap="any"``): the bundled faces (scenes/sky, the
  encoding of the tutorial's: ``Cubemap.sRGB`` and ``Cubemap.Exposed``) or any folder of faces
  named as the bundled or the tutorial's ``alp*.tga``; face paths are written relative to the
  scene's folder when :func:`write_scenes` knows it, else absolute;
- Complexity 1-16 and a tone curve near page 4's (Midpoint 0.5-0.8, Power 2-4, Black 0-0.2).

A page-2 scene (version 1.1) has one to four spheres seen by the orthographic camera, gouraud
materials with Reflection 0-0.8, Specular and Power, and one to three lights.

``python -m codermind_harness.randscene OUT --count N [--seed S]`` writes ``OUT/random-S.txt``,
``OUT/random-(S+1).txt``, ... (``--page``, ``--size WxH``, ``--cubemap``).
"""

from __future__ import annotations

import argparse
import math
import os
import random
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

#: The bundled cube-map faces (scenes/sky of the repository, beside reference/).
SKY = Path(__file__).resolve().parents[2] / "scenes" / "sky"
FACE_KEYS = ("Up", "Down", "Right", "Left", "Forward", "Backward")
#: File names of the faces: the bundled ones and the tutorial's page-4 ones.
FACE_NAMES = {"bundled": ("skyup.tga", "skydown.tga", "skyright.tga", "skyleft.tga",
                          "skyforward.tga", "skybackward.tga"),
              "tutorial": ("alpup.tga", "alpdown.tga", "alpright.tga", "alpleft.tga",
                           "alpforward.tga", "alpback.tga")}
KINDS = ("gouraud", "turbulence", "marble", "mirror", "metal", "plastic", "glass")
#: Relative weights of the material kinds (glass and mirrors are what the issue reports on).
WEIGHTS = (2, 2, 2, 2, 1, 1, 3)


@dataclass
class RandomScene:
    """One drawn scene: its file text and what it holds (for reports and filters)."""
    seed: int
    page: int
    text: str
    kinds: list[str] = field(default_factory=list)    #: material kind of each object
    bumped: int = 0                                     #: objects with a bump
    blob: bool = False
    cubemap: bool = False
    dof: bool = False
    lights: int = 0

    @property
    def tags(self) -> str:
        """A short description: ``glass+mirror, blob, cube map, dof, bump``."""
        out = ["+".join(dict.fromkeys(self.kinds)) or "empty"]
        out += [t for t, on in (("blob", self.blob), ("cube map", self.cubemap),
                                ("dof", self.dof), ("bump", self.bumped > 0)) if on]
        return ", ".join(out)


def _f(x: float) -> str:
    return f"{x:.4g}"


def _v(v) -> str:
    return ", ".join(_f(x) for x in v)


def _colour(r: random.Random, lo: float = 0.05, hi: float = 1.0) -> tuple[float, ...]:
    return tuple(r.uniform(lo, hi) for _ in range(3))


def material(r: random.Random, kind: str) -> tuple[dict, bool]:
    """The keys of a page-4 material of ``kind`` (see the module doc), and whether it has a
    bump."""
    m: dict = {"Type": "gouraud", "Diffuse": _colour(r), "Density": 1.0, "Reflection": 0.0,
               "Refraction": 0.0, "Specular": (0.0, 0.0, 0.0), "Power": 60}
    if kind in ("turbulence", "marble"):
        m["Type"] = kind
        m["Diffuse2"] = _colour(r, 0.0, 0.6)
    if kind in ("gouraud", "turbulence", "marble"):
        m["Reflection"] = r.choice((0.0, 0.0, 0.01, r.uniform(0.0, 0.5)))
        if r.random() < 0.5:
            m["Specular"] = (r.uniform(0.2, 1.2),) * 3
            m["Power"] = r.choice((10, 30, 60, 100))
    elif kind == "mirror":
        m.update(Diffuse=(0.0, 0.0, 0.0), Density=0.0, Reflection=1.0,
                 Specular=(r.uniform(0.5, 1.2),) * 3)
    elif kind == "metal":
        m.update(Density=0.0, Reflection=r.uniform(0.2, 0.9),
                 Specular=(r.uniform(0.2, 1.2),) * 3, Power=r.choice((20, 60)))
    elif kind == "plastic":
        m.update(Density=r.uniform(1.2, 2.0), Reflection=r.uniform(0.3, 1.0),
                 Specular=(r.uniform(0.2, 1.2),) * 3)
    elif kind == "glass":
        refl = r.uniform(0.5, 1.0)
        refr = refl if r.random() < 0.25 else r.uniform(0.5, 1.0)
        m.update(Diffuse=(0.0, 0.0, 0.0), Density=r.uniform(1.1, 2.4), Reflection=refl,
                 Refraction=refr, Specular=(r.uniform(0.0, 1.2),) * 3)
    else:
        raise ValueError(f"unknown material kind {kind!r}")
    bumped = r.random() < 1 / 3
    if bumped:
        m["Bumplevel"] = r.uniform(0.05, 0.3)
    return m, bumped


def _section(name: str, keys: dict) -> str:
    lines = [name, "{"]
    for k, v in keys.items():
        text = v if isinstance(v, str) else _v(v) if isinstance(v, tuple) else _f(v)
        lines.append(f"  {k} = {text};")
    return "\n".join(lines + ["}", ""])


def _free(c, radius: float, placed: list, points: list) -> bool:
    """No overlap with placed spheres (centre, radius) and no listed point inside."""
    for c2, r2 in placed:
        if math.dist(c, c2) < radius + r2 + 1.0:
            return False
    return all(math.dist(c, p) > radius + 5.0 for p in points)


def draw(seed: int, width: int = 160, height: int = 120, page: int = 4,
         cubemap: str = "any", faces: str | os.PathLike | None = None,
         face_names: str = "bundled") -> RandomScene:
    """Scene ``seed`` (module doc). ``cubemap``: ``"any"`` (one time in two), ``"always"`` or
    ``"never"``; ``faces``: their folder (default the bundled scenes/sky), as written into the
    file (:func:`write_scenes` makes it relative); ``face_names``: ``"bundled"`` or
    ``"tutorial"`` (``alp*.tga``)."""
    if page == 2:
        return _draw_page2(seed, width, height)
    if page != 4:
        raise ValueError(f"page must be 2 or 4, got {page}")
    r = random.Random(f"codermind-randscene-{seed}")
    fov = r.uniform(50.0, 100.0)
    pd = (width / 2) / math.tan(math.radians(fov) / 2)
    eye = (width / 2, height / 2, 0.0)

    def ray_point(sx: float, sy: float, depth: float):
        """The point at distance ``depth`` along the pinhole ray of image point (sx, sy)."""
        d = ((sx - eye[0]) / pd, (sy - eye[1]) / pd, 1.0)
        n = math.sqrt(sum(x * x for x in d))
        return tuple(e + depth * x / n for e, x in zip(eye, d))

    def pixel_radius(depth: float, frac: float) -> float:
        """World radius that looks ``frac`` of the image width wide at ``depth``."""
        return frac * width * depth / pd / 2

    lights = []
    for _ in range(r.randint(1, 3)):
        pos = (r.uniform(-1.0, 2.0) * width, r.uniform(-0.5, 2.0) * height,
               r.uniform(-300.0, 500.0))
        lights.append((pos, tuple(r.uniform(0.3, 4.0) for _ in range(3))))
    light_points = [p for p, _ in lights]

    objects = []        # (kind, "sphere" | "blob", keys)
    placed = []
    n_spheres = r.randint(1, 4)
    has_blob = r.random() < 0.5
    for _ in range(n_spheres + (1 if has_blob else 0)):
        is_blob = has_blob and len(objects) == n_spheres
        for _try in range(200):
            depth = r.uniform(250.0, 650.0)
            centre = ray_point(r.uniform(0.1, 0.9) * width, r.uniform(0.15, 0.9) * height, depth)
            size = pixel_radius(depth, r.uniform(0.08, 0.25))
            if is_blob:
                size *= 0.7
                reach = 1.3 * size + size * math.sqrt(10.0)   # beyond: no field at all
                if _free(centre, reach, placed, light_points + [eye]):
                    break
            elif _free(centre, size, placed, light_points + [eye]):
                break
        else:
            continue        # no room: one object fewer
        if is_blob:
            placed.append((centre, 1.3 * size + 1.5 * size))
            centres = [tuple(c + r.uniform(-1.3, 1.3) * size for c in centre) for _ in range(3)]
            keys = {f"Center{k}": centres[k] for k in range(3)}
            keys["Size"] = size
        else:
            placed.append((centre, size))
            keys = {"Center": centre, "Size": size}
        objects.append((r.choices(KINDS, WEIGHTS)[0], "blob" if is_blob else "sphere", keys))

    materials, bumped = [], 0
    for kind, _, _ in objects:
        m, b = material(r, kind)
        materials.append(m)
        bumped += b

    with_cubemap = {"any": r.random() < 0.5, "always": True, "never": False}[cubemap]
    dof = r.random() < 0.5
    top = {"Version.Major": "1", "Version.Minor": "3", "Image.Width": str(width),
           "Image.Height": str(height), "Perspective.Type": "conic",
           "Perspective.FOV": fov,
           "Perspective.ClearPoint": (math.dist(eye, placed[0][0]) if dof and placed else 450.0),
           "Perspective.Dispersion": r.uniform(2.0, 10.0) if dof else 0.0,
           "Tonemap.Midpoint": r.uniform(0.5, 0.8), "Tonemap.Power": r.uniform(2.0, 4.0),
           "Tonemap.Black": r.choice((0.0, r.uniform(0.02, 0.2))),
           "NumberOfMaterials": str(max(len(materials), 1)),
           "NumberOfSpheres": str(sum(o[1] == "sphere" for o in objects)),
           "NumberOfBlobs": str(sum(o[1] == "blob" for o in objects)),
           "NumberOfLights": str(len(lights)),
           "Complexity": str(r.choice((1, 2, 4, 16)))}
    if with_cubemap:
        folder = Path(faces) if faces is not None else SKY
        for key, name in zip(FACE_KEYS, FACE_NAMES[face_names]):
            top[f"Cubemap.{key}"] = (folder / name).as_posix()
        top["Cubemap.Exposed"] = "true"
        top["Cubemap.sRGB"] = "true"
    if not materials:
        materials.append(material(r, "gouraud")[0])

    parts = [f"// Random tutorial scene, seed {seed} (codermind_harness.randscene)\n",
             _section("Scene", top)]
    parts += [_section(f"Material{i}", m) for i, m in enumerate(materials)]
    k_sphere = k_blob = 0
    for i, (_, shape, keys) in enumerate(objects):
        if shape == "sphere":
            parts.append(_section(f"Sphere{k_sphere}", {**keys, "Material.Id": str(i)}))
            k_sphere += 1
        else:
            parts.append(_section(f"Blob{k_blob}", {**keys, "Material.Id": str(i)}))
            k_blob += 1
    for i, (pos, intensity) in enumerate(lights):
        parts.append(_section(f"Light{i}", {"Position": pos, "Intensity": intensity}))
    return RandomScene(seed, 4, "\n".join(parts), [o[0] for o in objects], bumped,
                       any(o[1] == "blob" for o in objects), with_cubemap, dof, len(lights))


def _draw_page2(seed: int, width: int, height: int) -> RandomScene:
    """A page-2 scene (version 1.1): orthographic, Lambert + Blinn, mirror reflection."""
    r = random.Random(f"codermind-randscene-page2-{seed}")
    lights = [((r.uniform(-0.5, 1.5) * width, r.uniform(-0.5, 1.5) * height,
                r.uniform(-1000.0, 0.0)), tuple(r.uniform(0.3, 2.0) for _ in range(3)))
              for _ in range(r.randint(1, 3))]
    spheres, placed = [], []
    for _ in range(r.randint(1, 4)):
        for _try in range(200):
            size = r.uniform(0.1, 0.3) * min(width, height)
            c = (r.uniform(0, width), r.uniform(10, height), r.uniform(-100.0, 300.0))
            if _free(c, size, placed, [p for p, _ in lights]):
                break
        else:
            continue
        placed.append((c, size))
        spheres.append((c, size))
    materials = [{"Diffuse": _colour(r), "Reflection": r.choice((0.0, r.uniform(0.0, 0.8))),
                  "Specular": (r.uniform(0.0, 1.0),) * 3, "Power": r.choice((10, 30, 60))}
                 for _ in spheres]
    top = {"Version.Major": "1", "Version.Minor": "1", "Image.Width": str(width),
           "Image.Height": str(height), "NumberOfMaterials": str(len(materials)),
           "NumberOfSpheres": str(len(spheres)), "NumberOfLights": str(len(lights))}
    parts = [f"// Random tutorial scene (page 2), seed {seed} (codermind_harness.randscene)\n",
             _section("Scene", top)]
    parts += [_section(f"Material{i}", m) for i, m in enumerate(materials)]
    parts += [_section(f"Sphere{i}", {"Center": c, "Size": s, "Material.Id": str(i)})
              for i, (c, s) in enumerate(spheres)]
    parts += [_section(f"Light{i}", {"Position": p, "Intensity": c})
              for i, (p, c) in enumerate(lights)]
    return RandomScene(seed, 2, "\n".join(parts), ["gouraud"] * len(spheres), 0, False, False,
                       False, len(lights))


def write_scene(folder: str | os.PathLike, seed: int, *, stem: str = "random",
                **options) -> tuple[Path, RandomScene]:
    """Scene ``seed`` (:func:`draw` with ``options``) written as ``folder/STEM-SEED.txt``, its
    face paths relative to ``folder``; the path and the scene."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    faces = Path(options.pop("faces", None) or SKY).resolve()
    try:
        rel = Path(os.path.relpath(faces, folder.resolve()))
    except ValueError:          # another drive (Windows)
        rel = faces
    scene = draw(seed, faces=rel, **options)
    path = folder / f"{stem}-{seed}.txt"
    path.write_text(scene.text, encoding="utf-8")
    return path, scene


def write_scenes(folder: str | os.PathLike, count: int, seed: int = 0, **options) -> list[Path]:
    """Scenes ``seed`` .. ``seed + count - 1`` written by :func:`write_scene`; their paths."""
    return [write_scene(folder, s, **options)[0] for s in range(seed, seed + count)]


# -- errors to inject (benchmarks/random_compare.py --power) ----------------------------------

_SECTION = re.compile(r"(?m)^[ \t]*(\w+)\s*\{([^}]*)\}")
ERRORS = ("colour", "light", "density", "bump", "camera")


def _number(text: str) -> float:
    return float(text.strip().rstrip("fF"))


def _scaled(body: str, key: str, factor: float) -> str | None:
    """``body`` with the value of ``key`` (one number or three) times ``factor``."""
    m = re.search(rf"(?m)(^|[;{{\s])({re.escape(key)}\s*=\s*)([^;]+);", body)
    if m is None:
        return None
    values = [_number(v) for v in m.group(3).split(",")]
    new = ", ".join(f"{v * factor:.6g}" for v in values)
    return body[:m.start(3)] + new + body[m.end(3):]


def _value(body: str, key: str) -> list[float] | None:
    m = re.search(rf"(?m)(^|[;{{\s]){re.escape(key)}\s*=\s*([^;]+);", body)
    return None if m is None else [_number(v) for v in m.group(2).split(",")]


def inject(text: str, error: str, fraction: float) -> str | None:
    """A scene file's text with one error of relative size ``fraction``, or None where the
    scene has nothing it applies to: ``colour``: the first material with a non-zero
    ``Diffuse`` (and its ``Diffuse2``) times 1 + fraction; ``light``: ``Light0``'s
    ``Intensity``; ``density``: the first refracting material's ``Density`` (> 1, with
    ``Refraction`` > 0); ``bump``: the first non-zero ``Bumplevel``; ``camera``:
    ``Perspective.FOV`` (page 4)."""
    if error not in ERRORS:
        raise ValueError(f"unknown error {error!r}; one of {', '.join(ERRORS)}")
    factor = 1.0 + fraction
    for m in _SECTION.finditer(text):
        name, body = m.group(1), m.group(2)
        new = None
        if error == "colour" and name.startswith("Material"):
            d = _value(body, "Diffuse")
            if d and max(abs(v) for v in d) > 0:
                new = _scaled(body, "Diffuse", factor)
                new = _scaled(new, "Diffuse2", factor) or new
        elif error == "light" and name == "Light0":
            new = _scaled(body, "Intensity", factor)
        elif error == "density" and name.startswith("Material"):
            d, t = _value(body, "Density"), _value(body, "Refraction")
            if d and t and d[0] > 1 and t[0] > 0:
                new = _scaled(body, "Density", factor)
        elif error == "bump" and name.startswith("Material"):
            b = _value(body, "Bumplevel")
            if b and b[0] > 0:
                new = _scaled(body, "Bumplevel", factor)
        elif error == "camera" and name == "Scene":
            new = _scaled(body, "Perspective.FOV", factor)
        if new is not None:
            return text[:m.start(2)] + new + text[m.end(2):]
    return None


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WxH, e.g. 160x120, got {text!r}") from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"expected a positive size, got {text!r}")
    return w, h


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m codermind_harness.randscene",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="folder to write the scenes into")
    ap.add_argument("--count", type=int, default=10, help="how many scenes (default 10)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the first (default 0)")
    ap.add_argument("--page", type=int, choices=(2, 4), default=4)
    ap.add_argument("--size", type=_size, default=(160, 120), metavar="WxH",
                    help="image size (default 160x120)")
    ap.add_argument("--cubemap", choices=("any", "always", "never"), default="any")
    ap.add_argument("--faces", metavar="DIR", help="cube-map faces' folder (default: the "
                    "bundled scenes/sky)")
    ap.add_argument("--face-names", choices=tuple(FACE_NAMES), default="bundled",
                    help="tutorial: the page-4 faces alp*.tga")
    args = ap.parse_args(argv)
    if args.count < 1:
        ap.error("--count must be >= 1")
    paths = write_scenes(args.out, args.count, args.seed, page=args.page,
                         width=args.size[0], height=args.size[1], cubemap=args.cubemap,
                         faces=args.faces, face_names=args.face_names)
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
