"""The gradient table: every differentiable parameter of every plugin, AD against finite
differences, under the default options and the others. One home for the machinery, used
by tests/plugins/test_gradient_table.py (the default-options rows and a few others, small) and
benchmarks/gradients.py (every row, more samples; writes docs/results/gradients.md).

**Rows are found, not listed.** Each :class:`Setup` is a small scene (16x16 pixels) that
uses one plugin with one set of its options. :func:`rows` loads it, runs ``mi.traverse``
and takes every key whose flags do not include ``NonDifferentiable`` and that belongs to
one of our plugins: its node is our plugin, or a Mitsuba object (an ``rgb`` colour)
directly inside ours, as ``obj.bsdf.diffuse.value`` of the ``tutorial`` BSDF. Keys that
our plugins inherit from Mitsuba's base classes (the ``blob``'s mesh buffers, those a
bare ``mi.Mesh`` exposes) are Mitsuba's and left out. So a parameter a plugin newly
exposes becomes a row by itself; what a setup says about a parameter by name (its step,
a skip, an expected zero) is checked to name an existing row.

**The check.** For a fixed random direction ``d`` in the parameter's space (positive
components), the derivative of the mean pixel along ``d``:

- AD: ``prb`` (``prb_projective`` where the flags include ``Discontinuous``: the
  parameter moves geometry whose silhouettes may be visible), forward mode: the
  derivative image of ``mi.render(..., seed_grad=s)`` with the parameter's gradient set
  to ``d`` (its mean is the derivative of the mean pixel); the benchmark also checks
  that reverse mode (``dr.backward`` of the mean, what an optimisation runs) gives the
  same number;
- FD: central differences ``(L(x + h d) - L(x - h d)) / 2h`` of primal renders at
  seed ``s``, for steps ``h`` and ``2h``.

The AD pass at ``seed_grad = s`` replays the sample sequence of the primal renders at
seed ``s`` (the primal pass of an AD render uses another seed, as Mitsuba requires), so
AD and FD are paired pixel by pixel: their difference does not carry the noise that both
share. The tolerance is derived from the measurements' own noise, in three parts:

- noise: ``t * sd(AD_p - FD_p(h)) / sqrt(n)`` over the ``n`` pixels of all seeds (each
  pixel's samples are independent of the others'), ``t`` the two-sided ``1 - ALPHA``
  quantile of Student's t with ``n - 1`` degrees of freedom: what the two estimators'
  paired difference reaches by chance when their expectations agree;
- step: ``|FD(2h) - FD(h)|`` (means), which bounds the truncation error of the central
  difference at ``h`` (a third of it for a smooth function) and carries the differences'
  own non-smooth noise (the blob re-meshes for each value);
- rounding: ``2^-24 * mean pixel / h``, the resolution of a float32 difference.

A row passes when ``|AD - FD(h)|`` is within the tolerance and the derivative is resolved
(``|FD(h)|`` above the tolerance), or, for a row whose derivative is 0 by construction
(``Setup.zero``), when AD is finite and within the tolerance of 0.

Scenes are framed so that each derivative is well posed for the integrator (what the
frame avoids is said in ``Setup.frame``): ``prb`` takes no boundary terms (no silhouette
that a parameter moves may be visible to it), Mitsuba differentiates no shadow edge of a
point light (the light is put at the eye where geometry or a normal moves), and ``prb``
differentiates the ``tutorial`` BSDF's delta events through ``eval`` (its docstring; the
scenes give those events no light). What still cannot be right is skipped with its
reason (``Setup.skip``), and the plugin's docstring states it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

#: Film size (pixels a side), and the false-alarm level of a row's noise term (two-sided).
SIZE = 16
ALPHA = 1e-3
#: Seed offset of the primal pass of an AD render (Mitsuba refuses seed == seed_grad;
#: seed_grad = 0 would mean "pick one", so the paired seeds start at 1).
PRIMAL_SEED_OFFSET = 1 << 20
#: Default FD step, relative to the parameter's RMS value (1 where that is 0).
REL_STEP = 0.01


# -- scenes --------------------------------------------------------------------------------

EYE = [0.0, 0.0, 4.0]


def camera(mi, **extra) -> dict:
    """Mitsuba's ``perspective`` camera at EYE looking at the origin (or ``extra``)."""
    return {"type": "perspective", "fov": 40,
            "to_world": mi.ScalarTransform4f().look_at(EYE, [0, 0, 0], [0, 1, 0]),
            "film": {"type": "hdrfilm", "width": SIZE, "height": SIZE,
                     "rfilter": {"type": "box"}},
            "sampler": {"type": "independent"}, **extra}


