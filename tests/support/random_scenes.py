"""Random small Mitsuba scenes that nobody tuned anything to, for tests/plugins/test_random_scenes.py
and benchmarks/random_scenes.py.

A scene is drawn by the hypothesis strategy :func:`scenes` as a *spec*: plain JSON data
(so that it can be printed, stored with a result and sent to a worker process) in the form of
an ``mi.load_dict`` dictionary without its integrator, where

- a transform is ``{"transform": [[op, *args], ...]}``, the chained calls of
  ``mi.ScalarTransform4f()`` (``["translate", v]``, ``["rotate", axis, degrees]``,
  ``["scale", v]``, ``["look_at", origin, target, up]``);
- a file name ``"@assets/NAME"`` lies in the folder :func:`write_assets` fills (a small PLY,
  an OBJ and an EXR environment map) and ``"@sky/NAME"`` in the bundled ``scenes/sky``.

:func:`build` turns a spec into the dictionary, :func:`integrator` gives each integrator's
dictionary, and :func:`render` loads and renders one, reporting a refusal (an exception) as
data. ``python tests/support/random_scenes.py`` is a worker: it reads one JSON job per line on stdin
and answers one JSON line per job, so that a crash of Mitsuba (a segfault in a scalar
variant) ends the worker, not the test run (:class:`Worker`).

What a spec holds, all drawn at random: a world size ``s`` from 0.01 to 1000 units (not the
tutorial's pixel scale only) around the origin; a ``perspective``, ``conic`` (disc or
tutorial lens, pinhole or not) or ``tutorialortho`` camera 3-5 ``s`` away looking at it, 8 to
16 pixels square; one to three objects within ``s`` of the origin (``sphere``,
``rectangle``, ``cube``, a PLY or OBJ mesh, a ``blob`` of 1-4 sources with either
``tessellate``, ``field``, ``normals``) and maybe a floor; each with a built-in BSDF
(``diffuse``, ``roughplastic``, ``dielectric``, ``conductor``) or ours (``tutorial`` on
page 1, 2 or 4, ``blinnphong``), possibly inside ``noisebump``, reflectances possibly a
``perlin``, ``turbulence`` or ``marble`` texture; one to three lights (an ``area`` rectangle
or sphere, ``point``, ``tutorialpoint``, and at most one environment: ``constant``,
``envmap`` or ``cubemap``). A few values users get wrong are drawn too (a ``blinnphong``
whose albedos sum above 1, or whose specular albedo exceeds 1), so that refusals happen;
everything else is valid.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[2]
SKY = ROOT / "scenes" / "sky"
FACES = ("up", "down", "right", "left", "forward", "backward")

#: Our plugins (the ``type`` of a node); every other type in a spec is Mitsuba's own.
OURS = {"tutorial", "blinnphong", "noisebump", "perlin", "turbulence", "marble", "blob",
        "conic", "tutorialortho", "tutorialpoint", "cubemap", "tutorialpath"}
#: Integrators each scene is rendered with (``tutorialpath`` clean; strict where allowed).
INTEGRATORS = ("path", "prb", "direct", "tutorialpath", "tutorialpath_strict")
#: ``prb`` exists only in the differentiable (``*_ad_*``) variants.
SCALAR_INTEGRATORS = ("path", "direct", "tutorialpath", "tutorialpath_strict")


# -- drawing helpers -------------------------------------------------------------------------

def uniform(lo: float, hi: float):
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def log_uniform(lo: float, hi: float):
    return st.floats(math.log10(lo), math.log10(hi)).map(
        lambda e: min(hi, max(lo, 10.0 ** e)))


def rgb(lo: float = 0.0, hi: float = 1.0):
    return st.tuples(uniform(lo, hi), uniform(lo, hi), uniform(lo, hi)).map(
        lambda c: {"type": "rgb", "value": list(c)})


def point(draw, radius: float) -> list[float]:
    """A point in the cube [-radius, radius]^3."""
    return [draw(uniform(-radius, radius)) for _ in range(3)]


def direction(draw, min_elevation: float = -90.0, max_elevation: float = 90.0) -> list[float]:
    azimuth = math.radians(draw(uniform(0.0, 360.0)))
    elevation = math.radians(draw(uniform(min_elevation, max_elevation)))
    return [math.cos(elevation) * math.cos(azimuth), math.sin(elevation),
            math.cos(elevation) * math.sin(azimuth)]


def axis(draw) -> list[float]:
    return direction(draw)


def transform(*ops) -> dict:
    return {"transform": [list(op) for op in ops]}


def placed(draw, s: float, size: float, uniform_scale: bool = True) -> dict:
    """translate(a point within 0.8 s) . rotate(random) . scale(size)."""
    scale = [size] * 3 if uniform_scale else [size * draw(uniform(0.6, 1.4)) for _ in range(3)]
    return transform(["translate", point(draw, 0.8 * s)],
                     ["rotate", axis(draw), draw(uniform(0.0, 360.0))], ["scale", scale])


# -- textures and BSDFs ----------------------------------------------------------------------

@st.composite
def texture(draw, s: float):
    """One of our solid textures, with values mostly in [0, 1] (turbulence is unclamped)."""
    kind = draw(st.sampled_from(["perlin", "turbulence", "marble"]))
    t = {"type": kind, "gradient": draw(st.sampled_from(["tutorial", "reference"]))}
    if kind == "perlin":
        t.update(frequency=draw(uniform(0.5, 5.0)) / s, scale=0.5, offset=0.5)
    else:
        t.update(frequency=draw(uniform(0.2, 2.0)) / s, octaves=draw(st.integers(1, 6)),
                 color0=draw(rgb()), color1=draw(rgb()))
        if kind == "marble":
            t["stripe_frequency"] = draw(uniform(0.5, 5.0)) / s
    if draw(st.booleans()):
        t["to_world"] = transform(["translate", point(draw, s)],
                                  ["rotate", axis(draw), draw(uniform(0.0, 360.0))])
    return t


def colour_or_texture(draw, s: float, lo: float = 0.0, hi: float = 1.0):
    return draw(st.one_of(rgb(lo, hi), texture(s)))


@st.composite
def bsdf(draw, s: float, tutorial_only: bool = False):
    kind = "tutorial" if tutorial_only else draw(st.sampled_from(
        ["diffuse", "roughplastic", "dielectric", "conductor", "tutorial", "blinnphong"]))
    if kind == "diffuse":
        b = {"type": "diffuse", "reflectance": colour_or_texture(draw, s)}
    elif kind == "roughplastic":
        b = {"type": "roughplastic", "alpha": draw(uniform(0.05, 0.5)),
             "int_ior": draw(uniform(1.2, 1.9)),
             "diffuse_reflectance": colour_or_texture(draw, s)}
    elif kind == "dielectric":
        b = {"type": "dielectric", "int_ior": draw(uniform(1.05, 2.0))}
    elif kind == "conductor":
        b = {"type": "conductor", "material": draw(st.sampled_from(["none", "Au", "Cu", "Al"]))}
    elif kind == "tutorial":
        page = draw(st.sampled_from([1, 2, 4]))
        b = {"type": "tutorial", "page": page, "diffuse": colour_or_texture(draw, s),
             "specular": draw(rgb(0.0, 1.5)), "power": draw(uniform(0.0, 200.0)),
             "reflection": draw(uniform(0.0, 1.0))}
        if page == 4:
            b["refraction"] = draw(uniform(0.0, 1.0))
            b["density"] = draw(st.one_of(st.just(0.0), uniform(1.0, 2.0)))
    else:
        # albedos summing up to 1.2: blinnphong refuses a uniform sum above 1 (a refusal)
        kd = draw(uniform(0.0, 0.8))
        b = {"type": "blinnphong", "diffuse_reflectance": {"type": "rgb", "value": kd},
             "specular_reflectance": {"type": "rgb", "value": draw(uniform(0.0, 1.2 - kd))},
             "exponent": draw(log_uniform(1.0, 1000.0))}
    if draw(st.integers(0, 3)) == 0:
        b = {"type": "noisebump", "bumplevel": draw(uniform(0.0, 1.0)),
             "frequency": draw(uniform(0.5, 5.0)) / s,
             "gradient": draw(st.sampled_from(["tutorial", "reference"])),
             "leak_check": draw(st.booleans()), "nested": b}
        if draw(st.booleans()):
            b["to_world"] = transform(["translate", point(draw, s)],
                                      ["rotate", axis(draw), draw(uniform(0.0, 360.0))])
    return b


# -- shapes ----------------------------------------------------------------------------------

@st.composite
def blob(draw, s: float):
    size = s * draw(uniform(0.2, 0.5))
    n = draw(st.integers(1, 4))
    centre = point(draw, 0.6 * s)
    field = draw(st.sampled_from(["tutorial", "exact"]))
    tessellate = field == "exact" or draw(st.booleans())
    b = {"type": "blob", "radius": size, "field": field, "tessellate": tessellate,
         "normals": draw(st.sampled_from(["exact", "field", "flat"]))}
    offsets = [point(draw, 1.2 * size) for _ in range(n)]
    if draw(st.booleans()):            # sources in world space
        b["centers"] = " ".join(f"{c + o:.9g}" for off in offsets
                                for c, o in zip(centre, off))
    else:                              # unit object space, placed by to_world
        for i, off in enumerate(offsets):
            b[f"center{i}"] = [o / size for o in off]
        b["radius"] = 1.0
        b["to_world"] = transform(["translate", centre],
                                  ["rotate", axis(draw), draw(uniform(0.0, 360.0))],
                                  ["scale", [size * draw(uniform(0.7, 1.3)) for _ in range(3)]])
    return b


@st.composite
def shape(draw, s: float, tutorial_only: bool = False):
    kind = draw(st.sampled_from(["sphere", "rectangle", "cube", "ply", "obj", "blob", "blob"]))
    size = s * draw(uniform(0.2, 0.6))
    if kind == "sphere":
        d = {"type": "sphere", "center": point(draw, 0.8 * s), "radius": size}
    elif kind in ("rectangle", "cube"):
        d = {"type": kind, "to_world": placed(draw, s, size, uniform_scale=kind == "cube")}
    elif kind in ("ply", "obj"):
        d = {"type": kind, "filename": f"@assets/{'tetra.ply' if kind == 'ply' else 'octa.obj'}",
             "to_world": placed(draw, s, size, uniform_scale=False)}
    else:
        d = draw(blob(s))
    d["bsdf"] = draw(bsdf(s, tutorial_only))
    return d


# -- lights ----------------------------------------------------------------------------------

@st.composite
def light(draw, s: float, delta_only: bool = False):
    kind = draw(st.sampled_from(["point", "tutorialpoint"] if delta_only else
                                ["area_rectangle", "area_sphere", "point", "tutorialpoint"]))
    where = [c * s * draw(uniform(2.0, 3.0)) for c in direction(draw, 10.0, 80.0)]
    if kind == "area_rectangle":
        # a panel facing the origin
        return {"type": "rectangle", "emitter": {"type": "area", "radiance": draw(rgb(1.0, 8.0))},
                "to_world": transform(["look_at", where, [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                                      ["scale", [s * draw(uniform(0.2, 0.8))] * 3]),
                "bsdf": {"type": "diffuse"}}
    if kind == "area_sphere":
        return {"type": "sphere", "center": where, "radius": s * draw(uniform(0.05, 0.3)),
                "emitter": {"type": "area", "radiance": draw(rgb(1.0, 10.0))}}
    if kind == "point":
        return {"type": "point", "position": where,
                "intensity": {"type": "rgb", "value": [draw(uniform(1.0, 20.0)) * s * s] * 3}}
    falloff = draw(st.booleans())
    scale = s * s if falloff else 1.0
    return {"type": "tutorialpoint", "position": where, "falloff": falloff,
            "intensity": {"type": "rgb", "value": [draw(uniform(0.2, 3.0)) * scale
                                                   for _ in range(3)]}}


@st.composite
def environment(draw, others: int, background_only: bool = False):
    """An environment emitter, or None. A ``cubemap`` in background mode only beside another
    light (it is never sampled, and a scene with nothing to sample cannot be built)."""
    kind = draw(st.sampled_from(["none", "cubemap"] if background_only and others else
                                ["none"] if background_only else
                                ["none", "constant", "envmap", "cubemap"]))
    rotation = ["rotate", axis(draw), draw(uniform(0.0, 360.0))]
    if kind == "constant":
        return {"type": "constant", "radiance": draw(rgb(0.05, 1.0))}
    if kind == "envmap":
        return {"type": "envmap", "filename": "@assets/sky.exr",
                "scale": draw(uniform(0.2, 2.0)), "to_world": transform(rotation)}
    if kind == "cubemap":
        mode = "background" if background_only else \
            draw(st.sampled_from(["light", "background"])) if others else "light"
        return {"type": "cubemap", "mode": mode, "scale": draw(uniform(0.2, 2.0)),
                "to_world": transform(rotation),
                **{face: f"@sky/sky{face}.exr" for face in FACES}}
    return None


# -- the camera ------------------------------------------------------------------------------

@st.composite
def sensor(draw, s: float):
    distance = s * draw(uniform(3.0, 5.0))
    eye = [c * distance for c in direction(draw, -60.0, 75.0)]
    target = point(draw, 0.2 * s)
    look = ["look_at", eye, target, [0.0, 1.0, 0.0]]
    size = draw(st.integers(8, 16))
    film = {"type": "hdrfilm", "width": size, "height": size,
            "rfilter": {"type": draw(st.sampled_from(["box", "gaussian", "tent"]))}}
    kind = draw(st.sampled_from(["perspective", "conic", "tutorialortho"]))
    d = {"type": kind, "film": film, "sampler": {"type": "independent"}}
    if kind == "tutorialortho":
        half = s * draw(uniform(1.2, 2.0))
        d.update(to_world=transform(look, ["scale", [half, half, 1.0]]), near_clip=0.0,
                 far_clip=3.0 * distance)
        return d
    d.update(to_world=transform(look), fov=draw(uniform(35.0, 60.0)))
    if kind == "conic":
        d["lens"] = draw(st.sampled_from(["disc", "tutorial"]))
        if draw(st.booleans()):
            aperture = s * draw(uniform(0.0, 0.1))
            d["aperture_radius" if d["lens"] == "disc" else "aperture"] = aperture
            d["focus_distance"] = distance * draw(uniform(0.8, 1.2))
        if draw(st.booleans()):
            d.update(near_clip=0.0, far_clip=10.0 * distance)
    return d


# -- the scene -------------------------------------------------------------------------------

@st.composite
def scenes(draw):
    """A spec: ``{"scene": <load_dict data without integrator>, "max_depth": int}``. One
    scene in four is in the tutorial's style (every BSDF ``tutorial``, delta lights and at
    most a background cube map), which ``tutorialpath``'s strict mode accepts."""
    s = draw(log_uniform(0.01, 1000.0))
    tutorial = draw(st.integers(0, 3)) == 0
    scene = {"type": "scene", "sensor": draw(sensor(s))}
    for i in range(draw(st.integers(1, 3))):
        scene[f"obj{i}"] = draw(shape(s, tutorial))
    if draw(st.booleans()):
        scene["floor"] = {"type": "rectangle", "bsdf": draw(bsdf(s, tutorial)),
                          "to_world": transform(["translate", [0.0, -s, 0.0]],
                                                ["rotate", [1.0, 0.0, 0.0], -90.0],
                                                ["scale", [3.0 * s] * 3])}
    lights = draw(st.integers(1 if tutorial else 0, 2))
    for i in range(lights):
        scene[f"light{i}"] = draw(light(s, tutorial))
    env = draw(environment(lights, tutorial))
    if env is not None:
        scene["env"] = env
    elif lights == 0:
        scene["light0"] = draw(light(s))
    return {"scene": scene, "max_depth": draw(st.integers(1, 5))}


