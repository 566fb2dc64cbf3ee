"""Property-based tests (hypothesis) of every plugin: for random VALID parameters, on many
random directions, positions and samples at once (plus the degenerate ones: normal and exactly
tangent incidence, samples 0 and 1 - 2^-24), no output is NaN or Inf; random INVALID
parameters always fail with an error that names the parameter.

Each example builds its plugin with ``mi.load_dict`` and compiles its kernels (parameters are
literals in them), about 0.1-0.3 s, so CI runs a few examples per property (``ci`` profile,
derandomized); ``HYPOTHESIS_PROFILE=long`` runs many more (docs/harness.md, "Property and fuzz tests").
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, strategies as st

from support import examples

N = 256                                   # directions / points / samples per example
ONE_MINUS = 1.0 - 2.0 ** -24              # the largest float32 below 1
SEEDS = st.integers(0, 2 ** 32 - 1)
F32_MAX = 3.4028234663852886e38           # the largest float32: plugins accept up to it
F32_TINY = 1.1754943508222875e-38         # the smallest normal float32


def unit(lo: float = 0.0, hi: float = 1.0):
    return st.floats(lo, hi, allow_nan=False)


def positive(lo: float, hi: float):
    """Log-uniform-ish positive floats in [lo, hi]: small and huge values both appear."""
    return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: min(hi, max(lo, 10.0 ** e)))


RGB = st.tuples(unit(), unit(), unit())


def rgb(value) -> dict:
    return {"type": "rgb", "value": [float(c) for c in value]}


# -- sampling inputs -----------------------------------------------------------------------

def directions(rng, n: int = N) -> np.ndarray:
    """(3, n) unit vectors, both hemispheres, with the degenerate ones first."""
    d = rng.normal(size=(3, n))
    special = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [1, 0, 1e-7],
                        [1, 0, -1e-7], [0.6, 0, 0.8], [-0.6, 0, -0.8]], dtype=float).T
    d[:, :special.shape[1]] = special
    return d / np.linalg.norm(d, axis=0)


def samples(rng, n: int = N, dim: int = 2) -> np.ndarray:
    """(dim, n) uniform samples in [0, 1), the first three 0, 1 - 2^-24 and 0.5."""
    s = rng.random((dim, n))
    s[:, :3] = [0.0, ONE_MINUS, 0.5]
    return s


def positions(rng, n: int = N, scale: float = 1e3, extreme: bool = True) -> np.ndarray:
    """(3, n) points at magnitudes up to about 10 ``scale``; with ``extreme``, also the
    origin, a float32 integer lattice point and points near the float32 range."""
    p = rng.normal(size=(3, n)) * scale * 10.0 ** rng.uniform(-3, 1, n)
    if extreme:
        p[:, :4] = np.array([[0, 0, 0], [2.0 ** 23 + 0.5, -3.25, 7], [1e30, 1, 2],
                             [-3e38, 5, 1e20]]).T
    return p


def assert_finite(**arrays):
    import drjit as dr
    # one kernel for all outputs: compiling each separately cost 2.5x the time (a texture
    # of 64 octaves: 40 s against 16 s)
    dr.eval(*[v for v in arrays.values() if dr.is_array_v(v) or dr.is_struct_v(v)])
    for name, value in arrays.items():
        a = np.asarray(value.numpy() if hasattr(value, "numpy") else value, dtype=np.float64)
        bad = ~np.isfinite(a)
        assert not bad.any(), f"{name}: {int(bad.sum())} non-finite of {a.size}"


def interaction(mi, rng, n: int = N):
    import drjit as dr
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(directions(rng, n).astype(np.float32))
    si.p = mi.Point3f(positions(rng, n).astype(np.float32))
    si.n = mi.Normal3f(0.0, 0.0, 1.0)
    shading = rng.normal(size=(3, n)) * 0.3 + [[0], [0], [1]]
    si.sh_frame = mi.Frame3f(mi.Vector3f((shading / np.linalg.norm(shading, axis=0))
                                         .astype(np.float32)))
    return si


def check_bsdf(mi, spec: dict, seed: int, max_weight: float | None = None):
    """Every output of eval, pdf, eval_pdf, sample, eval_diffuse_reflectance is finite; with
    ``max_weight``, the physical bounds (eval, pdf >= 0, 0 <= weight <= max_weight)."""
    rng = np.random.default_rng(seed)
    bsdf = mi.load_dict(spec)
    si = interaction(mi, rng)
    wo = mi.Vector3f(directions(rng).astype(np.float32))
    for ctx in (mi.BSDFContext(), mi.BSDFContext(mi.TransportMode.Importance)):
        value, pdf = bsdf.eval_pdf(ctx, si, wo)
        s1, s2 = samples(rng, dim=1), samples(rng)
        bs, weight = bsdf.sample(ctx, si, mi.Float(s1[0]), mi.Point2f(s2))
        outputs = dict(eval=bsdf.eval(ctx, si, wo), pdf=bsdf.pdf(ctx, si, wo), eval_pdf_value=value,
                       eval_pdf_pdf=pdf, wo=bs.wo, sample_pdf=bs.pdf, eta=bs.eta, weight=weight,
                       diffuse_reflectance=bsdf.eval_diffuse_reflectance(si))
        assert_finite(**outputs)
        if max_weight is not None:
            for name in ("eval", "pdf", "sample_pdf", "weight"):
                assert outputs[name].numpy().min() >= 0, name
            assert weight.numpy().max() <= max_weight * (1 + 1e-5) + 1e-6


# -- valid parameters: BSDFs ----------------------------------------------------------------

@st.composite
def blinnphong_specs(draw):
    """(spec, bound of the sample weight): a lobe picked with probability p has weight at
    most colour / p in each channel; p = channel mean of its colour / (mean kd + mean ks)."""
    kd = draw(RGB)
    ks = tuple(draw(unit(0.0, 1.0 - d)) for d in kd)
    exponent = draw(st.one_of(st.sampled_from([0.0, 1.0, 1e6]), positive(1e-6, 1e6)))
    md, ms = sum(kd) / 3, sum(ks) / 3
    bound = max([d / md * (md + ms) for d in kd if md > 0] +
                [s_ / ms * (md + ms) for s_ in ks if ms > 0] + [0.0])
    return {"type": "blinnphong", "diffuse_reflectance": rgb(kd),
            "specular_reflectance": rgb(ks), "exponent": exponent}, bound


def colour_or_texture(draw):
    """A tutorial colour: an RGB (may exceed 1) or a procedural texture."""
    kind = draw(st.sampled_from(["rgb", "rgb", "turbulence", "marble"]))
    if kind == "rgb":
        return rgb(draw(st.tuples(unit(0, 10), unit(0, 10), unit(0, 10))))
    return {"type": kind, "color0": rgb(draw(RGB)), "color1": rgb(draw(RGB)),
            "octaves": draw(st.integers(1, 9))}


@st.composite
def tutorial_specs(draw):
    page = draw(st.sampled_from([1, 2, 4]))
    spec = {"type": "tutorial", "page": page, "diffuse": colour_or_texture(draw),
            "specular": colour_or_texture(draw),
            "power": draw(st.one_of(st.sampled_from([0.0, F32_MAX]), positive(1e-3, F32_MAX))),
            "reflection": draw(unit())}
    if page == 4:
        spec["refraction"] = draw(unit())
        spec["density"] = draw(st.one_of(st.sampled_from([0.0, 1.0, 1.5, 2.0, F32_TINY, F32_MAX]),
                                         unit(0, 10).filter(lambda v: v == 0 or v >= F32_TINY),
                                         positive(F32_TINY, F32_MAX)))
    return spec


@examples(ci=8, long=1500)
@given(case=blinnphong_specs(), seed=SEEDS)
def test_blinnphong_outputs_are_finite_and_bounded(llvm, case, seed):
    spec, albedo = case
    check_bsdf(llvm, spec, seed, max_weight=albedo)


@examples(ci=8, long=1500)
@given(spec=tutorial_specs(), seed=SEEDS)
def test_tutorial_outputs_are_finite(llvm, spec, seed):
    check_bsdf(llvm, spec, seed)


@examples(ci=8, long=1500)
@given(nested=st.one_of(tutorial_specs(), blinnphong_specs().map(lambda c: c[0])),
       bumplevel=unit(), frequency=positive(1e-30, F32_MAX), leak_check=st.booleans(),
       seed=SEEDS)
def test_noisebump_outputs_are_finite(llvm, nested, bumplevel, frequency, leak_check, seed):
    check_bsdf(llvm, {"type": "noisebump", "bumplevel": bumplevel, "frequency": frequency,
                      "leak_check": leak_check, "nested": nested}, seed)


# -- valid parameters: textures -------------------------------------------------------------

@st.composite
def texture_specs(draw):
    kind = draw(st.sampled_from(["perlin", "turbulence", "marble"]))
    spec = {"type": kind, "frequency": draw(positive(1e-30, F32_MAX))}
    if kind != "perlin":
        spec["octaves"] = draw(st.integers(1, 64))
        spec["color0"] = rgb(draw(st.tuples(unit(-10, 10), unit(-10, 10), unit(-10, 10))))
        spec["color1"] = rgb(draw(st.tuples(unit(-10, 10), unit(-10, 10), unit(-10, 10))))
    if kind == "marble":
        spec["stripe_frequency"] = draw(positive(1e-30, F32_MAX))
    return spec


@examples(ci=10, long=1500)
@given(spec=texture_specs(), seed=SEEDS, scaled=st.booleans())
def test_texture_outputs_are_finite(llvm, spec, seed, scaled):
    mi = llvm
    if scaled:
        spec["to_world"] = mi.ScalarTransform4f().translate([1.0, -2.0, 3.0]).scale(0.25)
    texture = mi.load_dict(spec)
    si = interaction(mi, np.random.default_rng(seed))
    assert_finite(eval=texture.eval(si), eval_1=texture.eval_1(si), eval_3=texture.eval_3(si),
                  mean=[texture.mean()])
    if spec["type"] == "perlin":
        assert np.abs(texture.eval_1(si).numpy()).max() <= 1.1


# -- valid parameters: emitters -------------------------------------------------------------

def check_emitter(mi, emitter, rng, nonnegative: bool = True):
    import drjit as dr
    it = dr.zeros(mi.Interaction3f, N)
    it.p = mi.Point3f(positions(rng, N, scale=1e3, extreme=False).astype(np.float32))
    it.wavelengths = dr.zeros(type(it.wavelengths), N)
    ds, weight = emitter.sample_direction(it, mi.Point2f(samples(rng)))
    probe = dr.zeros(mi.DirectionSample3f, N)
    probe.d = mi.Vector3f(directions(rng).astype(np.float32))
    probe.p = it.p + probe.d
    si = dr.zeros(mi.SurfaceInteraction3f, N)
    si.wi = -probe.d
    ray, ray_weight = emitter.sample_ray(0.0, mi.Float(samples(rng, dim=1)[0]),
                                         mi.Point2f(samples(rng)), mi.Point2f(samples(rng)))
    ps, ps_weight = emitter.sample_position(0.0, mi.Point2f(samples(rng)))
    assert_finite(ds_p=ds.p, ds_d=ds.d, ds_pdf=ds.pdf, ds_dist=ds.dist, weight=weight,
                  pdf_direction=emitter.pdf_direction(it, ds),
                  pdf_direction_any=emitter.pdf_direction(it, probe),
                  eval_direction=emitter.eval_direction(it, probe), eval=emitter.eval(si),
                  ray_o=ray.o, ray_d=ray.d, ray_weight=ray_weight, ps_p=ps.p,
                  ps_weight=ps_weight)
    assert ds.pdf.numpy().min() >= 0
    if nonnegative:
        assert weight.numpy().min() >= 0


@examples(ci=8, long=1500)
@given(size=st.integers(1, 4), mode=st.sampled_from(["light", "background"]),
       srgb=st.booleans(), exposed=st.booleans(), exposure=positive(1e-20, 1e38),
       scale=st.one_of(st.just(0.0), positive(1e-20, 1e20)), angle=unit(-180, 180),
       seed=SEEDS)
def test_cubemap_outputs_are_finite(llvm, size, mode, srgb, exposed, exposure, scale, angle,
                                    seed):
    """Radiance factors scale / exposure up to 1e20 (the light-tracing weight, radiance times
    the scene disc's area pi 1e10, overflows float32 from a factor of about 1e27)."""
    mi = llvm
    assume(scale / exposure <= 1e20)
    rng = np.random.default_rng(seed)
    faces = {}
    for name in ("up", "down", "right", "left", "forward", "backward"):
        texels = rng.random((size, size, 3))
        texels[rng.random((size, size)) < 0.3] = rng.choice([0.0, 1.0])   # black or white
        faces[name] = mi.Bitmap(texels.astype(np.float32))
    spec = {"type": "cubemap", "mode": mode, "srgb": srgb, "exposed": exposed,
            "exposure": exposure, "scale": scale,
            "to_world": mi.ScalarTransform4f().rotate([1 / 3, 2 / 3, 2 / 3], angle), **faces}
    if mode == "background":
        spec["sampling_weight"] = 1.0
    # the tutorial's 'exposed' decode -ln(1.001 - c) is negative for c < 0.001 (facts.md F12.4)
    check_emitter(mi, mi.load_dict(spec), rng, nonnegative=not exposed)


@examples(ci=8, long=1500)
@given(position=st.tuples(unit(-1e6, 1e6), unit(-1e6, 1e6), unit(-1e6, 1e6)),
       intensity=st.tuples(unit(0, 1e6), unit(0, 1e6), unit(0, 1e6)), falloff=st.booleans(),
       seed=SEEDS)
def test_tutorialpoint_outputs_are_finite(llvm, position, intensity, falloff, seed):
    mi = llvm
    emitter = mi.load_dict({"type": "tutorialpoint", "position": list(position),
                            "intensity": rgb(intensity), "falloff": falloff})
    rng = np.random.default_rng(seed)
    # shading points 1 to 1e6 from the light (a point AT a point light is undefined)
    offsets = directions(rng) * 10.0 ** rng.uniform(0, 6, N)
    import drjit as dr
    it = dr.zeros(mi.Interaction3f, N)
    it.p = mi.Point3f((np.array(position)[:, None] + offsets).astype(np.float32))
    ds, weight = emitter.sample_direction(it, mi.Point2f(samples(rng)))
    ray, ray_weight = emitter.sample_ray(0.0, mi.Float(samples(rng, dim=1)[0]),
                                         mi.Point2f(samples(rng)), mi.Point2f(samples(rng)))
    assert_finite(ds_p=ds.p, ds_d=ds.d, ds_dist=ds.dist, ds_pdf=ds.pdf, weight=weight,
                  eval_direction=emitter.eval_direction(it, ds),
                  pdf_direction=emitter.pdf_direction(it, ds), ray_o=ray.o, ray_d=ray.d,
                  ray_weight=ray_weight)
    assert weight.numpy().min() >= 0


# -- valid parameters: sensors --------------------------------------------------------------

def rigid(mi, rng, mirror: bool):
    """A random rotation (with a mirror when asked) and translation."""
    axis = rng.normal(size=3)
    t = mi.ScalarTransform4f().translate([float(v) for v in rng.normal(size=3) * 100])
    t = t.rotate([float(v) for v in axis / np.linalg.norm(axis)], float(rng.uniform(-180, 180)))
    return t.scale([-1.0, 1.0, 1.0]) if mirror else t


def check_sensor(mi, sensor, rng):
    s1 = mi.Float(samples(rng, dim=1)[0])
    s2, s3 = mi.Point2f(samples(rng)), mi.Point2f(samples(rng))
    ray, weight = sensor.sample_ray(0.0, s1, s2, s3)
    rd, rd_weight = sensor.sample_ray_differential(0.0, s1, s2, s3)
    assert_finite(o=ray.o, d=ray.d, weight=weight, rd_o=rd.o, rd_d=rd.d,
                  o_x=rd.o_x, o_y=rd.o_y, d_x=rd.d_x, d_y=rd.d_y, rd_weight=rd_weight)
    np.testing.assert_allclose(np.linalg.norm(ray.d.numpy(), axis=0), 1.0, rtol=1e-4)
    assert ray.maxt.numpy().min() >= 0          # +inf allowed (far_clip = inf)


@st.composite
def film(draw):
    return {"type": "hdrfilm", "width": draw(st.integers(1, 64)),
            "height": draw(st.integers(1, 64)), "rfilter": {"type": "box"}}


@st.composite
def clip_range(draw):
    # near_clip up to 1e6: on the near plane a ray at nearly 90 degrees to the axis starts
    # near_clip / cos(angle) away, beyond float32 for huge near_clip (no meaningful camera)
    near = draw(st.one_of(st.just(0.0), positive(1e-30, 1e6)))
    far = draw(st.one_of(positive(1e-2, 1e300), st.just(math.inf)))
    return near, max(far, near * 1.001) + near


@st.composite
def pixel_offset(draw):
    if draw(st.booleans()):
        return {}
    return {"pixel_offset_x": draw(unit()), "pixel_offset_y": draw(unit())}


@examples(ci=10, long=1500)
@given(lens=st.sampled_from(["disc", "tutorial"]),
       fov=st.floats(0.0, 180.0, exclude_min=True, exclude_max=True),
       fov_axis=st.sampled_from(["x", "y", "diagonal", "smaller", "larger"]),
       aperture=st.one_of(st.just(0.0), positive(1e-30, 1e20)),
       focus=positive(1e-30, F32_MAX), clip=clip_range(), offset=pixel_offset(), film=film(),
       mirror=st.booleans(), seed=SEEDS)
def test_conic_rays_are_finite_unit(llvm, lens, fov, fov_axis, aperture, focus, clip, offset,
                                    film, mirror, seed):
    """Apertures up to 1e20 (the thin_lens sweep goes to 1e30): a ray from an aperture point
    at 1e38 towards a focus point at 1 runs almost parallel to the lens, and its start on the
    near plane lies beyond float32."""
    mi = llvm
    rng = np.random.default_rng(seed)
    sensor = mi.load_dict({"type": "conic", "lens": lens, "fov": fov, "fov_axis": fov_axis,
                           "aperture": aperture, "focus_distance": focus,
                           "near_clip": clip[0], "far_clip": clip[1], "film": film,
                           "to_world": rigid(mi, rng, mirror), **offset})
    check_sensor(mi, sensor, rng)


@examples(ci=8, long=1500)
@given(clip=clip_range(), offset=pixel_offset(), film=film(),
       scale=st.tuples(*[st.one_of(positive(1e-3, 1e3), positive(1e-3, 1e3).map(lambda v: -v))
                         for _ in range(3)]), mirror=st.booleans(), seed=SEEDS)
def test_tutorialortho_rays_are_finite_unit(llvm, clip, offset, film, scale, mirror, seed):
    mi = llvm
    rng = np.random.default_rng(seed)
    to_world = rigid(mi, rng, mirror).scale([float(v) for v in scale])
    sensor = mi.load_dict({"type": "tutorialortho", "near_clip": clip[0], "far_clip": clip[1],
                           "film": film, "to_world": to_world, **offset})
    check_sensor(mi, sensor, rng)


# -- invalid parameters ---------------------------------------------------------------------

NOT_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])
NOT_A_NUMBER = st.one_of(st.text(max_size=5), st.booleans())
NEGATIVE = st.floats(max_value=-1e-9, allow_nan=False, allow_infinity=False)