def rgb(value) -> dict:
    return {"type": "rgb", "value": value}


def point(position=(2.0, 2.0, 3.0), intensity=15.0) -> dict:
    """Mitsuba's own point light (so that only the plugin under test has rows)."""
    return {"type": "point", "position": list(position), "intensity": rgb(intensity)}


def scene(mi, integrator: dict, bsdf=None, shape=None, sensor=None, emitters=None,
          extra=None) -> dict:
    """A unit sphere (or ``shape``) with ``bsdf`` (Mitsuba's ``diffuse``) seen by
    ``sensor`` (:func:`camera`), lit by ``emitters`` (a :func:`point` light)."""
    obj = dict(shape or {"type": "sphere"})
    obj.setdefault("bsdf", bsdf or {"type": "diffuse", "reflectance": rgb(0.5)})
    d = {"type": "scene", "integrator": integrator, "sensor": sensor or camera(mi),
         "obj": obj}
    d.update(emitters or {"light": point()})
    d.update(extra or {})
    return d


def faces(mi, seed: int = 1) -> dict:
    """Six random 4x4 cube-map faces (values in [0.1, 0.9])."""
    rng = np.random.default_rng(seed)
    return {name: mi.Bitmap(rng.uniform(0.1, 0.9, (4, 4, 3)).astype(np.float32))
            for name in ("up", "down", "right", "left", "forward", "backward")}


def placement(mi):
    """A ``to_world`` that rotates, scales and moves (for the textures and the bump)."""
    return (mi.ScalarTransform4f().translate([0.3, 0.2, 0.1])
            .rotate([1, 1, 0], 30).scale(1.5))


# -- setups -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Setup:
    """One plugin with one set of options, in a small scene.

    ``build(mi, integrator)`` returns the scene dict with the integrator dict given
    (``prb`` or ``prb_projective`` with ``max_depth``). ``frame`` says why the scene is
    as it is where that makes a derivative well posed. By parameter name (``owner.param``,
    e.g. ``tutorial.power``): ``steps`` an absolute FD step instead of ``REL_STEP``;
    ``skip`` the reason a derivative cannot be right here; ``zero`` the reason it is 0;
    ``ci`` rows of a non-default setup that CI runs too."""
    plugin: str
    options: str
    build: Callable
    max_depth: int = 2
    default: bool = False
    frame: str = ""
    steps: dict = field(default_factory=dict)
    skip: dict = field(default_factory=dict)
    zero: dict = field(default_factory=dict)
    ci: tuple = ()

    @property
    def id(self) -> str:
        return f"{self.plugin}[{self.options}]"


DIRECT = ("direct light from a point light only (max_depth 2): no light reaches the "
          "material's mirror and refraction events, whose derivatives prb takes from "
          "eval (the tutorial BSDF's docstring)")
AT_EYE = "point light at the eye: no visible shadow edge"
UNLIT_MIRROR = ("no light reaches the mirror event in this frame, so reflection has no "
                "effect (AD must still be 0 and finite); where light does, prb's derivative "
                "is wrong: see tutorial[page=2,lit_mirror]")
LIT_MIRROR = ("prb differentiates the mirrored light through eval at the mirror direction, "
              "the lighting term, not the event's weight (the tutorial BSDF's docstring)")


def _tutorial(page: int, **values) -> dict:
    return {"type": "tutorial", "page": page, "diffuse": rgb(0.5), **values}


