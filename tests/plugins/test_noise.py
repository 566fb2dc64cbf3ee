"""Perlin noise and the solid textures against the independent float64 reference
(tests/support/perlin64.py), for each ``gradient`` choice (the tutorial's and Perlin's 2002
reference, facts.md F9), the measured noise values of facts.md F14.5, the float32 breakdown, and the
texture plugins' interface."""

from __future__ import annotations

import numpy as np
import pytest

from support import perlin64


GRADIENTS = ("tutorial", "reference")


def noise32(mi, p, gradient="tutorial"):
    from codermind.textures import _noise
    p = np.asarray(p, dtype=np.float32)
    value = _noise.noise(mi.Float(p[0]), mi.Float(p[1]), mi.Float(p[2]), gradient)
    return value.numpy().astype(np.float64)


def interaction(mi, p):
    import drjit as dr
    p = np.asarray(p, dtype=np.float32)
    si = dr.zeros(mi.SurfaceInteraction3f, p.shape[1])
    si.p = mi.Point3f(p)
    return si


def test_reference_is_perlins():
    """The test's own reference reproduces the value printed by Perlin's Java reference
    implementation, noise(3.14, 42, 7) = 0.136919958784, so its table and code are his; the
    value of the reference gradient at (1.3, 2.7, -5.55), -0.4458 (facts.md F14.5), checks its grad()."""
    for gradient in GRADIENTS:      # none of its corners hashes to 13 or 14 (facts.md F14.5)
        value = float(perlin64.noise(3.14, 42, 7, gradient))
        assert value == pytest.approx(0.13691995878400012, abs=1e-15)
    assert float(perlin64.noise(1.3, 2.7, -5.55, "reference")) == pytest.approx(-0.4458,
                                                                               abs=5e-5)
    assert sorted(perlin64._P[:256]) == list(range(256))


def test_tutorial_reference_matches_the_original_program():
    """Spec "Corrections" (measured on the original page-4 program): its noise(1.3, 2.7,
    -5.55) is about -0.5538 and its noise(3.14, 42, 7) is 0.13691995878400012; the test's
    double transcription of the tutorial's grad() gives both."""
    assert float(perlin64.noise(1.3, 2.7, -5.55, "tutorial")) == pytest.approx(-0.5538,
                                                                              abs=5e-5)
    assert float(perlin64.noise(3.14, 42, 7, "tutorial")) == 0.13691995878400012


def test_gradients_differ_only_for_hashes_13_and_14():
    """facts.md F9: the tutorial's and the reference grad() agree for every h except 13, 14."""
    x, y, z = np.random.default_rng(3).normal(size=(3, 50))
    for h in range(16):
        same = np.allclose(perlin64._grad_tutorial(np.full(50, h), x, y, z),
                           perlin64._grad_reference(np.full(50, h), x, y, z))
        assert same == (h not in (13, 14)), h


@pytest.mark.parametrize("gradient, expected", [("tutorial", -0.5538), ("reference", -0.4458)])
def test_plugin_gives_the_spec_values(llvm, gradient, expected):
    """Through the perlin texture (frequency 1, from XML-style properties): the values
    of each gradient (facts.md F14.5) at (1.3, 2.7, -5.55) and noise(3.14, 42, 7) = 0.13691995878400012 (both),
    within the float32 error of the rounded positions (<= 2e-6). Default: the tutorial's."""
    mi = llvm
    import drjit as dr
    spec = {"type": "perlin"} if gradient == "tutorial" else {"type": "perlin",
                                                              "gradient": gradient}
    texture = mi.load_dict(spec)
    si = dr.zeros(mi.SurfaceInteraction3f, 2)
    si.p = mi.Point3f([1.3, 3.14], [2.7, 42.0], [-5.55, 7.0])
    a, b = texture.eval_1(si).numpy().astype(np.float64)
    assert a == pytest.approx(expected, abs=5e-5 + 2e-6)
    assert b == pytest.approx(0.13691995878400012, abs=2e-6)
    assert f"gradient = {gradient}" in str(texture)


def test_plugin_table_is_perlins_not_the_typo(llvm):
    from codermind.textures import _noise
    table = _noise.PERMUTATION
    assert sorted(table) == list(range(256))          # a permutation: 23 is not doubled
    assert table[156] == 223 and table[28] == 23
    assert list(table) == perlin64._P[:256].tolist()