# -- what a spec contains --------------------------------------------------------------------

def nodes(d: dict, path: str = ""):
    """``(path, node)`` of every plugin dictionary in ``d`` (dotted keys as ``mi.traverse``'s)."""
    for key, value in d.items():
        if isinstance(value, dict) and "type" in value:
            here = f"{path}.{key}" if path else key
            yield here, value
            yield from nodes(value, here)


def types(spec: dict) -> set[str]:
    return {node["type"] for _, node in nodes(spec["scene"])}


def has_analytic_blob(spec: dict) -> bool:
    """A ``blob`` without a mesh: only ``tutorialpath`` sees it."""
    return any(n["type"] == "blob" and not n.get("tessellate", True)
               for _, n in nodes(spec["scene"]))


def strict_allowed(spec: dict) -> bool:
    """``tutorialpath`` strict takes only ``tutorial`` BSDFs (in ``noisebump`` or not) and
    no light that has to be sampled (an area light, an environment that is not a background
    cube map)."""
    for _, n in nodes(spec["scene"]):
        if n["type"] == "area" or n["type"] in ("constant", "envmap") or \
                n["type"] == "cubemap" and n.get("mode") != "background":
            return False
    for key, n in spec["scene"].items():
        if isinstance(n, dict) and "bsdf" in n and "emitter" not in n:
            b = n["bsdf"]
            if b["type"] == "noisebump":
                b = b["nested"]
            if b["type"] != "tutorial":
                return False
    return True