def _tutorial_setups() -> list[Setup]:
    # reflection != refraction: with equal weights 1 - Rf - Tr does not depend on R
    p4 = dict(specular=rgb(0.4), power=10.0, reflection=0.3, refraction=0.5, density=1.5)
    p2 = dict(specular=rgb(0.4), power=10.0, reflection=0.3)
    names = ("tutorial.diffuse.value", "tutorial.specular.value", "tutorial.power",
             "tutorial.reflection")
    return [
        Setup("tutorial", "page=4", lambda mi, i: scene(mi, i, _tutorial(4, **p4)),
              default=True, frame=DIRECT),
        Setup("tutorial", "page=2", lambda mi, i: scene(mi, i, _tutorial(2, **p2)),
              frame=DIRECT, zero={"tutorial.reflection": UNLIT_MIRROR}),
        # page 1 is page 2 without the Blinn term: power then has no effect
        Setup("tutorial", "page=1", lambda mi, i: scene(mi, i, _tutorial(
            1, power=10.0, reflection=0.3)), frame=DIRECT,
            zero={"tutorial.reflection": UNLIT_MIRROR,
                  "tutorial.power": "specular is 0 on page 1 (AD must still be finite: "
                                    "d(cos^power)/dpower is cos^power ln cos)"},
            ci=("tutorial.power",)),
        # what prb does where the mirror event is lit (a constant environment)
        Setup("tutorial", "page=2,lit_mirror", lambda mi, i: scene(
            mi, i, _tutorial(2, **p2), extra={"sky": {"type": "constant",
                                                      "radiance": rgb(1.0)}}),
            max_depth=3, skip={name: LIT_MIRROR for name in names}),
    ]


def _blinnphong_setups() -> list[Setup]:
    def build(mi, i):
        wall = {"type": "rectangle", "bsdf": {"type": "diffuse"},
                "to_world": mi.ScalarTransform4f().translate([0, 0, -1.5]).scale(3)}
        return scene(mi, i, {"type": "blinnphong", "diffuse_reflectance": rgb(0.4),
                             "specular_reflectance": rgb(0.3), "exponent": 20.0},
                     extra={"wall": wall})
    return [Setup("blinnphong", "default", build, max_depth=3, default=True,
                  frame="a wall behind the sphere, max_depth 3: light reflected between "
                        "them, so prb differentiates the sampled lobe too")]


def _noisebump_setups() -> list[Setup]:
    frame = ("point light at the eye: the bump moves the terminator, where the nested "
             "BSDF's lighting would jump (the tutorial's Blinn term has no cosine); with "
             "the light at the eye every term is 0 there, and no shadow edge is visible")

    def bump(nested, placed=False, **options):
        def build(mi, i):
            extra = {"to_world": placement(mi)} if placed else {}
            return scene(mi, i, {"type": "noisebump", "bumplevel": 0.3, "frequency": 2.0,
                                 **extra, **options, "nested": nested},
                         emitters={"light": point(EYE, 15.0)})
        return build

    nested_tutorial = _tutorial(2, specular=rgb(0.4), power=10.0, reflection=0.3)
    diffuse = {"type": "diffuse", "reflectance": rgb(0.5)}
    return [
        Setup("noisebump", "default", bump(nested_tutorial),
              default=True, frame=frame, zero={"tutorial.reflection": UNLIT_MIRROR}),
        Setup("noisebump", "gradient=reference", bump(diffuse, gradient="reference"),
              frame=frame),
        Setup("noisebump", "leak_check=true", bump(diffuse, leak_check=True), frame=frame,
              ci=("noisebump.bumplevel",)),
        Setup("noisebump", "to_world", bump(diffuse, placed=True), frame=frame),
    ]


def _texture_setups() -> list[Setup]:
    def texture(kind, **options):
        values = {"perlin": dict(frequency=1.0, scale=0.4, offset=0.5),
                  "turbulence": dict(frequency=1.0, octaves=3, color0=rgb(0.6),
                                     color1=rgb(0.1)),
                  "marble": dict(frequency=1.0, octaves=3, stripe_frequency=2.0,
                                 color0=rgb(0.6), color1=rgb(0.1))}[kind]

        def build(mi, i):
            extra = {"to_world": placement(mi)} if options.get("placed") else \
                {k: v for k, v in options.items() if k != "placed"}
            return scene(mi, i, {"type": "diffuse", "reflectance": {
                "type": kind, **values, **extra}})
        return build

    out = []
    for kind in ("perlin", "turbulence", "marble"):
        out += [Setup(kind, "default", texture(kind), default=True),
                Setup(kind, "gradient=reference", texture(kind, gradient="reference")),
                Setup(kind, "to_world", texture(kind, placed=True))]
    return out