def outside(lo: float, hi: float):
    return st.one_of(st.floats(max_value=lo, exclude_max=True, allow_nan=False),
                     st.floats(min_value=hi, exclude_min=True, allow_nan=False), NOT_FINITE,
                     NOT_A_NUMBER)


def bad_colour(hi: float | None = None):
    """An RGB with a non-finite (or negative, or above ``hi``) channel."""
    bad = st.one_of(NOT_FINITE, NEGATIVE) if hi is None else \
        st.one_of(NOT_FINITE, NEGATIVE, st.floats(min_value=hi * 1.001, max_value=1e30))
    return st.tuples(bad, unit(), unit()).flatmap(lambda c: st.permutations(c)).map(rgb)


FACES = {name: None for name in ("up", "down", "right", "left", "forward", "backward")}

#: (plugin spec without the bad parameter, parameter, invalid values)
INVALID = [
    ({"type": "blinnphong"}, "exponent", outside(0.0, 1e6)),
    ({"type": "blinnphong"}, "diffuse_reflectance", bad_colour(1.0)),
    ({"type": "blinnphong"}, "specular_reflectance", bad_colour(1.0)),
    ({"type": "tutorial"}, "power", st.one_of(NEGATIVE, NOT_FINITE, NOT_A_NUMBER)),
    ({"type": "tutorial"}, "reflection", outside(0.0, 1.0)),
    ({"type": "tutorial"}, "refraction", outside(0.0, 1.0)),
    ({"type": "tutorial"}, "density", st.one_of(NEGATIVE, NOT_FINITE, NOT_A_NUMBER)),
    ({"type": "tutorial"}, "page", st.one_of(st.integers().filter(lambda p: p not in (1, 2, 4)),
                                             st.text(max_size=3), st.booleans())),
    ({"type": "tutorial", "page": 2}, "density", unit()),
    ({"type": "tutorial"}, "diffuse", bad_colour()),
    ({"type": "tutorial"}, "specular", bad_colour()),
    ({"type": "noisebump", "nested": {"type": "tutorial"}}, "bumplevel", outside(0.0, 1.0)),
    ({"type": "noisebump", "nested": {"type": "tutorial"}}, "frequency",
     st.one_of(st.just(0.0), NEGATIVE, NOT_FINITE, NOT_A_NUMBER)),
    ({"type": "noisebump", "nested": {"type": "tutorial"}}, "leak_check",
     st.one_of(st.integers(), st.text(max_size=5))),
    ({"type": "perlin"}, "frequency", st.one_of(st.just(0.0), NEGATIVE, NOT_FINITE, NOT_A_NUMBER)),
    ({"type": "turbulence"}, "octaves", st.one_of(st.integers().filter(lambda o: not 1 <= o <= 64),
                                                  st.floats(), st.text(max_size=3))),
    ({"type": "turbulence"}, "color0", st.tuples(NOT_FINITE, unit(), unit()).map(rgb)),
    ({"type": "marble"}, "stripe_frequency", st.one_of(st.just(0.0), NEGATIVE, NOT_FINITE)),
    ({"type": "cubemap", **FACES}, "exposure", st.one_of(st.just(0.0), NEGATIVE, NOT_FINITE,
                                                         NOT_A_NUMBER)),
    ({"type": "cubemap", **FACES}, "scale", st.one_of(NOT_FINITE, NOT_A_NUMBER,
                                                      st.floats(min_value=3.5e38))),
    ({"type": "cubemap", **FACES}, "mode", st.text(max_size=8).filter(
        lambda m: m not in ("light", "background"))),
    ({"type": "cubemap", **FACES}, "srgb", st.one_of(st.integers(), st.text(max_size=5))),
    ({"type": "tutorialpoint"}, "intensity", st.tuples(NOT_FINITE, unit(), unit()).map(rgb)),
    ({"type": "tutorialpoint"}, "position", st.tuples(NOT_FINITE, unit(), unit()).map(list)),
    ({"type": "tutorialpoint"}, "falloff", st.one_of(st.integers(), st.text(max_size=5))),
    ({"type": "conic"}, "fov", st.one_of(outside(0.0, 180.0), st.sampled_from([0.0, 180.0]))),
    ({"type": "conic"}, "aperture", st.one_of(NEGATIVE, NOT_FINITE, NOT_A_NUMBER,
                                              st.floats(min_value=3.5e38))),
    ({"type": "conic", "aperture": 1.0}, "focus_distance",
     st.one_of(st.just(0.0), NEGATIVE, NOT_FINITE, NOT_A_NUMBER)),
    ({"type": "conic"}, "lens", st.text(max_size=8).filter(lambda m: m not in ("disc", "tutorial"))),
    ({"type": "conic"}, "near_clip", st.one_of(NEGATIVE, st.just(math.nan), NOT_A_NUMBER,
                                               st.floats(min_value=1e4))),
    ({"type": "conic", "far_clip": math.inf}, "near_clip", st.floats(min_value=3.5e38)),
    ({"type": "tutorialortho", "far_clip": math.inf}, "near_clip", st.floats(min_value=3.5e38)),
    ({"type": "conic", "pixel_offset_x": 0.5}, "pixel_offset_y", outside(0.0, 1.0)),
    ({"type": "tutorialortho"}, "far_clip", st.one_of(NEGATIVE, st.just(0.0),
                                                      st.just(math.nan), NOT_A_NUMBER)),
    ({"type": "tutorialortho", "pixel_offset_y": 0.5}, "pixel_offset_x", outside(0.0, 1.0)),
]


@pytest.fixture(scope="module")
def faces(tmp_path_factory):
    """Six 2x2 faces as files (a cubemap needs them to get to its parameter checks)."""
    import mitsuba as mi
    folder = tmp_path_factory.mktemp("faces")
    mi.set_variant("llvm_ad_rgb")
    for name in FACES:
        mi.Bitmap(np.full((2, 2, 3), 0.5, np.float32)).write(str(folder / f"{name}.exr"))
    return {name: str(folder / f"{name}.exr") for name in FACES}


@examples(ci=60, long=20_000)
@given(data=st.data())
def test_invalid_parameters_name_the_parameter(llvm, faces, data):
    mi = llvm
    base, name, values = data.draw(st.sampled_from(INVALID), label="case")
    value = data.draw(values, label=name)
    spec = {k: (faces[k] if k in faces and v is None else v) for k, v in base.items()}
    spec[name] = value
    with pytest.raises((RuntimeError, ValueError)) as e:
        mi.load_dict(spec)
    last = str(e.value).strip().splitlines()[-1]
    assert f"'{name}'" in last or f'"{name}"' in last, last