def integrator(name: str, max_depth: int, exact_hits: bool = False) -> dict:
    """The integrator dictionary: ``path`` without Russian roulette (``rr_depth`` beyond
    ``max_depth``), ``tutorialpath`` clean or (``tutorialpath_strict``) strict."""
    if name == "path":
        return {"type": "path", "max_depth": max_depth, "rr_depth": max_depth + 1}
    if name == "prb":
        return {"type": "prb", "max_depth": max_depth, "rr_depth": max_depth + 1}
    if name == "direct":
        return {"type": "direct"}
    quirks = "strict" if name == "tutorialpath_strict" else "clean"
    return {"type": "tutorialpath", "max_depth": max_depth, "exact_hits": exact_hits,
            "quirks": quirks}


# -- from spec to Mitsuba --------------------------------------------------------------------

def write_assets(mi, folder: Path) -> Path:
    """A tetrahedron (ASCII PLY), an octahedron (OBJ) and a 16 x 8 EXR environment map."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "tetra.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 4\nproperty list uchar int vertex_indices\n"
        "end_header\n-1 -1 -1\n1 1 -1\n1 -1 1\n-1 1 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    v = ["1 0 0", "-1 0 0", "0 1 0", "0 -1 0", "0 0 1", "0 0 -1"]
    f = ["1 3 5", "3 2 5", "2 4 5", "4 1 5", "3 1 6", "2 3 6", "4 2 6", "1 4 6"]
    (folder / "octa.obj").write_text("".join(f"v {x}\n" for x in v) +
                                     "".join(f"f {x}\n" for x in f))
    exr = folder / "sky.exr"
    if not exr.exists():
        import numpy as np
        y = np.linspace(0.0, 1.0, 8, dtype=np.float32)[:, None, None]
        x = np.linspace(0.0, 1.0, 16, dtype=np.float32)[None, :, None]
        image = np.ascontiguousarray(0.2 + np.concatenate(
            [y + 0 * x, 0.5 * x + 0 * y, 1.0 - y + 0 * x], axis=2) * 2.0, dtype=np.float32)
        mi.Bitmap(image).write(str(exr))
    return folder


def build(spec: dict, mi, assets: Path, size: int | None = None, name: str = "path",
          exact_hits: bool = False) -> dict:
    """The ``mi.load_dict`` dictionary of ``spec`` with integrator ``name``; ``size``
    replaces the film's width and height (scalar variants render 4 x 4)."""

    def convert(value):
        if isinstance(value, dict):
            if set(value) == {"transform"}:
                t = mi.ScalarTransform4f()
                for op, *args in value["transform"]:
                    t = getattr(t, op)(*args)
                return t
            return {k: convert(v) for k, v in value.items()}
        if isinstance(value, str) and value.startswith("@assets/"):
            return str(Path(assets) / value[len("@assets/"):])
        if isinstance(value, str) and value.startswith("@sky/"):
            return str(SKY / value[len("@sky/"):])
        return value

    d = convert(spec["scene"])
    if size is not None:
        d["sensor"]["film"].update(width=size, height=size)
    d["integrator"] = integrator(name, spec["max_depth"], exact_hits)
    return d


