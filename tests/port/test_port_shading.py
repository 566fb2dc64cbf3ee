"""Unit checks of the port's page-4 shading pieces against the formulas of facts.md F7-F10."""

from __future__ import annotations

import math

import numpy as np
import pytest

import codermind_ref as ref
from codermind_ref import materials, perlin, transport
from codermind_ref.world import World
from support.port_scenes import write_scene


def test_fresnel_normal_incidence_brewster_and_total_internal_reflection():
    one, glass = np.array([1.0]), np.array([1.5])
    r, cos_t = transport.fresnel(one, glass, np.array([1.0]))
    assert r[0] == pytest.approx(0.04) and cos_t[0] == 1.0
    brewster = math.atan(1.5)                      # p-polarised reflectance vanishes
    r, cos_t = transport.fresnel(one, glass, np.array([math.cos(brewster)]))
    rs = ((1.5 * cos_t[0] - math.cos(brewster)) / (1.5 * cos_t[0] + math.cos(brewster))) ** 2
    assert r[0] == pytest.approx(0.5 * rs, rel=1e-12)
    assert cos_t[0] == pytest.approx(math.cos(math.asin(math.sin(brewster) / 1.5)), rel=1e-12)
    r, cos_t = transport.fresnel(glass, one, np.array([0.5]))   # sinT = 1.5 * 0.866 > 1
    assert r[0] == 1.0 and cos_t[0] == 0.0
    r, _ = transport.fresnel(one, one, np.linspace(0.1, 1, 7))  # Density 1: R = 0 everywhere
    assert np.all(r < 1e-30)                                    # up to cosT rounding


def _table(tmp_path, material: str):
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Perspective.Type = conic;\nNumberOfMaterials = 1;\n",
        f"Material0 {{ {material} }}\n"))
    return materials.MaterialTable(scene)


def test_turbulence_and_marble_colours(tmp_path):
    rng = np.random.default_rng(2)
    p = rng.uniform(-300, 300, (3, 50))
    t = sum((1 / k) * np.abs(perlin.noise(0.05 * k * p[0], 0.05 * k * p[1], 0.05 * k * p[2]))
            for k in range(1, 10))
    d1, d2 = np.array([0.35, 0.25, 0.01]), np.array([0.5, 0.5, 0.01])
    keys = "Diffuse = 0.35, 0.25, 0.01; Diffuse2 = 0.5, 0.5, 0.01;"
    turb = _table(tmp_path, "Type = turbulence; " + keys).colour(np.zeros(50, int), p)
    assert np.allclose(turb, t * d1[:, None] + (1 - t) * d2[:, None], rtol=1e-13)
    m = 0.5 * np.sin(0.05 * (p[0] + p[1]) + t) + 0.5
    marble = _table(tmp_path, "Type = marble; " + keys).colour(np.zeros(50, int), p)
    assert np.allclose(marble, m * d1[:, None] + (1 - m) * d2[:, None], rtol=1e-13)
    noise = _table(tmp_path, "Type = noise; " + keys)       # parsed, shaded as gouraud
    assert np.array_equal(noise.colour(np.zeros(50, int), p), np.repeat(d1[:, None], 50, 1))


def test_bump_rotates_the_noise_coordinates():
    n = np.array([[0.0], [0.0], [-1.0]])
    p = np.array([[12.3], [-45.6], [78.9]])
    b = 0.1
    x, y, z = 0.1 * p[:, 0]
    g = np.array([perlin.noise(x, y, z), perlin.noise(y, z, x), perlin.noise(z, x, y)])
    expected = (1 - b) * n[:, 0] + b * g
    got = materials.bump(n, p, np.array([b]))[:, 0]
    assert np.allclose(got, expected / np.linalg.norm(expected), rtol=1e-14)


def test_shadow_rays_stop_at_the_light_in_clean_and_at_its_square_in_strict(tmp_path):
    # a point at the origin, a light at distance 10 along +x, an occluder at distance 50
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.1", "NumberOfMaterials = 1;\nNumberOfSpheres = 1;\nNumberOfLights = 1;\n",
        "Material0 { Diffuse = 1; }\nSphere0 { Center = 50, 0, 0; Size = 5; }\n"
        "Light0 { Position = 10, 0, 0; Intensity = 1; }\n"))
    world = World(scene, np.float64)
    o, d = np.zeros((3, 1)), np.array([[1.0], [0.0], [0.0]])
    assert world.occluded(o, d, np.array([100.0]))[0]        # strict: |L|^2 = 100
    assert not world.occluded(o, d, np.array([10.0]))[0]     # clean: |L| = 10


def test_two_spheres_at_the_same_distance_go_to_the_first_unless_ties_last(tmp_path):
    """Mirror-image spheres about x = 0: a ray in that plane meets both at exactly the same
    t (the same float operations on +-3). The original keeps the sphere listed first (a later
    one wins only if strictly closer); ``ties="last"`` takes the other; off the plane the
    nearer sphere wins under both rules."""
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.1", "NumberOfMaterials = 1;\nNumberOfSpheres = 2;\nNumberOfLights = 1;\n",
        "Material0 { Diffuse = 1; }\nSphere0 { Center = -3, 0, 50; Size = 5; }\n"
        "Sphere1 { Center = 3, 0, 50; Size = 5; }\nLight0 { Position = 0, 0, 0; Intensity = 1; }\n"))
    o = np.array([[0.0, -0.5, 0.5], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], dtype=np.float32)
    d = np.array([[0.0] * 3, [0.0] * 3, [1.0] * 3], dtype=np.float32)
    far = np.full(3, 1000.0, dtype=np.float32)
    t_first, first = World(scene, np.float32).intersect(o, d, far)
    t_last, last = World(scene, np.float32, ties="last").intersect(o, d, far)
    assert t_first[0] == t_last[0] == np.float32(50 - 4)        # sqrt(5^2 - 3^2) = 4
    assert first.tolist() == [0, 0, 1] and last.tolist() == [1, 0, 1]
    with pytest.raises(ValueError, match="ties"):
        World(scene, np.float32, ties="nearest")


def test_refraction_at_near_normal_incidence_keeps_its_length_only_in_strict():
    """facts.md F8: cosI >= 0.999 forces cosT = 1, so (n1/n2)(d + cosI n) - n has length
    sqrt(1 + (n1/n2)^2 sin^2 I), not 1, and the original's next intersection takes it as unit
    (the tutorial's blob code: A = 1.0f). Strict keeps that length; clean normalizes. Elsewhere
    Snell's law makes it unit in both."""
    n = np.array([[0.0], [0.0], [-1.0]])
    for cos_i, ratio in ((0.9995, 2.0), (0.9995, 0.5), (0.8, 0.5)):
        sin_i = math.sqrt(1 - cos_i ** 2)
        d = np.array([[sin_i], [0.0], [cos_i]])
        forced = cos_i >= 0.999
        cos_t = 1.0 if forced else math.sqrt(1 - (ratio * sin_i) ** 2)
        args = (d, n, np.array([cos_i]), np.array([cos_t]), np.array([ratio]))
        strict = transport.refracted(*args, ref.STRICT)[:, 0]
        clean = transport.refracted(*args, ref.CLEAN)[:, 0]
        expected = math.sqrt(1 + (ratio * sin_i) ** 2) if forced else 1.0
        assert np.linalg.norm(strict) == pytest.approx(expected, rel=1e-12)
        assert np.linalg.norm(clean) == pytest.approx(1.0, rel=1e-12)
        assert np.allclose(clean, strict / np.linalg.norm(strict), rtol=1e-12)