def _blob_setups() -> list[Setup]:
    def blob(field_, normals, placed=False, light=EYE, wall=False, **options):
        def build(mi, i):
            shape = {"type": "blob", "centers": "-0.6 0 0  0.6 0.1 0", "radius": 0.8,
                     "max_error": 0.002, "field": field_, "normals": normals, **options}
            if placed:
                shape["to_world"] = (mi.ScalarTransform4f().translate([0.1, -0.1, 0.2])
                                     .rotate([0, 0, 1], 25).scale(0.9))
            if normals != "flat":
                extra = {"wall": {"type": "rectangle", "bsdf": {"type": "diffuse"},
                                  "to_world": mi.ScalarTransform4f().translate(
                                      [0, 0, -0.9]).scale(3)}} if wall else None
                return scene(mi, i, shape=shape, emitters={"light": point(light, 15.0)},
                             extra=extra)
            shape["emitter"] = {"type": "area", "radiance": rgb(1.0)}
            return scene(mi, i, shape=shape, emitters={"none": {"type": "constant",
                                                                 "radiance": 0.0}})
        return build

    steps = {"blob.centers": 0.01, "blob.radius": 0.005}
    # a silhouette's motion changes which samples a pixel covers: a difference needs
    # steps of a few tenths of a pixel (5.5 pixels per unit here) to count enough of them
    coverage = {"blob.centers": 0.04, "blob.radius": 0.02}
    smooth = (AT_EYE + "; the silhouettes are in the frame (prb_projective), where the "
              "diffuse shading goes to 0")
    flat = ("the blob emits (radiance 1, no other light): with flat normals the shading "
            "jumps at every facet edge and the edges sweep over the image, which no "
            "integrator differentiates (the blob's docstring), so only the silhouettes "
            "move here (prb_projective); the polygonal contour still slides, a few per "
            "cent of this term by the docstring, below this row's tolerance")
    shadows = ("the point light at (3, 0.5, 2) casts the blob's shadow on a wall behind "
               "it and the lobes' on each other, in view, and Mitsuba differentiates no "
               "shadow edge of a point light (the blob's docstring)")
    out = []
    for field_ in ("tutorial", "exact"):
        for normals in ("exact", "field", "flat"):
            default = field_ == "tutorial" and normals == "exact"
            out.append(Setup("blob", f"field={field_},normals={normals}",
                             blob(field_, normals), default=default,
                             frame=flat if normals == "flat" else smooth,
                             steps=coverage if normals == "flat" else steps))
    out.append(Setup("blob", "to_world", blob("tutorial", "exact", placed=True),
                     frame=smooth, steps=steps))
    out.append(Setup("blob", "field=tutorial,normals=exact,shadows",
                     blob("tutorial", "exact", light=(3.0, 0.5, 2.0), wall=True),
                     steps=steps,
                     skip={"blob.centers": shadows, "blob.radius": shadows}))
    no_mesh = ("tessellate false: no mesh, so prb sees no blob (only tutorialpath "
               "intersects it), and the surface carries no derivatives (the blob's "
               "docstring)")
    out.append(Setup("blob", "tessellate=false", blob("tutorial", "exact", tessellate=False),
                     frame=smooth, steps=steps,
                     skip={"blob.centers": no_mesh, "blob.radius": no_mesh}))
    return out


def _camera_setups() -> list[Setup]:
    """The cameras expose no differentiable parameter; the derivatives of a texture seen
    through each lens (prb: the projective integrators support only ``perspective``)."""
    textured = {"type": "diffuse", "reflectance": {"type": "perlin", "frequency": 1.0,
                                                   "scale": 0.4, "offset": 0.5}}

    def conic(**lens):
        return lambda mi, i: scene(mi, i, textured, sensor=camera(mi, type="conic", **lens))

    def ortho(mi, i):
        return scene(mi, i, textured, sensor={
            "type": "tutorialortho", "near_clip": 0.0, "far_clip": 20.0,
            "to_world": mi.ScalarTransform4f().translate([0, 0, 5]).scale([1.5, 1.5, -1]),
            "film": camera(mi)["film"], "sampler": {"type": "independent"}})
    return [
        Setup("conic", "default", conic(), default=True),
        Setup("conic", "lens=disc,aperture_radius=0.3", conic(
            aperture_radius=0.3, focus_distance=4.0)),
        Setup("conic", "lens=tutorial,aperture=0.4", conic(
            lens="tutorial", aperture=0.4, focus_distance=4.0), ci=("perlin.frequency",)),
        Setup("tutorialortho", "default", ortho, default=True),
    ]


