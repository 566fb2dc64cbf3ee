"""The `tutorialpoint` light: with falloff it is built-in `point`; without, a Lambert
sphere's pixels follow the tutorial's closed form (facts.md F7) at any light distance."""

from __future__ import annotations

import numpy as np
import pytest

W, H = 48, 40
CENTRE, RADIUS = np.array([24.0, 20.0, 100.0]), 15.0


def scene_with(mi, light: dict, integrator: dict | None = None) -> object:
    """A diffuse sphere and a glossy one seen by a pinhole, lit by ``light``."""
    return mi.load_dict({
        "type": "scene",
        "integrator": integrator or {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 40.0,
                   "to_world": mi.ScalarTransform4f().look_at([0, 1, -5], [0, 0, 0], [0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 32, "height": 24}},
        "a": {"type": "sphere", "center": [-0.6, 0, 0], "radius": 0.5,
              "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.5, 0.3]}}},
        "b": {"type": "sphere", "center": [0.6, 0, 0.3], "radius": 0.5,
              "bsdf": {"type": "roughplastic", "alpha": 0.2}},
        "floor": {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate(
            [0, -0.5, 0]).rotate([1, 0, 0], -90).scale(4)},
        "light": light})


def test_with_falloff_equals_builtin_point(llvm):
    mi = llvm
    common = {"position": [1.0, 3.0, -2.0], "intensity": {"type": "rgb", "value": [25.0, 20.0, 15.0]}}
    ref = np.array(mi.render(scene_with(mi, {"type": "point", **common}), spp=16, seed=3))
    mine = np.array(mi.render(scene_with(mi, {"type": "tutorialpoint", "falloff": True, **common}),
                              spp=16, seed=3))
    assert ref.max() > 0.1
    assert np.allclose(mine, ref, rtol=1e-5, atol=1e-7)



def test_particle_tracer_with_falloff_equals_builtin_point(llvm):
    """[built-in] The particle tracer starts light paths with sample_ray and connects them
    with sample_position's record: every field of that record must be set (it failed with
    "ad_call(): callable returned an empty/uninitialized Dr.Jit array" before)."""
    mi = llvm
    common = {"position": [1.0, 3.0, -2.0], "intensity": {"type": "rgb", "value": [25.0, 20.0, 15.0]}}
    tracer = {"type": "ptracer", "max_depth": 3}
    ref = np.array(mi.render(scene_with(mi, {"type": "point", **common}, tracer), spp=64, seed=5))
    mine = np.array(mi.render(scene_with(mi, {"type": "tutorialpoint", "falloff": True, **common},
                                         tracer), spp=64, seed=5))
    assert ref.mean() > 0.01
    assert abs(mine.mean() / ref.mean() - 1) < 0.02

def lambert_image(mi, light_position, intensity, albedo):
    """Orthographic view of a diffuse sphere: one ray through the centre of each pixel,
    direct lighting from the light alone (deterministic)."""
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": {"type": "tutorialortho", "pixel_offset_x": 0.5, "pixel_offset_y": 0.5,
                   "near_clip": 0.0, "far_clip": 2000.0,
                   "to_world": mi.ScalarTransform4f().translate([W / 2, H / 2, -1000]).scale([-W / 2, W / 2, 1]),
                   "film": {"type": "hdrfilm", "width": W, "height": H, "pixel_format": "rgb",
                            "rfilter": {"type": "box"}}},
        "ball": {"type": "sphere", "center": CENTRE.tolist(), "radius": RADIUS,
                 "bsdf": {"type": "diffuse", "reflectance": albedo}},
        "light": {"type": "tutorialpoint", "position": list(light_position), "intensity": intensity}})
    return np.array(mi.render(scene, spp=1), dtype=np.float64)[..., 0]


@pytest.mark.parametrize("light", [[60.0, 50.0, 40.0], [600.0, 500.0, -500.0]],
                         ids=["near", "far"])
def test_without_falloff_lambert_sphere_is_the_closed_form(llvm, light):
    """Radiance = I * albedo / pi * max(n . l, 0) with no distance term. (The tutorial's
    Lambert term is I * Diffuse * (n . l): a `diffuse` BSDF of reflectance Diffuse needs
    intensity pi * I to give it.)"""
    mi = llvm
    intensity, albedo = 3.0, 0.6
    img = lambert_image(mi, light, intensity, albedo)
    # Expected, from the geometry: ray from (x + 1/2, y + 1/2, -1000) along +z, y up.
    rows, cols = np.mgrid[0:H, 0:W]
    x, y = cols + 0.5, H - rows - 0.5
    dx, dy = x - CENTRE[0], y - CENTRE[1]
    hit = dx**2 + dy**2 < RADIUS**2
    p = np.stack([x, y, CENTRE[2] - np.sqrt(np.maximum(RADIUS**2 - dx**2 - dy**2, 0))], -1)
    n = (p - CENTRE) / RADIUS
    l_vec = np.array(light) - p
    cos = np.maximum((n * l_vec).sum(-1) / np.linalg.norm(l_vec, axis=-1), 0)
    expected = np.where(hit, intensity * albedo / np.pi * cos, 0.0)
    # Skip the silhouette, where float rounding decides hit or miss.
    inner = np.abs(np.sqrt(dx**2 + dy**2) - RADIUS) > 0.05
    assert expected.max() > 0.3 and (expected[inner & hit] == 0).any()
    # atol: float32 cosines near grazing angles (absolute error ~1e-6 of n . l).
    assert np.allclose(img[inner], expected[inner], rtol=1e-4, atol=1e-5)


def test_position_and_to_world_are_exclusive(llvm):
    with pytest.raises(RuntimeError, match="only one of 'position' and 'to_world'"):
        llvm.load_dict({"type": "tutorialpoint", "position": [0, 0, 0],
                        "to_world": llvm.ScalarTransform4f().translate([1, 2, 3])})


@pytest.mark.parametrize("params, name", [
    ({"intensity": float("nan")}, "intensity"),
    ({"intensity": {"type": "rgb", "value": [1.0, float("inf"), 1.0]}}, "intensity"),
    ({"position": [0.0, float("nan"), 0.0]}, "position"),
])
def test_non_finite_parameters_are_refused(llvm, params, name):
    with pytest.raises(RuntimeError, match=f"tutorialpoint: '{name}' must be finite"):
        llvm.load_dict({"type": "tutorialpoint", **params})


@pytest.mark.parametrize("variant", ["llvm", "scalar"])
def test_sample_ray_weight_is_four_pi_intensity(variant, request):
    """Light tracing from the light: direction uniform over the sphere, weight 4 pi I (the
    built-in point's at unit distance). It raised AttributeError (a Mitsuba function that
    Python does not have; found by the property tests)."""
    mi = request.getfixturevalue(variant)
    emitter = mi.load_dict({"type": "tutorialpoint", "position": [1.0, 2.0, 3.0],
                            "intensity": {"type": "rgb", "value": [0.5, 1.0, 2.0]}})
    ray, weight = emitter.sample_ray(0.0, 0.3, mi.Point2f(0.5, 0.5), mi.Point2f(0.25, 0.75))
    np.testing.assert_allclose(np.array(weight).ravel(), 4 * np.pi * np.array([0.5, 1.0, 2.0]),
                               rtol=1e-6)
    np.testing.assert_allclose(np.array(ray.o).ravel(), [1, 2, 3])
    assert abs(np.linalg.norm(np.array(ray.d).ravel()) - 1) < 1e-6