@pytest.mark.parametrize("gradient", GRADIENTS)
@pytest.mark.parametrize("scale", [1.0, 10.0, 100.0, 1e3, 1e4])
def test_noise_matches_double_reference(llvm, scale, gradient):
    """|noise_f32(p) - noise_f64(p)| <= 2e-6 for float32 inputs p, |p_i| <= 1e4, for each
    gradient; and the two gradients' noises differ (by up to ~1), so the check tells them
    apart."""
    rng = np.random.default_rng(int(scale))
    p = (rng.uniform(-1, 1, (3, 400_000)) * scale).astype(np.float32)
    value = noise32(llvm, p, gradient)
    err = np.abs(value - perlin64.noise(*p.astype(np.float64), gradient))
    assert err.max() <= 2e-6
    other = "reference" if gradient == "tutorial" else "tutorial"
    if scale >= 10:
        assert np.abs(value - perlin64.noise(*p.astype(np.float64), other)).max() > 0.3


@pytest.mark.parametrize("gradient", GRADIENTS)
def test_noise_near_lattice_points(llvm, gradient):
    """Cell boundaries, negative coordinates and the wrap at 256: just below, at and just
    above integers, where the floor and the hash change."""
    k = np.arange(-300, 300, 7, dtype=np.float64)
    offsets = np.array([-1e-3, -np.float32(2 ** -20), 0.0, 2 ** -20, 1e-3, 0.5])
    grid = (k[:, None] + offsets[None, :]).ravel()
    p = np.stack([grid, np.roll(grid, 5), np.roll(grid, 11)]).astype(np.float32)
    err = np.abs(noise32(llvm, p, gradient) - perlin64.noise(*p.astype(np.float64), gradient))
    assert err.max() <= 2e-6
    lattice = np.stack([k, k + 1, -k]).astype(np.float32)
    assert (noise32(llvm, lattice, gradient) == 0).all()   # zero at every lattice point


def test_float32_breakdown(llvm):
    """Where float32 stops representing the noise (measured; a documentation test).

    Here the reference is evaluated at the exact float64 point and the plugin at that point
    rounded to float32 (as any world position is), with each coordinate's magnitude in
    [M/2, M]. Measured with 200k points per M (seeded):

    ======== ============ ============
    M        max error    rms error
    ======== ============ ============
    1e4      8.5e-4       1.7e-4
    6.6e4    6.8e-3       1.4e-3
    9.3e4    1.3e-2       2.3e-3
    1.3e5    1.5e-2       2.8e-3
    5.2e5    5.5e-2       1.1e-2
    4.2e6    0.43         8.7e-2
    ======== ============ ============

    (Measured with the reference gradient; the tutorial's, checked here, behaves alike.)
    The error first exceeds 1e-2 at M of about 8e4 (noise coordinates, i.e. world
    coordinates times the frequency: 1.8e5 world units for the turbulence's finest octave,
    8e5 for the bump). The noise collapses when every coordinate is >= 2^23 = 8.4e6: float32
    has no fractional bits left, every point is a lattice point and the noise is exactly 0
    (from 2^22 on, fractions are multiples of 1/2 and the noise is already degenerate).
    """
    rng = np.random.default_rng(12)

    def max_err(m, n=100_000):
        p = rng.uniform(0.5, 1, (3, n)) * rng.choice([-1, 1], (3, n)) * m
        return np.abs(noise32(llvm, p) - perlin64.noise(*p)).max()

    assert max_err(1e4) < 2e-3
    assert max_err(2 ** 16) < 1e-2
    assert max_err(2 ** 16.5) > 1e-2
    assert max_err(2 ** 17) > 1e-2
    p = rng.uniform(2 ** 23, 2 ** 24, (3, 10_000)) * rng.choice([-1, 1], (3, 10_000))
    assert (noise32(llvm, p) == 0).all()
    p = rng.uniform(2 ** 21, 2 ** 22, (3, 10_000))
    assert np.std(noise32(llvm, p)) > 0.1


#: The tutorial's frequencies (per pixel, its world unit); the plugins' defaults are for
#: scenes in units of 100 pixels
TUTORIAL_FREQUENCIES = {"turbulence": {"frequency": 0.05},
                        "marble": {"frequency": 0.05, "stripe_frequency": 0.05}}


