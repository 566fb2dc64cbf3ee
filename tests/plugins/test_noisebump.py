"""noisebump: the perturbed normal is the tutorial's (facts.md F10, with the flip-before-bump
for hits from inside), checked through nested tutorial BSDFs against the float64 noise of
``perlin64``; a bumped sphere rendered with ``path`` equals the closed form per pixel.

Tolerances: positions up to 700 world units scaled by 0.1 are rounded to float32 before the
noise (half an ulp of 70 is 3.8e-6), and the noise has gradients up to about 3, so the
bump vector carries errors of ~1e-5 times b; mirror directions double that, refraction
near grazing angles amplifies it further."""

from __future__ import annotations

import numpy as np
import pytest

from support import perlin64
from support.closed_form import (CENTER, RADIUS, fresnel, lighting, material, normalize,
                         render_with_positions)

B = 0.3    # a strong bump, so that errors in the perturbation are visible
F = 0.1    # the tutorial's bump frequency per pixel (its world unit), which perlin64 uses


def bump_normal(p, n, b, front=True, gradient="tutorial"):
    """The tutorial's bumped facing normal: normalize((1-b) f + b N), f = n or -n."""
    f = n if front else -n
    return normalize((1 - b) * f + b * perlin64.bump_vector(p.T, gradient=gradient).T)


def interaction(mi, dr, p, n_geo, wi_world):
    """A surface interaction at points p with normal n (shading = geometric)."""
    k = len(p)
    si = dr.zeros(mi.SurfaceInteraction3f, k)
    si.p = mi.Point3f(p.T.astype(np.float32))
    si.n = mi.Normal3f(n_geo.T.astype(np.float32))
    si.sh_frame = mi.Frame3f(mi.Vector3f(si.n))
    si.wi = si.sh_frame.to_local(mi.Vector3f(wi_world.T.astype(np.float32)))
    return si


def random_setup(k, seed):
    rng = np.random.default_rng(seed)
    n = normalize(rng.normal(size=(k, 3)))
    p = rng.uniform(-300, 700, (k, 3))
    # wi within 75 degrees of n (front side)
    t = normalize(rng.normal(size=(k, 3)))
    t = normalize(t - np.sum(t * n, axis=1, keepdims=True) * n)
    ang = rng.uniform(0, np.radians(75), k)[:, None]
    wi = np.cos(ang) * n + np.sin(ang) * t
    return p.astype(np.float32).astype(np.float64), n, wi


@pytest.mark.parametrize("front", [True, False])
def test_perturbed_normal_lambert(llvm, front):
    """A nested page-2 Lambert material reports cos = wo . n' of the bumped normal; from
    behind, n' is the outward side of normalize((1-b)(-n) + b N)."""
    mi = llvm
    import drjit as dr
    k = 2000
    p, n, wi = random_setup(k, 1)
    if not front:
        wi = -wi
    bsdf = mi.load_dict({"type": "noisebump", "bumplevel": B, "frequency": F,
                         "inner": material(page=2, diffuse=1.0, specular=0.0)})
    facing = bump_normal(p, n, B, front)
    outward = facing if front else -facing
    wo = normalize(outward + 0.5 * normalize(np.random.default_rng(2).normal(size=(k, 3))))
    si = interaction(mi, dr, p, n, wi)
    value = bsdf.eval(mi.BSDFContext(), si, si.sh_frame.to_local(
        mi.Vector3f(wo.T.astype(np.float32)))).numpy()[0]
    expected = np.maximum(np.sum(wo * outward, axis=1), 0)
    np.testing.assert_allclose(value, expected, atol=1e-5)