def _emitter_setups() -> list[Setup]:
    def tutorialpoint(falloff):
        return lambda mi, i: scene(mi, i, emitters={"light": {
            "type": "tutorialpoint", "position": [2.0, 2.0, 3.0], "falloff": falloff,
            "intensity": rgb(15.0 if falloff else 1.0)}})

    def cubemap(**options):
        def build(mi, i):
            extra = {"to_world": mi.ScalarTransform4f().rotate([0, 1, 0], 30)} \
                if options.get("placed") else {}
            env = {"type": "cubemap", **faces(mi), **extra,
                   **{k: v for k, v in options.items() if k != "placed"}}
            lights = {"env": env}
            if options.get("mode") == "background":
                lights["light"] = point()
            return scene(mi, i, emitters=lights)
        return build

    return [
        Setup("tutorialpoint", "default", tutorialpoint(False),
              default=True),
        Setup("tutorialpoint", "falloff=true", tutorialpoint(True),
              ci=("tutorialpoint.intensity.value",)),
        Setup("cubemap", "default", cubemap(), default=True),
        Setup("cubemap", "mode=background", cubemap(mode="background"), max_depth=3,
              frame="max_depth 3: the background reaches the sphere along sampled "
                    "directions as well as the camera directly",
              ci=("cubemap.data",)),
        Setup("cubemap", "srgb,exposed,exposure=2,to_world", cubemap(
            srgb=True, exposed=True, exposure=2.0, placed=True)),
    ]


def _integrator_setups() -> list[Setup]:
    """``tutorialpath`` exposes no differentiable parameter; its setup shows that."""
    def build(mi, i):
        return scene(mi, {"type": "tutorialpath", "max_depth": 2})
    return [Setup("tutorialpath", "default", build, default=True)]


SETUPS: list[Setup] = (_tutorial_setups() + _blinnphong_setups() + _noisebump_setups()
                       + _texture_setups() + _blob_setups() + _camera_setups()
                       + _emitter_setups() + _integrator_setups())


# -- rows ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class Row:
    """One differentiable parameter of one of our plugins in one setup."""
    setup: Setup
    key: str            # the scene key, e.g. "obj.bsdf.diffuse.value"
    owner: str          # our plugin the key belongs to, e.g. "tutorial"
    param: str          # the key below the owner, e.g. "diffuse.value"
    discontinuous: bool

    @property
    def name(self) -> str:
        return f"{self.owner}.{self.param}"

    @property
    def id(self) -> str:
        return f"{self.setup.id}-{self.name}"

    @property
    def integrator(self) -> str:
        return "prb_projective" if self.discontinuous else "prb"

    @property
    def skip(self) -> str | None:
        return self.setup.skip.get(self.name)

    @property
    def zero(self) -> str | None:
        return self.setup.zero.get(self.name)

    @property
    def ci(self) -> bool:
        return (self.setup.default and self.owner == self.setup.plugin) or \
            self.name in self.setup.ci


def plugin_of(node) -> str | None:
    """The XML type of our plugin ``node`` (its module is named after it), else None."""
    module = type(node).__module__
    if not module.startswith("codermind."):
        return None
    return module.rsplit(".", 1)[1]


#: Loaded scenes, the last few only: Dr.Jit traces a virtual call for every live instance
#: of the class it dispatches on, so every scene kept alive slows the renders of the
#: others (all 36 setups alive made the other tests of a pytest worker 3x slower).
_SCENES: dict = {}
KEEP = 2


def integrator_dict(setup: Setup, integrator: str) -> dict:
    """``prb`` or ``prb_projective`` with the setup's ``max_depth``. The projective one
    samples no indirect silhouettes (``sppi`` 0): every scene here is framed to have
    none (a point light or an environment, and no occluder between a surface and them),
    as Mitsuba's own warning says when it finds none."""
    d = {"type": integrator, "max_depth": setup.max_depth}
    if integrator == "prb_projective":
        d["sppi"] = 0
    return d