@pytest.mark.parametrize("gradient", GRADIENTS)
@pytest.mark.parametrize("kind", ["turbulence", "marble"])
def test_turbulence_and_marble_match_reference(llvm, kind, gradient):
    """Within 1e-4 of the float64 formulas of facts.md F7 for |p_i| <= 1e3 (default colours:
    the texture returns T or m itself), in eval, eval_1 and eval_3, for each gradient."""
    mi = llvm
    rng = np.random.default_rng(21)
    p = (rng.uniform(-1, 1, (3, 200_000)) * 1e3).astype(np.float32)
    reference = getattr(perlin64, kind)(p.astype(np.float64), gradient=gradient)
    texture = mi.load_dict({"type": kind, "gradient": gradient, **TUTORIAL_FREQUENCIES[kind]})
    si = interaction(mi, p)
    for values in (texture.eval_1(si).numpy()[None], texture.eval(si).numpy(),
                   texture.eval_3(si).numpy()):
        assert np.abs(values - reference).max() <= 1e-4


def test_mix_is_unclamped(llvm):
    """c = T color0 + (1 - T) color1 also where T > 1 (extrapolation, even negative)."""
    mi = llvm
    c0, c1 = np.array([0.35, 0.25, 0.01]), np.array([0.5, 0.5, 0.01])
    texture = mi.load_dict({"type": "turbulence", "color0": {"type": "rgb", "value": c0.tolist()},
                            "color1": {"type": "rgb", "value": c1.tolist()},
                            **TUTORIAL_FREQUENCIES["turbulence"]})
    rng = np.random.default_rng(5)
    p = (rng.uniform(-1, 1, (3, 200_000)) * 1e3).astype(np.float32)
    t = perlin64.turbulence(p.astype(np.float64))
    assert (t > 1).sum() > 10
    value = texture.eval(interaction(mi, p)).numpy()
    expected = t * c0[:, None] + (1 - t) * c1[:, None]
    np.testing.assert_allclose(value, expected, atol=1e-4)
    assert value[0][t > 1].max() < c0[0]


def test_frequency_octaves_and_to_world(llvm):
    mi = llvm
    T = mi.ScalarTransform4f
    rng = np.random.default_rng(8)
    p = (rng.uniform(-50, 50, (3, 50_000))).astype(np.float32)
    si = interaction(mi, p)
    to_world = T().translate([3, -2, 1]).rotate([0, 0, 1], 30).scale(2)
    local = np.linalg.inv(np.array(to_world.matrix, dtype=np.float64))
    q = local[:3, :3] @ p.astype(np.float64) + local[:3, 3:]
    perlin = mi.load_dict({"type": "perlin", "frequency": 0.7, "to_world": to_world})
    np.testing.assert_allclose(perlin.eval_1(si).numpy(), perlin64.noise(*(0.7 * q)), atol=2e-5)
    turb = mi.load_dict({"type": "turbulence", "frequency": 0.2, "octaves": 3})
    np.testing.assert_allclose(turb.eval_1(si).numpy(),
                               perlin64.turbulence(p.astype(np.float64), 0.2, 3), atol=2e-5)
    marble = mi.load_dict({"type": "marble", "frequency": 0.05, "stripe_frequency": 0.3,
                           "octaves": 2})
    np.testing.assert_allclose(marble.eval_1(si).numpy(),
                               perlin64.marble(p.astype(np.float64), 0.05, 2, 0.3), atol=2e-5)


@pytest.mark.parametrize("gradient", GRADIENTS)
def test_means(llvm, gradient):
    """mean(): 0 for raw noise, the measured E|noise| of the gradient for turbulence (checked
    here against the reference over the noise's period), 1/2 for marble's m."""
    mi = llvm
    rng = np.random.default_rng(9)
    p = rng.uniform(0, 256, (3, 1_000_000))
    mean_abs = np.abs(perlin64.noise(*p, gradient)).mean()       # +- 1.4e-4 (1 sigma)
    from codermind.textures import _noise
    assert _noise.MEAN_ABS_NOISE[gradient] == pytest.approx(mean_abs, abs=6e-4)
    assert mi.load_dict({"type": "perlin", "gradient": gradient}).mean() == 0
    harmonic = sum(1 / k for k in range(1, 10))
    c0, c1 = 0.8, 0.2
    turb = mi.load_dict({"type": "turbulence", "color0": c0, "color1": c1,
                         "gradient": gradient})
    m = _noise.MEAN_ABS_NOISE[gradient] * harmonic
    assert turb.mean()[0] == pytest.approx(m * c0 + (1 - m) * c1, rel=1e-6)
    marble = mi.load_dict({"type": "marble", "color0": c0, "color1": c1})
    assert marble.mean()[0] == pytest.approx(0.5, rel=1e-6)