@pytest.mark.parametrize("gradient", [None, "tutorial", "reference"])
def test_mirror_reflects_about_bumped_normal(llvm, gradient):
    """Mirror about the bumped normal, with each noise gradient (None: the default, the
    tutorial's); the other gradient's normal is measurably different."""
    mi = llvm
    import drjit as dr
    k = 2000
    p, n, wi = random_setup(k, 3)
    spec = {"type": "noisebump", "bumplevel": B, "frequency": F,
            "inner": material(page=2, diffuse=0.0, specular=0.0, reflection=1.0)}
    if gradient:
        spec["gradient"] = gradient
    bsdf = mi.load_dict(spec)
    si = interaction(mi, dr, p, n, wi)
    bs, weight = bsdf.sample(mi.BSDFContext(), si, 0.5, mi.Point2f(0.5, 0.5))
    wo = si.sh_frame.to_world(bs.wo).numpy().T
    gradient = gradient or "tutorial"
    for g in ("tutorial", "reference"):
        f = bump_normal(p, n, B, gradient=g)
        expected = 2 * np.sum(wi * f, axis=1, keepdims=True) * f - wi
        if g == gradient:
            np.testing.assert_allclose(wo, expected, atol=2e-5)
        else:
            assert np.abs(wo - expected).max() > 0.05
    assert (weight.numpy() == 1).all()


def test_refraction_from_inside_uses_flipped_then_bumped_normal(llvm):
    """Inside a page-4 glass (the tutorial's blob): the refracted direction is Snell's with
    the facing normal f' = normalize((1-b)(-n) + b N), n1 = density, n2 = 1."""
    mi = llvm
    import drjit as dr
    k = 2000
    p, n, wi = random_setup(k, 4)
    wi = -wi                                         # behind the (outward) normal
    bsdf = mi.load_dict({"type": "noisebump", "bumplevel": B, "frequency": F,
                         "inner": material(page=4, diffuse=0.0, specular=0.0, reflection=0.0,
                                           refraction=1.0, density=1.3)})
    si = interaction(mi, dr, p, n, wi)
    bs, weight = bsdf.sample(mi.BSDFContext(), si, 0.5, mi.Point2f(0.5, 0.5))
    wo = si.sh_frame.to_world(bs.wo).numpy().T
    d = -wi
    f = bump_normal(p, n, B, front=False)
    cos_i = np.abs(np.sum(d * f, axis=1))
    r, cos_t = fresnel(cos_i, 1.3, 1.0)
    refr = (weight.numpy()[0] > 0) & (r < 1)
    assert refr.mean() > 0.5
    expected = normalize((1.3 * (d + cos_i[:, None] * f) - cos_t[:, None] * f))
    # float32 errors of the normal (~1e-6) grow as 1/cos_t in the refracted direction: with
    # the tutorial's noise one of these samples refracts at cos_t = 0.013 (error 5.8e-5)
    err = np.abs(wo - expected).max(axis=1)
    assert (err[refr] <= 1e-5 + 3e-6 / cos_t[refr]).all()
    assert (bs.sampled_component.numpy()[refr] == 3).all()


def test_bumped_sphere_render_matches_closed_form(llvm):
    """path + tutorialpoint + noisebump(tutorial page 2) on a sphere of radius 100: each
    pixel is the tutorial's Lambert + Blinn with the bumped normal (0 where the light is
    behind the geometric normal: the sphere shadows itself there)."""
    mi = llvm
    center, radius = np.array([0.0, 0.0, 500.0]), 100.0
    light = np.array([300.0, 300.0, 100.0])
    value, pos = render_with_positions(mi, {"ball": {
        "type": "sphere", "center": center.tolist(), "radius": radius,
        "bsdf": {"type": "noisebump", "bumplevel": 0.1, "frequency": F, "inner": material()}}},
        max_depth=11, light=light)
    on = np.abs(np.linalg.norm(pos - center, axis=-1) - radius) < 0.05
    p = pos[on]
    n = normalize(p - center)
    cos_geo = np.sum(normalize(light - p) * n, axis=1)
    expected = lighting(p, bump_normal(p, n, 0.1), normalize(-p), light=light)
    expected[cos_geo <= 0] = 0
    keep = np.abs(cos_geo) > 0.02                    # away from the terminator
    assert on.sum() > 300 and expected[keep].max() > 0.5
    np.testing.assert_allclose(value[on][keep], expected[keep], rtol=1e-4, atol=1e-5)


def test_zero_bump_is_the_nested_bsdf(llvm):
    mi = llvm
    objects = lambda bsdf: {"ball": {"type": "sphere", "center": CENTER.tolist(),  # noqa: E731
                                     "radius": RADIUS, "bsdf": bsdf}}
    plain, _ = render_with_positions(mi, objects(material()), max_depth=3, size=24)
    bumped, _ = render_with_positions(
        mi, objects({"type": "noisebump", "bumplevel": 0.0, "frequency": F,
                     "inner": material()}), max_depth=3, size=24)
    np.testing.assert_allclose(bumped, plain, rtol=1e-5, atol=1e-7)