def load(mi, setup: Setup, integrator: str = "prb"):
    """The setup's scene with ``integrator`` (kept: loading a blob meshes it)."""
    key = (mi.variant(), setup.id, integrator)
    if key not in _SCENES:
        d = setup.build(mi, integrator_dict(setup, integrator))
        if integrator == "prb_projective":     # Mitsuba's advice for moving shapes
            d["sensor"]["film"]["sample_border"] = True
        scene_ = mi.load_dict(d)
        # every differentiable value evaluated (not a literal baked into the kernels), as
        # it is once a difference has written it: one kernel serves every render
        import drjit as dr
        params = mi.traverse(scene_)
        for name in params.keys():
            if not params.flags(name) & mi.ParamFlags.NonDifferentiable:
                dr.make_opaque(params[name])
        while len(_SCENES) >= KEEP:
            del _SCENES[next(iter(_SCENES))]
        _SCENES[key] = scene_
    return _SCENES[key]


def forget() -> None:
    """Drop the loaded scenes (and their plugins, from Dr.Jit's registry)."""
    import gc
    _SCENES.clear()
    gc.collect()


def inherited_keys(mi) -> set[str]:
    """What a bare ``mi.Mesh`` exposes: Mitsuba's own buffers of a mesh plugin."""
    return set(mi.traverse(mi.Mesh("bare", 3, 1)).keys())


def scene_rows(mi, setup: Setup) -> tuple[list[Row], set[str]]:
    """The setup's rows, and the names of our plugins its scene instantiates."""
    params = mi.traverse(load(mi, setup))
    nodes = {}                       # node path -> our plugin's name
    for key in params.keys():
        node = params.properties[key][2]
        name = plugin_of(node)
        if name is not None:
            nodes[key.rsplit(".", 1)[0] if "." in key else ""] = name
    bare = inherited_keys(mi)
    non_differentiable = int(mi.ParamFlags.NonDifferentiable)
    discontinuous = int(mi.ParamFlags.Discontinuous)
    out = []
    for key in params.keys():
        flags = int(params.properties[key][3])
        if flags & non_differentiable:
            continue
        path = key.rsplit(".", 1)[0]
        if path in nodes:                                     # our plugin's own key
            owner_path = path
        elif "." in path and path.rsplit(".", 1)[0] in nodes \
                and plugin_of(params.properties[key][2]) is None:  # a colour inside ours
            owner_path = path.rsplit(".", 1)[0]
        else:
            continue
        param = key[len(owner_path) + 1:]
        if isinstance(params.properties[key][2], mi.Mesh) and param in bare:
            continue
        out.append(Row(setup, key, nodes[owner_path], param, bool(flags & discontinuous)))
    return out, set(nodes.values())


def rows(mi, setups=None) -> list[Row]:
    """Every row of ``setups`` (default: all), in order."""
    found = []
    for setup in SETUPS if setups is None else setups:
        found += scene_rows(mi, setup)[0]
    return found


# -- the measurement ----------------------------------------------------------------------