def _on_unit_sphere(mi, n: int, seed: int, jitter: float = 0.0):
    """Interactions at ``n`` random points of the unit sphere, each moved by a random step of
    about ``jitter`` and put back on the sphere."""
    import drjit as dr
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(3, n))
    p /= np.linalg.norm(p, axis=0)
    q = p + jitter * rng.normal(size=p.shape) / np.sqrt(3)
    q /= np.linalg.norm(q, axis=0)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.p = mi.Point3f(*q.astype(np.float32))
    return si


@pytest.mark.parametrize("kind", ["turbulence", "marble"])
def test_defaults_vary_over_an_object_of_radius_one(llvm, kind):
    """The default frequencies suit a scene in Mitsuba's usual units: over a sphere of radius
    1 the texture changes by more than 0.05 on average between points about 0.1 apart
    (measured: marble 0.098, turbulence 0.18). At the tutorial's per-pixel frequencies
    the same sphere is nearly uniform (0.009 and 0.019): the control."""
    mi = llvm
    a, b = _on_unit_sphere(mi, 20_000, 3), _on_unit_sphere(mi, 20_000, 3, jitter=0.1)

    def change(texture):
        return np.abs(texture.eval_1(a).numpy() - texture.eval_1(b).numpy()).mean()

    assert change(mi.load_dict({"type": kind})) > 0.05
    assert change(mi.load_dict({"type": kind, **TUTORIAL_FREQUENCIES[kind]})) < 0.025


def test_textures_in_both_bsdfs_from_xml(llvm):
    """Nested in blinnphong (a reflectance, colours in [0, 1]) and in the tutorial
    material, from XML, and rendered with path."""
    mi = llvm
    scene = mi.load_string("""
    <scene version="3.0.0">
      <integrator type="path"><integer name="max_depth" value="3"/></integrator>
      <sensor type="perspective">
        <transform name="to_world"><lookat origin="0,0,0" target="0,0,1" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
      </sensor>
      <emitter type="tutorialpoint"><point name="position" x="0" y="0" z="0"/></emitter>
      <shape type="sphere">
        <point name="center" x="-60" y="0" z="300"/><float name="radius" value="50"/>
        <bsdf type="blinnphong">
          <texture type="marble" name="diffuse_reflectance">
            <rgb name="color0" value="0.5, 0.5, 0.5"/><rgb name="color1" value="0.15, 0.01, 0.15"/>
            <float name="frequency" value="0.05"/><float name="stripe_frequency" value="0.05"/>
          </texture>
        </bsdf>
      </shape>
      <shape type="sphere">
        <point name="center" x="60" y="0" z="300"/><float name="radius" value="50"/>
        <bsdf type="tutorial">
          <texture type="turbulence" name="diffuse">
            <rgb name="color0" value="0.35, 0.25, 0.01"/><rgb name="color1" value="0.5, 0.5, 0.01"/>
            <float name="frequency" value="0.05"/>
          </texture>
          <float name="density" value="1"/>
        </bsdf>
      </shape>
    </scene>""")
    image = mi.render(scene).numpy()
    assert np.isfinite(image).all()
    assert image[:, :8].mean() > 0 and image[:, 8:].mean() > 0


