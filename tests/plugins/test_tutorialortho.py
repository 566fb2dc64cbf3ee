"""The `tutorialortho` camera: the built-in orthographic camera's rays, and the tutorial's
page-1 rays and page-2 sub-sample grid (facts.md F1.2, F3) through a full render."""

from __future__ import annotations

import numpy as np
import pytest

W, H = 64, 48


def tutorial_ortho(mi, k=1, sampler=None, w=W, h=H):
    """Pages 1/2: pixel (x, y) fires from (x, y, -1000) along +z, t < 2000; k x film."""
    return {"type": "tutorialortho", "near_clip": 0.0, "far_clip": 2000.0,
            "pixel_offset_x": 0.0, "pixel_offset_y": 1.0,
            "to_world": mi.ScalarTransform4f().translate([w / 2, h / 2, -1000]).scale([-w / 2, w / 2, 1]),
            "sampler": sampler or {"type": "stratified", "sample_count": 1, "jitter": False},
            "film": {"type": "hdrfilm", "width": k * w, "height": k * h, "pixel_format": "rgb",
                     "rfilter": {"type": "box"}}}


def test_rays_equal_builtin_orthographic(llvm):
    mi = llvm
    common = {"to_world": mi.ScalarTransform4f().look_at([1, 2, 3], [0, 0, 0], [0, 1, 0]).scale([2, 2, 1]),
              "near_clip": 0.5, "far_clip": 30.0, "film": {"type": "hdrfilm", "width": 40, "height": 30}}
    ref = mi.load_dict({"type": "orthographic", **common})
    mine = mi.load_dict({"type": "tutorialortho", **common})
    rng = np.random.default_rng(7)
    s2 = mi.Point2f(*rng.random((2, 1000)))
    a, _ = ref.sample_ray_differential(0.0, 0.5, s2, mi.Point2f(0.5))
    b, _ = mine.sample_ray_differential(0.0, 0.5, s2, mi.Point2f(0.5))
    for field in ("o", "d", "o_x", "o_y", "d_x", "d_y"):
        assert np.abs(np.array(getattr(a, field)) - np.array(getattr(b, field))).max() < 1e-5, field
    assert np.allclose(np.array(a.maxt), np.array(b.maxt))


def hit_positions(mi, sensor, size=W):
    """World position each film pixel's ray hits on the plane z = 0 (aov integrator).
    The plane is only as large as needed: its hit points are computed in its local frame
    and scaled, which costs float precision."""
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "aov", "aovs": "p:position"}, "sensor": sensor,
        "plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate(
            [size / 2, size / 2, 0]).scale(size / 2 + 1)}})
    return np.array(mi.render(scene, seed=0))[..., -3:]


@pytest.mark.parametrize("k", [1, 2], ids=["page1", "page2-grid"])
def test_rays_start_at_the_tutorial_positions(llvm, k):
    """k=1: film pixel (c, r) is tutorial pixel (c, H-1-r); k=2: film pixel (c, r) is
    sub-sample (c/2, (2H-1-r)/2), i.e. (x + {0, 1/2}, y + {0, 1/2})."""
    mi = llvm
    pos = hit_positions(mi, tutorial_ortho(mi, k))
    r, c = np.mgrid[0:k * H, 0:k * W]
    assert np.abs(pos[..., 0] - c / k).max() < 1e-4
    assert np.abs(pos[..., 1] - (k * H - 1 - r) / k).max() < 1e-4
    assert np.all(pos[..., 2] == 0)


def test_random_jitter_rarely_moves_a_sample_to_the_neighbour_point(llvm):
    """With a jittering sampler a pixel is ambiguous when pixel + jitter rounds to the
    next integer in float32: measured about 5e-5 of the samples on a 1280 x 960 film."""
    mi = llvm
    sensor = tutorial_ortho(mi, 2, sampler={"type": "independent", "sample_count": 1},
                            w=640, h=480)
    pos = hit_positions(mi, sensor, 640)
    r, c = np.mgrid[0:960, 0:1280]
    off = np.maximum(np.abs(pos[..., 0] - c / 2), np.abs(pos[..., 1] - (959 - r) / 2))
    moved = off > 1e-3
    assert moved.mean() < 2e-4
    assert np.all(off[moved] < 0.5 + 1e-3)       # only ever to a neighbour's point


def test_ray_range_is_the_tutorial_t_range(llvm):
    mi = llvm
    sensor = mi.load_dict(tutorial_ortho(mi))
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(0.3, 0.6), mi.Point2f(0.5))
    assert np.array(ray.o)[2] == -1000.0
    assert np.allclose(np.array(ray.d).ravel(), [0, 0, 1])
    assert np.array(ray.maxt) == 2000.0


@pytest.mark.parametrize("params, needle", [
    ({"near_clip": 5.0, "far_clip": 1.0}, "'near_clip'"),
    ({"pixel_offset_y": 2.0, "pixel_offset_x": 0.0}, "'pixel_offset_y'"),
    ({"pixel_offset_y": 0.0}, "'pixel_offset_x'"),
    ({"near_clip": "near"}, "'near_clip' must be a number"),
    ({"pixel_offset_x": 0.0, "pixel_offset_y": "0"}, "'pixel_offset_y' must be a number"),
])
def test_bad_parameters_give_one_clear_error(llvm, params, needle):
    with pytest.raises(RuntimeError) as e:
        llvm.load_dict({"type": "tutorialortho", **params})
    assert needle in str(e.value).strip().splitlines()[-1]