def test_leak_check(llvm):
    """With leak_check a direction below the original shading plane gives nothing even if
    it is above the bumped one; without it the tutorial's lighting goes through."""
    mi = llvm
    import drjit as dr
    k = 4000
    p, n, wi = random_setup(k, 6)
    si = interaction(mi, dr, p, n, wi)
    f = bump_normal(p, n, 0.6)
    # just below the geometric plane, but above the bumped one where possible
    t = normalize(f - np.sum(f * n, axis=1, keepdims=True) * n)
    wo = normalize(t - 0.05 * n)
    wo_local = si.sh_frame.to_local(mi.Vector3f(wo.T.astype(np.float32)))
    above = np.sum(wo * f, axis=1) > 0.01
    assert above.mean() > 0.5
    values = {}
    for check in (False, True):
        bsdf = mi.load_dict({"type": "noisebump", "bumplevel": 0.6, "frequency": F,
                             "leak_check": check,
                             "inner": material(page=2, diffuse=1.0, specular=0.0)})
        values[check] = bsdf.eval(mi.BSDFContext(), si, wo_local).numpy()[0]
    assert (values[False][above] > 0).all()
    assert (values[True] == 0).all()


@pytest.mark.parametrize("params, message", [
    ({"bumplevel": 1.5, "inner": {"type": "diffuse"}}, "noisebump: 'bumplevel'"),
    ({"bumplevel": -0.1, "inner": {"type": "diffuse"}}, "noisebump: 'bumplevel'"),
    ({"frequency": 0.0, "inner": {"type": "diffuse"}}, "noisebump: 'frequency'"),
    ({"bumplevel": 0.1}, "noisebump: needs exactly one nested BSDF"),
    ({"bumplevel": 0.1, "a": {"type": "diffuse"}, "b": {"type": "diffuse"}},
     "noisebump: needs exactly one nested BSDF, got 2"),
    ({"inner": {"type": "diffuse"}, "noise": {"type": "perlin"}},
     "noisebump: 'noise' is a Texture, but the only nested object it takes is one BSDF"),
    # a misspelled parameter is never read, and Mitsuba refuses what no plugin read
    ({"bumplvel": 0.3, "inner": {"type": "diffuse"}}, '(?s)unreferenced property.*"bumplvel"'),
])
def test_bad_parameters(llvm, params, message):
    mi = llvm
    with pytest.raises(RuntimeError, match=message):
        mi.load_dict({"type": "noisebump", **params})


def test_scalar_variant(scalar):
    mi = scalar
    bsdf = mi.load_dict({"type": "noisebump", "bumplevel": B, "frequency": F,
                         "inner": material(page=2, diffuse=1.0, specular=0.0)})
    p, n = np.array([[120.5, -40.25, 300.0]]), np.array([[0.0, 0.0, 1.0]])
    si = mi.SurfaceInteraction3f()
    si.p = mi.Point3f(*map(float, p[0]))
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.wi = mi.Vector3f(0, 0, 1)
    value = bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(0, 0, 1))
    expected = bump_normal(p, n, B)[0, 2]
    np.testing.assert_allclose(np.array(value), expected, rtol=1e-5)


def test_scalar_render_of_all_material_plugins(scalar):
    """A tiny render in scalar_rgb with every plugin of this part nested as a tutorial
    scene would: noisebump(tutorial(turbulence)), tutorial(marble), blinnphong(perlin).
    (A built-in point light, so that this test depends on no other part.)"""
    mi = scalar
    T = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 60,
                   "to_world": T().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 12, "height": 8},
                   "sampler": {"type": "independent", "sample_count": 1}},
        "light": {"type": "point", "position": [0, 200, 0], "intensity": 2e5},
        "a": {"type": "sphere", "center": [-150, 0, 300], "radius": 80, "bsdf": {
            "type": "noisebump", "bumplevel": 0.1, "frequency": F, "inner": {
                "type": "tutorial", "page": 4, "density": 1.5, "reflection": 0.5,
                "refraction": 0.5, "diffuse": {"type": "turbulence"}}}},
        "b": {"type": "sphere", "center": [0, 0, 300], "radius": 80, "bsdf": {
            "type": "tutorial", "page": 4, "density": 1.0, "diffuse": {"type": "marble"}}},
        "c": {"type": "sphere", "center": [150, 0, 300], "radius": 80, "bsdf": {
            "type": "blinnphong", "specular_reflectance": 0.2,
            "diffuse_reflectance": {"type": "perlin", "frequency": 0.05}}},
    })
    image = np.array(mi.render(scene))
    assert image.shape == (8, 12, 3) and np.isfinite(image).all()
    assert all(image[:, k:k + 4].max() > 0 for k in (0, 4, 8))     # all three spheres