@dataclass
class Result:
    """A row measured: means over the pixels and seeds of the derivative images."""
    row: Row
    spp: int
    seeds: int
    h: float
    ad: float                       # forward-mode AD
    fd: float                       # FD(h)
    fd2: float                      # FD(2h)
    noise_term: float               # t * sd / sqrt(n) of the paired differences
    step_term: float                # |FD(2h) - FD(h)|
    rounding_term: float            # 2^-24 mean pixel / h
    backward: float                 # reverse-mode AD at the first seed (nan: not run)
    forward_first: float            # forward-mode AD at the first seed
    backward_bound: float           # float32 accumulation bound of their difference
    finite: bool
    worst: float = 0.0              # the largest |AD_p - FD_p(h)| of a pixel
    spread: float = 0.0             # the sd of AD_p - FD_p(h) over pixels and seeds

    @property
    def tolerance(self) -> float:
        return self.noise_term + self.step_term + self.rounding_term

    @property
    def error(self) -> float:
        return abs(self.ad - self.fd)

    @property
    def resolved(self) -> bool:
        return abs(self.fd) > self.tolerance

    @property
    def modes_agree(self) -> bool:
        """Reverse mode gave the forward mode's number (True where it was not run)."""
        return math.isnan(self.backward) or \
            abs(self.backward - self.forward_first) <= self.backward_bound

    @property
    def passed(self) -> bool:
        if not (self.finite and self.modes_agree):
            return False
        if self.row.zero:
            return abs(self.ad) <= self.tolerance
        return self.resolved and self.error <= self.tolerance

    def verdict(self) -> str:
        if not self.finite:
            return "FAIL (AD not finite)"
        if not self.modes_agree:
            return "FAIL (backward != forward)"
        if self.row.zero:
            return "pass (0)" if self.passed else "FAIL (not 0)"
        if not self.resolved:
            return "FAIL (lost in the noise)"
        return "pass" if self.passed else "FAIL"

    def describe(self) -> str:
        return (f"{self.row.id} [{self.row.integrator}, {self.spp} spp x {self.seeds} "
                f"seed(s), h {self.h:.3g}]: AD {self.ad:.6g}, FD {self.fd:.6g} (2h: "
                f"{self.fd2:.6g}), |AD - FD| {self.error:.3g}, tolerance "
                f"{self.tolerance:.3g} = noise {self.noise_term:.3g} + step "
                f"{self.step_term:.3g} + rounding {self.rounding_term:.3g}; backward "
                f"{self.backward:.7g} vs forward {self.forward_first:.7g} (bound "
                f"{self.backward_bound:.2g}): {self.verdict()}")


def _flat(mi, value) -> np.ndarray:
    import drjit as dr
    a = value.array if isinstance(value, mi.TensorXf) else dr.ravel(value)
    return np.array(a, dtype=np.float64)


def _make(mi, like, flat: np.ndarray):
    import drjit as dr
    data = mi.Float(flat.astype(np.float32))
    if isinstance(like, mi.TensorXf):
        return mi.TensorXf(data, like.shape)
    return dr.unravel(type(like), data)


def direction(row: Row, n: int) -> np.ndarray:
    """The fixed random direction of a row's parameter (n components in [0.5, 1])."""
    seed = sum(ord(c) for c in row.name)
    return np.random.default_rng(seed).uniform(0.5, 1.0, n)


def step(row: Row, x0: np.ndarray) -> float:
    if row.name in row.setup.steps:
        return row.setup.steps[row.name]
    rms = float(np.sqrt(np.mean(np.square(x0))))
    return REL_STEP * (rms if rms > 0 else 1.0)


def _pixels(image) -> np.ndarray:
    """An image (H, W, channels) as its per-pixel channel means, float64."""
    return np.array(image, dtype=np.float64).mean(axis=-1)


class Derivatives:
    """AD of one scene's parameters ``keys`` (forward and reverse mode), at paired seeds.

    Every key has gradients enabled, the others with a zero gradient (evaluated, not a
    literal) when one is differentiated: the AD kernels are then the same for all of them
    and compiled once per scene. ``restore`` puts the values back, detached."""

    def __init__(self, mi, scene_, keys: list[str], spp: int):
        self.mi, self.scene, self.spp = mi, scene_, spp
        self.params = mi.traverse(scene_)
        self.keys = keys
        self.likes = {k: type(self.params[k])(self.params[k]) for k in keys}
        self.start = {k: _flat(mi, self.likes[k]) for k in keys}

    def set(self, key: str, flat: np.ndarray) -> None:
        self.params[key] = _make(self.mi, self.likes[key], flat)
        self.params.update()

    def primal(self, seed: int) -> np.ndarray:
        return _pixels(self.mi.render(self.scene, self.params, spp=self.spp, seed=seed))

    def _attached_render(self, key: str, seed: int):
        import drjit as dr
        for k in self.keys:
            if not dr.grad_enabled(self.params[k]):
                self.params[k] = _make(self.mi, self.likes[k], self.start[k])
                dr.enable_grad(self.params[k])
        # an update per render, as an optimisation makes one per step: a plugin that
        # attaches derivatives in parameters_changed (the blob's vertices) attaches them
        # again (a traversal consumes the graph it follows)
        self.params.set_dirty(key)
        self.params.update()
        return self.mi.render(self.scene, self.params, spp=self.spp,
                              seed=seed + PRIMAL_SEED_OFFSET, seed_grad=seed)

    def forward(self, key: str, d: np.ndarray, seed: int) -> np.ndarray:
        """The derivative image (H, W, channels) along ``d`` of ``key``, forward mode."""
        import drjit as dr
        image = self._attached_render(key, seed)
        for k in self.keys:
            dr.set_grad(self.params[k], _make(self.mi, self.likes[k], d if k == key else
                                              np.zeros(self.start[k].size)))
        dr.enqueue(dr.ADMode.Forward, *[self.params[k] for k in self.keys])
        dr.traverse(dr.ADMode.Forward)
        grad = np.array(dr.grad(image), dtype=np.float64)
        for k in self.keys:
            dr.clear_grad(self.params[k])
        return grad

    def backward(self, key: str, d: np.ndarray, seed: int) -> float:
        """The derivative of the mean pixel along ``d`` of ``key``, reverse mode."""
        import drjit as dr
        image = self._attached_render(key, seed)
        dr.backward(dr.mean(image, axis=None))
        value = float(np.dot(_flat(self.mi, dr.grad(self.params[key])), d))
        for k in self.keys:
            dr.clear_grad(self.params[k])
        return value

    def restore(self) -> None:
        for k in self.keys:
            self.params[k] = _make(self.mi, self.likes[k], self.start[k])
        self.params.update()