def load(mi, d: dict):
    """``mi.load_dict`` and the step Python emitters need after loading (codermind.scene)."""
    from codermind.scene import attach_emitters
    scene = mi.load_dict(d)
    attach_emitters(scene)
    return scene


def load_file(mi, path, **params):
    """``mi.load_file`` with the step Python emitters need after loading (codermind.scene);
    ``params`` replace the file's ``<default>`` values."""
    from codermind.scene import attach_emitters
    scene = mi.load_file(str(path), **{k: str(v) for k, v in params.items()})
    attach_emitters(scene)
    return scene


def refusal(error: BaseException) -> str:
    """The one-line message of an error (codermind.errors.one_line)."""
    from codermind.errors import one_line
    return one_line(str(error))


def render(mi, spec: dict, assets: Path, name: str, seeds=(0,), spp: int = 4,
           size: int | None = None, exact_hits: bool = False) -> dict:
    """Load ``spec`` with integrator ``name`` and render it once per seed:
    ``{"images": [float64 arrays]}``, or ``{"error": type, "message": one line}``."""
    import numpy as np
    try:
        scene = load(mi, build(spec, mi, assets, size, name, exact_hits))
        images = [np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
                  for seed in seeds]
    except Exception as e:    # a refusal: judged by the caller (is_refusal)
        return {"error": type(e).__name__, "message": refusal(e), "raw": str(e),
                **cause(e)}
    return {"images": images}


