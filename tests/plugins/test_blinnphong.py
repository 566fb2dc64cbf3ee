"""blinnphong: sampling matches pdf (chi2), eval == weight * pdf, reciprocity, energy
conservation (white furnace), rendering with the built-in path tracer, parameter checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

EXPONENTS = [1, 10, 100, 1000, 10000]
ANGLES = [10, 30, 60, 85]          # incident angle in degrees


def spectrum(value):
    return {"type": "rgb", "value": list(value)} if isinstance(value, (tuple, list)) else value


def bsdf_dict(exponent, kd=0.3, ks=0.5):
    return {"type": "blinnphong", "exponent": float(exponent),
            "diffuse_reflectance": spectrum(kd), "specular_reflectance": spectrum(ks)}


def incident(deg):
    th = math.radians(deg)
    return [math.sin(th), 0.0, math.cos(th)]


def chi2_res(exponent, deg):
    """Histogram resolution for mitsuba.chi2: SphericalDomain has res/2 cells in phi, each
    integrated with ires=16 points; near grazing the reflected lobe is only about
    2 cos(theta_i) / (sqrt(n) sin(theta_i)) wide in phi, and the integration step must not
    exceed that (else the test's own quadrature fails, not the BSDF)."""
    th = math.radians(deg)
    width = 2 * math.cos(th) / (math.sqrt(exponent + 1) * math.sin(th))
    res = max(101, int(4 * math.pi / (15 * width)))
    return res | 1                  # odd, as mitsuba.chi2 recommends


@pytest.mark.parametrize("exponent", EXPONENTS)
@pytest.mark.parametrize("deg", ANGLES)
def test_chi2_sampling_matches_pdf(llvm, exponent, deg):
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain
    sample, pdf = BSDFAdapter("blinnphong", bsdf_dict(exponent), wi=incident(deg))
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf,
                         sample_dim=3, res=chi2_res(exponent, deg),
                         ires=16 if exponent >= 100 else 4)
    # 20 tests together at the 1 % level (Sidak correction inside mitsuba.chi2)
    assert chi2.run(0.01, test_count=len(EXPONENTS) * len(ANGLES)), chi2.messages


def _interaction(mi, dr, n, wi):
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = wi
    return si


@pytest.mark.parametrize("exponent", [1, 100, 10000])
def test_eval_equals_weight_times_pdf(llvm, exponent):
    mi = llvm
    import drjit as dr
    bsdf = mi.load_dict(bsdf_dict(exponent, kd=(0.2, 0.3, 0.4), ks=(0.5, 0.4, 0.3)))
    ctx, n = mi.BSDFContext(), 50_000
    rng = np.random.default_rng(3)
    wi = mi.warp.square_to_uniform_hemisphere(mi.Point2f(rng.random((2, n))))
    si = _interaction(mi, dr, n, wi)
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(n)), mi.Point2f(rng.random((2, n))))
    value, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
    ok = (bs.pdf > 0).numpy()
    assert ok.mean() > 0.5
    np.testing.assert_allclose((weight * bs.pdf).numpy()[:, ok], value.numpy()[:, ok],
                               rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(pdf.numpy()[ok], bs.pdf.numpy()[ok], rtol=1e-5)
    # eval_pdf agrees with eval and pdf, and the sampled type matches the lobe
    np.testing.assert_allclose(bsdf.eval(ctx, si, bs.wo).numpy(), value.numpy(), rtol=1e-6)
    np.testing.assert_allclose(bsdf.pdf(ctx, si, bs.wo).numpy(), pdf.numpy(), rtol=1e-6)
    glossy = (bs.sampled_component == 1).numpy()
    assert 0.2 < glossy.mean() < 0.8
    assert ((bs.sampled_type.numpy() == int(mi.BSDFFlags.GlossyReflection)) == glossy).all()


def test_reciprocity(llvm):
    mi = llvm
    import drjit as dr
    ctx, n = mi.BSDFContext(), 20_000
    rng = np.random.default_rng(4)
    a = mi.warp.square_to_uniform_hemisphere(mi.Point2f(rng.random((2, n))))
    b = mi.warp.square_to_uniform_hemisphere(mi.Point2f(rng.random((2, n))))
    for exponent in (1, 30, 3000):
        bsdf = mi.load_dict(bsdf_dict(exponent))
        f_ab = bsdf.eval(ctx, _interaction(mi, dr, n, a), b) / mi.Frame3f.cos_theta(b)
        f_ba = bsdf.eval(ctx, _interaction(mi, dr, n, b), a) / mi.Frame3f.cos_theta(a)
        np.testing.assert_allclose(f_ab.numpy(), f_ba.numpy(), rtol=2e-4, atol=1e-7)


def test_closed_form_value(llvm):
    """eval at one configuration against the documented formula, by hand."""
    mi = llvm
    import drjit as dr
    n, kd, ks = 20.0, 0.25, 0.5
    bsdf = mi.load_dict(bsdf_dict(n, kd, ks))
    wi = np.array([0.3, 0.1, 0.0]); wi[2] = math.sqrt(1 - wi @ wi)
    wo = np.array([-0.2, 0.25, 0.0]); wo[2] = math.sqrt(1 - wo @ wo)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    spec = ks * (n + 1) / (2 * math.pi) * h[2] ** n / (4 * (wi @ h) * max(wi[2], wo[2]))
    expected = (kd / math.pi + spec) * wo[2]
    si = _interaction(mi, dr, 1, mi.Vector3f(*map(float, wi)))
    value = bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, wo))).numpy()
    np.testing.assert_allclose(value, expected, rtol=1e-5)