@pytest.mark.parametrize("wrapped", [False, True])
def test_fused_eval_sample_equals_eval_and_sample(llvm, wrapped):
    """``eval_sample`` (the one call per hit of ``tutorialpath``) gives exactly ``eval``
    towards each direction and ``sample`` (internal agreement of the two code paths; the
    integrator's expectation is checked against ``path`` in test_tutorialpath.py). Glass
    seen from both sides, with a turbulence diffuse colour."""
    mi = llvm
    import drjit as dr
    k = 1000
    p, n, wi = random_setup(k, 5)
    wi[k // 2:] *= -1                                   # half of the hits from inside
    inner = {"type": "tutorial", "diffuse": {"type": "turbulence"}, "specular": 1.2,
             "power": 60.0, "reflection": 0.9, "refraction": 0.9, "density": 2.0}
    bsdf = mi.load_dict({"type": "noisebump", "bumplevel": B, "frequency": F, "inner": inner}
                        if wrapped else inner)
    si = interaction(mi, dr, p, n, wi)
    rng = np.random.default_rng(6)
    wos = [si.sh_frame.to_local(mi.Vector3f(normalize(rng.normal(size=(k, 3))).T
                                            .astype(np.float32))) for _ in range(2)]
    u = mi.Float(rng.uniform(size=k).astype(np.float32))
    u2 = mi.Point2f(0.5)
    ctx = mi.BSDFContext()
    values, bs, weight = bsdf.eval_sample(ctx, si, wos, u, u2, True)
    bs_ref, weight_ref = bsdf.sample(ctx, si, u, u2, True)
    for wo, value in zip(wos, values):
        ref = bsdf.eval(ctx, si, wo, True).numpy()
        assert np.abs(ref).max() > 0
        np.testing.assert_array_equal(value.numpy(), ref)
    np.testing.assert_array_equal(weight.numpy(), weight_ref.numpy())
    np.testing.assert_array_equal(bs.wo.numpy(), bs_ref.wo.numpy())
    np.testing.assert_array_equal(bs.pdf.numpy(), bs_ref.pdf.numpy())
    np.testing.assert_array_equal(bs.sampled_type.numpy(), bs_ref.sampled_type.numpy())


def test_default_frequency_bumps_an_object_of_radius_one(llvm):
    """The default frequency suits a scene in Mitsuba's usual units: over a sphere of radius
    1 the angle between the bumped and the unbumped normal (bumplevel 0.1) varies with an sd
    above 0.5 degrees (measured 1.06; mean 2.1). At the tutorial's 0.1 per pixel the noise
    hardly changes over such a sphere, which then only tilts evenly (sd 0.10): the control."""
    mi = llvm
    import drjit as dr
    rng = np.random.default_rng(4)
    n = normalize(rng.normal(size=(20_000, 3)))
    si = interaction(mi, dr, n, n, n)          # on the unit sphere, seen along its normal

    def angle_sd(**frequency):
        bsdf = mi.load_dict({"type": "noisebump", "bumplevel": 0.1, **frequency,
                             "inner": material(page=2, diffuse=1.0, specular=0.0)})
        wo = si.sh_frame.to_local(mi.Vector3f(n.T.astype(np.float32)))
        # the nested Lambert term is cos(wo, n'): along n it is cos of the bump's angle
        cos = bsdf.eval(mi.BSDFContext(), si, wo).numpy()[0]
        return np.degrees(np.arccos(np.clip(cos, -1, 1))).std()

    assert angle_sd() > 0.5
    assert angle_sd(frequency=F) < 0.25