def cause(error: BaseException) -> dict:
    """The innermost exception behind ``error`` (a Dr.Jit loop re-raises what its body
    raised as "encountered an exception (see above)"), where there is one."""
    inner = error
    while inner.__cause__ is not None:
        inner = inner.__cause__
    if inner is error:
        return {}
    import traceback
    where = traceback.extract_tb(inner.__traceback__)[-1] if inner.__traceback__ else None
    return {"cause": f"{type(inner).__name__}: {refusal(inner)}"
                     + (f" ({Path(where.filename).name}:{where.lineno})" if where else "")}


def is_refusal(result: dict, spec: dict) -> bool:
    """A ValueError or RuntimeError whose one-line message names one of the scene's plugin
    types and a quoted parameter name (``'name'`` or ``"name"``)."""
    import re
    if result.get("error") not in ("ValueError", "RuntimeError"):
        return False
    message = result["message"]
    if "\n" in message:
        return False
    named = any(re.search(rf"\b{re.escape(t)}\b", message)
                for t in types(spec) | {"tutorialpath", "path", "prb", "direct"})
    quoted = re.search(r"""(['"])[A-Za-z_][\w.]*\1""", message) is not None
    return named and quoted


def finite(result: dict) -> bool | None:
    """Whether every film of a :func:`render` result is free of NaN and inf (None: refused)."""
    import numpy as np
    if "images" not in result:
        return None
    return all(bool(np.isfinite(image).all()) for image in result["images"])