def measure(mi, row: Row, spp: int = 16, seeds: int = 1, backward: bool = False) -> Result:
    """AD and FD of the row's derivative (see the module's docstring) with ``seeds`` paired
    seeds of ``spp`` samples per pixel. AD is forward mode, which gives the derivative
    image, so that the paired differences are per pixel: their spread over the pixels
    and seeds is the noise. With ``backward``, reverse mode (``dr.backward``, what an
    optimisation runs) at the first seed must give the forward mode's number, to float32
    accumulation (its kernels are compiled per row: the benchmark runs it, CI does not).
    The parameters are left as they were."""
    from scipy.special import stdtrit
    keys = [r.key for r in scene_rows(mi, row.setup)[0] if r.integrator == row.integrator]
    ad_ = Derivatives(mi, load(mi, row.setup, row.integrator), keys, spp)
    key, x0 = row.key, ad_.start[row.key]
    d = direction(row, x0.size)
    h = step(row, x0)
    seed_list = range(1, seeds + 1)

    def images(flat) -> np.ndarray:
        ad_.set(key, flat)
        return np.array([ad_.primal(s) for s in seed_list])

    try:
        plus, minus = images(x0 + h * d), images(x0 - h * d)
        fd = (plus - minus) / (2 * h)
        fd2 = (images(x0 + 2 * h * d) - images(x0 - 2 * h * d)) / (4 * h)
        level = float(np.mean(plus + minus)) / 2
        grads = [ad_.forward(key, d, s) for s in seed_list]
        ad = np.array([g.mean(axis=-1) for g in grads])
        first_terms = float(np.mean(np.abs(grads[0])))
        reverse = ad_.backward(key, d, 1) if backward else math.nan
    finally:
        ad_.restore()
    diff = (ad - fd).ravel()
    t = float(stdtrit(diff.size - 1, 1 - ALPHA / 2))
    # reverse mode sums every sample's contribution in float32 in another order: Higham's
    # bound n u sum|terms| for n terms (samples x channels), with the sum of the pixels'
    # |derivatives| (their samples' terms rarely differ in sign within a pixel)
    bound = (SIZE * SIZE * spp * 3) * 2.0 ** -24 * first_terms
    return Result(row, spp, seeds, h, float(np.mean(ad)), float(np.mean(fd)),
                  float(np.mean(fd2)),
                  noise_term=t * float(np.std(diff, ddof=1)) / math.sqrt(diff.size),
                  step_term=abs(float(np.mean(fd2) - np.mean(fd))),
                  rounding_term=2.0 ** -24 * abs(level) / h,
                  backward=reverse, forward_first=float(np.mean(ad[0])),
                  backward_bound=bound, finite=bool(np.isfinite(ad).all()),
                  worst=float(np.abs(diff).max()), spread=float(np.std(diff, ddof=1)))