def albedo(mi, dr, bsdf, deg, n=400_000, seed=5):
    rng = np.random.default_rng(seed)
    si = _interaction(mi, dr, n, mi.Vector3f(*incident(deg)))
    _, weight = bsdf.sample(mi.BSDFContext(), si, mi.Float(rng.random(n)),
                            mi.Point2f(rng.random((2, n))))
    w = weight.numpy()[0]
    return float(w.mean()), float(w.std()) / math.sqrt(n), float(w.max())


def specular_albedo_normal_incidence(n):
    """Albedo of the lobe alone (ks = 1) at normal incidence: there theta_o = 2 theta_h and
    max(cos) = 1, so it is E[cos 2 theta_h; theta_h < 45 deg] under the half-vector density
    (n + 1) cos^n sin, which integrates in closed form."""
    return (n + 1) * (2 * (1 - 2 ** (-(n + 3) / 2)) / (n + 3) - (1 - 2 ** (-(n + 1) / 2)) / (n + 1))


@pytest.mark.parametrize("exponent", EXPONENTS)
def test_white_furnace(llvm, exponent):
    """Albedo <= 1 at every angle: the sample weight itself never exceeds kd + ks = 1, so
    the estimate is a mean of values <= 1. A white lossless diffuse material (kd = 1) has
    albedo 1; a white lobe (ks = 1) keeps nearly all energy for sharp lobes away from
    grazing (>= 0.98 for n >= 1000 up to 30 degrees; it loses the part of the lobe below
    the horizon and to the max(cos) normalization: 0.25 for n = 1, 0.961 for n = 100 at
    normal incidence, 0.74 for n = 1000 at 85 degrees)."""
    mi = llvm
    import drjit as dr
    for kd, ks in ((1.0, 0.0), (0.0, 1.0), (0.5, 0.5)):
        bsdf = mi.load_dict(bsdf_dict(exponent, kd, ks))
        for deg in (0, 30, 60, 85):
            mean, err, wmax = albedo(mi, dr, bsdf, deg)
            assert wmax <= 1 + 1e-5
            assert mean <= 1 + 1e-5
            if ks == 0:
                assert mean == pytest.approx(1.0, abs=1e-5)
            if ks == 1 and deg == 0:
                assert mean == pytest.approx(specular_albedo_normal_incidence(exponent),
                                             abs=4 * err + 1e-5)
            if ks == 1 and exponent >= 1000 and deg <= 30:
                assert mean >= 0.98


def test_renders_with_path_tracer(llvm):
    """Global illumination with the built-in path integrator: a Cornell-like box with a
    blinnphong sphere and walls gives a finite image, brighter than direct lighting only."""
    mi = llvm

    def scene(max_depth):
        wall = {"type": "blinnphong", "diffuse_reflectance": 0.6, "specular_reflectance": 0.3,
                "exponent": 50.0}
        T = mi.ScalarTransform4f
        return mi.load_dict({
            "type": "scene",
            "integrator": {"type": "path", "max_depth": max_depth},
            "sensor": {"type": "perspective", "fov": 50,
                       "to_world": T().look_at(origin=[0, 0, 3.5], target=[0, 0, 0], up=[0, 1, 0]),
                       "film": {"type": "hdrfilm", "width": 32, "height": 32},
                       "sampler": {"type": "independent", "sample_count": 32}},
            "light": {"type": "point", "position": [0, 0.8, 0.5], "intensity": 5.0},
            "floor": {"type": "rectangle", "bsdf": wall,
                      "to_world": T().translate([0, -1, 0]).rotate([1, 0, 0], -90)},
            "back": {"type": "rectangle", "bsdf": wall, "to_world": T().translate([0, 0, -1])},
            "ball": {"type": "sphere", "radius": 0.4, "center": [0, -0.6, 0],
                     "bsdf": bsdf_dict(200, kd=0.2, ks=0.7)},
        })

    direct = mi.render(scene(2), seed=1).numpy()
    gi = mi.render(scene(6), seed=1).numpy()
    assert np.isfinite(gi).all() and (gi >= 0).all()
    assert gi.mean() > direct.mean() * 1.05      # indirect light adds
    assert 0.01 < gi.mean() < 10


@pytest.mark.parametrize("params, name", [
    ({"exponent": -1.0}, "exponent"),
    ({"exponent": float("nan")}, "exponent"),
    ({"diffuse_reflectance": -0.1}, "diffuse_reflectance"),
    ({"specular_reflectance": -0.2}, "specular_reflectance"),
    ({"diffuse_reflectance": 0.7, "specular_reflectance": 0.5}, "diffuse_reflectance"),
    ({"diffuse_reflectance": float("nan")}, "diffuse_reflectance"),
    ({"diffuse_reflectance": (1.5, 0.1, 0.1)}, "diffuse_reflectance"),
    ({"specular_reflectance": (0.1, float("nan"), 0.1)}, "specular_reflectance"),
])
def test_bad_parameters_name_the_parameter(llvm, params, name):
    mi = llvm
    d = {"type": "blinnphong", **{k: spectrum(v) for k, v in params.items()}}
    with pytest.raises(RuntimeError, match=f"blinnphong: '{name}'"):
        mi.load_dict(d)


def test_scalar_variant(scalar):
    mi = scalar
    bsdf = mi.load_dict(bsdf_dict(50.0, kd=0.4, ks=0.5))
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*incident(30))
    ctx = mi.BSDFContext()
    bs, weight = bsdf.sample(ctx, si, 0.3, mi.Point2f(0.4, 0.6))
    value, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
    assert bs.pdf > 0
    np.testing.assert_allclose(np.array(weight) * bs.pdf, np.array(value), rtol=1e-5)