def compare(mi, spec: dict, assets: Path, k: int = 8, spp: int = 16,
            significance: float = 1e-3) -> dict:
    """``path`` (no Russian roulette) against ``tutorialpath`` clean (``exact_hits`` false)
    on ``spec``: K renders a side with distinct seeds (path 0..K-1, tutorialpath K..2K-1)
    and tests/support/zstat.py's ``t_test`` at ``significance`` per scene. Returns both
    :func:`render` results and ``"test"``, the ZTest (None where a side was refused or
    rendered a non-finite value)."""
    from . import zstat
    a = render(mi, spec, assets, "path", seeds=range(k), spp=spp)
    b = render(mi, spec, assets, "tutorialpath", seeds=range(k, 2 * k), spp=spp)
    test = None
    if finite(a) and finite(b):
        test = zstat.t_test(zstat.renders(a["images"]), zstat.renders(b["images"]),
                            significance)
    return {"path": a, "tutorialpath": b, "test": test}


def misspellings(spec: dict, plugin: str | None = None) -> list[tuple[str, str, str]]:
    """``(node path, parameter, misspelling)`` for every plain (non-plugin) parameter of
    every node of our plugins (of type ``plugin`` only, if given) in ``spec``: the name with
    one character dropped, where that is no name the node has."""
    out = []
    for path, node in nodes(spec["scene"]):
        if node["type"] not in OURS or plugin is not None and node["type"] != plugin:
            continue
        for key, value in node.items():
            if key == "type" or isinstance(value, dict) and "type" in value:
                continue
            for i in range(len(key)):
                typo = key[:i] + key[i + 1:]
                if typo and typo not in node and (path, key, typo) not in out:
                    out.append((path, key, typo))
    return out


