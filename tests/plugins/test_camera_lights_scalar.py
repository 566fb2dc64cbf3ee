"""conic, tutorialortho, cubemap and tutorialpoint load and render in scalar_rgb, and give
the image llvm_ad_rgb gives (the scenes are deterministic: fixed pixel positions, a
delta light sampled once, no BSDF sampling)."""

from __future__ import annotations

import numpy as np
import pytest

FACES = ("up", "down", "right", "left", "forward", "backward")


def scene_dict(mi, sensor: str, mode: str) -> dict:
    rng = np.random.default_rng(8)
    faces = {name: mi.Bitmap(rng.random((4, 4, 3)).astype(np.float32)) for name in FACES}
    film = {"type": "hdrfilm", "width": 12, "height": 9, "pixel_format": "rgb",
            "rfilter": {"type": "box"}}
    if sensor == "conic":
        camera = {"type": "conic", "lens": "tutorial", "fov": 60.0, "focus_distance": 10.0,
                  "pixel_offset_x": 0.0, "pixel_offset_y": 1.0, "film": film,
                  "to_world": mi.ScalarTransform4f().translate([0, 0, -4]).scale([-1, 1, 1])}
    else:
        camera = {"type": "tutorialortho", "near_clip": 0.0, "pixel_offset_x": 0.5,
                  "pixel_offset_y": 0.5, "film": film,
                  "to_world": mi.ScalarTransform4f().translate([0, 0, -4]).scale([-2, 2, 1])}
    return {
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": camera,
        "ball": {"type": "sphere", "radius": 1.0, "bsdf": {"type": "diffuse"}},
        "light": {"type": "tutorialpoint", "position": [2.0, 3.0, -3.0], "intensity": 2.0},
        "env": {"type": "cubemap", "mode": mode, "srgb": True, **faces},
    }


def render(variant: str, sensor: str, mode: str) -> np.ndarray:
    import mitsuba as mi
    mi.set_variant(variant)
    import codermind  # noqa: F401
    scene = mi.load_dict(scene_dict(mi, sensor, mode))
    spp = 1 if mode == "background" else 64
    return np.array(mi.render(scene, spp=spp, seed=0), dtype=np.float64)


@pytest.mark.parametrize("sensor, mode", [("conic", "background"), ("tutorialortho", "light")])
def test_scalar_rgb_renders_like_llvm(sensor, mode):
    try:
        scalar = render("scalar_rgb", sensor, mode)
        llvm = render("llvm_ad_rgb", sensor, mode)
    finally:
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
    assert scalar.shape == (9, 12, 3) and scalar.max() > 0.05
    if mode == "light":
        # Light sampling uses each variant's own random numbers: compare the means.
        assert scalar.mean() == pytest.approx(llvm.mean(), rel=0.05)
    else:
        assert np.allclose(scalar, llvm, rtol=1e-4, atol=1e-6)