@pytest.mark.parametrize("params, name", [
    ({"type": "perlin", "frequency": 0.0}, "perlin: 'frequency'"),
    ({"type": "turbulence", "frequency": -1.0}, "turbulence: 'frequency'"),
    ({"type": "turbulence", "octaves": 0}, "turbulence: 'octaves'"),
    ({"type": "marble", "octaves": 100}, "marble: 'octaves'"),
    ({"type": "marble", "stripe_frequency": float("inf")}, "marble: 'stripe_frequency'"),
    ({"type": "turbulence", "color0": float("nan")}, "turbulence: 'color0'"),
    ({"type": "perlin", "frequency": 1e39}, "perlin: 'frequency'"),
    ({"type": "marble", "color1": {"type": "rgb", "value": [0.0, float("inf"), 0.0]}},
     "marble: 'color1'"),
    ({"type": "perlin", "gradient": "perlin"},
     "perlin: 'gradient' must be 'tutorial' or 'reference', got 'perlin'"),
    ({"type": "turbulence", "gradient": "Tutorial"}, "turbulence: 'gradient' must be"),
    ({"type": "marble", "gradient": 1.0}, "marble: 'gradient' must be"),
    ({"type": "noisebump", "gradient": "improved", "inner": {"type": "diffuse"}},
     "noisebump: 'gradient' must be 'tutorial' or 'reference'"),
])
def test_bad_parameters(llvm, params, name):
    with pytest.raises(RuntimeError, match=name):
        llvm.load_dict(params)


def test_scalar_variant(scalar):
    mi = scalar
    p = np.array([[123.25], [-45.5], [310.75]])
    si = mi.SurfaceInteraction3f()
    si.p = mi.Point3f(*map(float, p[:, 0]))
    for gradient in GRADIENTS:
        for kind, reference in (("perlin", perlin64.noise(*p, gradient)),
                                ("turbulence", perlin64.turbulence(p, gradient=gradient)),
                                ("marble", perlin64.marble(p, gradient=gradient))):
            texture = mi.load_dict({"type": kind, "gradient": gradient,
                                    **TUTORIAL_FREQUENCIES.get(kind, {})})
            assert texture.eval_1(si) == pytest.approx(float(reference[0]), abs=1e-4)
            assert np.allclose(np.array(texture.eval(si)), float(reference[0]), atol=1e-4)


def test_overflowing_coordinates_give_zero_not_nan(llvm):
    """A finite position times a finite frequency can exceed the float32 range; the noise
    there is 0 (as for every coordinate beyond 2^23), never NaN (found by the perlin_float32
    stability sweep)."""
    mi = llvm
    import drjit as dr
    p = np.array([[1e30, -1e30, 3e38, 1e20], [1.0, 2.0, 3e38, -1e30], [0.25, 1e30, -3e38, 2.0]])
    for spec in ({"type": "perlin", "frequency": 1e10}, {"type": "turbulence", "frequency": 1e10},
                 {"type": "marble", "frequency": 1e10, "stripe_frequency": 1e10}):
        texture = mi.load_dict(spec)
        si = dr.zeros(mi.SurfaceInteraction3f, p.shape[1])
        si.p = mi.Point3f(p.astype(np.float32))
        value = texture.eval_1(si).numpy()
        assert np.isfinite(value).all(), (spec["type"], value)
    # the finest octave's frequency (9 x 1e38) is beyond float32: still 0 x it = 0, not NaN
    texture = mi.load_dict({"type": "turbulence", "frequency": 1e38})
    si = dr.zeros(mi.SurfaceInteraction3f, 2)
    si.p = mi.Point3f([0.0, 1e-30], [0.0, 0.0], [0.0, 0.0])
    assert np.isfinite(texture.eval_1(si).numpy()).all()
    texture = mi.load_dict({"type": "perlin", "frequency": 1e10})
    si = dr.zeros(mi.SurfaceInteraction3f, p.shape[1])
    si.p = mi.Point3f(p.astype(np.float32))
    assert (texture.eval_1(si).numpy() == 0).all()


def test_marble_stays_in_its_colour_range_far_away(llvm):
    """m = sin(phase) / 2 + 1/2 stays in [0, 1] where the float32 sine of the stripe phase
    would not (Dr.Jit's sine leaves [-1, 1] from a phase of about 1.5e7)."""
    mi = llvm
    import drjit as dr
    rng = np.random.default_rng(5)
    texture = mi.load_dict({"type": "marble"})
    for magnitude in (1e8, 1e9, 1e12, 1e30):
        p = rng.uniform(1, 2, (3, 1000)) * magnitude
        si = dr.zeros(mi.SurfaceInteraction3f, p.shape[1])
        si.p = mi.Point3f(p.astype(np.float32))
        m = texture.eval_1(si).numpy()
        assert np.isfinite(m).all() and m.min() >= 0 and m.max() <= 1, magnitude