def misspelled(spec: dict, path: str, key: str, typo: str) -> dict:
    """A copy of ``spec`` whose node ``path`` has parameter ``key``'s value also under the
    misspelled name ``typo``."""
    import copy
    wrong = copy.deepcopy(spec)
    node = dict(nodes(wrong["scene"]))[path]
    node[typo] = node[key]
    return wrong


def refuses_typo(mi, spec: dict, assets: Path, path: str, key: str, typo: str) -> dict:
    """Load ``spec`` with one misspelled parameter added: ``{"refused": bool, "message": one
    line, "names_it": the message is one line naming the plugin type and the typo in
    quotes}``."""
    import re
    plugin = dict(nodes(spec["scene"]))[path]["type"]
    try:
        load(mi, build(misspelled(spec, path, key, typo), mi, assets))
    except (ValueError, RuntimeError) as e:
        message = refusal(e)
        return {"refused": True, "message": message, "names_it": "\n" not in message and bool(
            re.search(rf"\b{plugin}\b", message)) and bool(
            re.search(rf"""(['"]){re.escape(typo)}\1""", message))}
    return {"refused": False, "message": "", "names_it": False}


# -- a worker process: one JSON job per line on stdin, one JSON answer per line ---------------

class Worker:
    """A ``python tests/support/random_scenes.py`` process, started on first use and again after it
    died; :meth:`run` sends one job and returns the answer, or ``{"exit": status}`` if the
    process ended without answering (a crash)."""

    def __init__(self, assets: Path, timeout: float = 600.0, env: dict | None = None):
        self.assets, self.timeout, self.env, self.process = Path(assets), timeout, env, None

    def run(self, job: dict) -> dict:
        import subprocess
        if self.process is None or self.process.poll() is not None:
            self.process = subprocess.Popen(
                [sys.executable, __file__, str(self.assets)], stdin=subprocess.PIPE,
                stdout=subprocess.PIPE, text=True, env=self.env)
        self.process.stdin.write(json.dumps(job) + "\n")
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        if not line:
            status = self.process.wait(timeout=self.timeout)
            self.process = None
            return {"exit": status}
        return json.loads(line)

    def close(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.stdin.close()
            self.process.wait(timeout=60)
        self.process = None


def _serve(assets: Path) -> None:
    """The worker's loop. A job: ``{"kind", "variant", "spec", ...}``, one of

    - ``render`` (``integrator``, ``spp``, ``size``, ``seeds``): ``{"error", "message"}``
      or ``{"finite": bool, "mean": float}``;
    - ``compare`` (``k``, ``spp``, ``significance``): :func:`compare`'s outcome,
      ``{"path": ..., "tutorialpath": ... (as for render), "passed", "min_p", "alpha"}``;
    - ``print``: ``{"loaded": False, "message"}`` (refused) or ``{"loaded": True, "ok":
      bool, "message"}`` for ``str(scene)`` of the scene with ``path``;
    - ``typo`` (``path``, ``key``, ``typo``): :func:`refuses_typo`'s answer;
    - ``file`` (``file``, ``params``, ``spp``; ``spec`` unused): a scene file rendered with
      its own integrator, ``{"finite", "mean", "printed"}``."""
    import os
    answers = os.fdopen(os.dup(1), "w")    # the answers' channel; Mitsuba's log goes to stderr
    os.dup2(2, 1)
    import mitsuba as mi
    import numpy as np

    def summary(result: dict) -> dict:
        if "images" in result:
            return {"finite": finite(result), "mean": float(np.nanmean(result["images"]))}
        return {k: v for k, v in result.items() if k != "raw"}

    for line in sys.stdin:
        job = json.loads(line)
        mi.set_variant(job["variant"])
        import codermind  # noqa: F401  (registers the plugins)
        kind, spec = job.get("kind", "render"), job["spec"]
        if kind == "render":
            result = summary(render(mi, spec, assets, job["integrator"],
                                    seeds=job.get("seeds", [0]), spp=job.get("spp", 2),
                                    size=job.get("size")))
        elif kind == "compare":
            out = compare(mi, spec, assets, job.get("k", 8), job.get("spp", 16),
                          job.get("significance", 1e-3))
            test = out["test"]
            result = {"path": summary(out["path"]), "tutorialpath": summary(out["tutorialpath"]),
                      "passed": None if test is None else test.passed,
                      "min_p": None if test is None else test.min_p,
                      "alpha": None if test is None else test.alpha}
        elif kind == "print":
            try:
                scene = load(mi, build(spec, mi, assets))
            except (ValueError, RuntimeError) as e:     # a refusal (judged elsewhere)
                result = {"loaded": False, "message": refusal(e)}
            else:
                try:
                    result = {"loaded": True, "ok": str(scene).startswith("Scene["),
                              "message": ""}
                except Exception as e:  # noqa: BLE001 (reported, with its kind)
                    result = {"loaded": True, "ok": False,
                              "message": f"{type(e).__name__}: {refusal(e)}"}
        elif kind == "file":
            try:
                scene = load_file(mi, job["file"], **job.get("params", {}))
                image = np.array(mi.render(scene, spp=job.get("spp", 2), seed=0))
                result = {"finite": bool(np.isfinite(image).all()), "mean": float(image.mean()),
                          "printed": str(scene).startswith("Scene[")}
            except Exception as e:      # noqa: BLE001 (reported, with its kind)
                result = {"error": type(e).__name__, "message": refusal(e)}
        else:
            result = refuses_typo(mi, spec, assets, job["path"], job["key"], job["typo"])
        print(json.dumps(result), file=answers, flush=True)


if __name__ == "__main__":
    _serve(Path(sys.argv[1]))
