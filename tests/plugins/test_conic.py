"""The `conic` thin-lens camera: the disc lens against built-in `thinlens`, blur sizes
against the thin-lens formula, the tutorial lens against the construction of facts.md F5,
the pinhole case, the fixed sub-sample grid of §2.2, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from support import zstat
from support import run_cli

W, H = 64, 48                        # a small "tutorial" image


def tutorial_camera(mi, lens="tutorial", fov=30.0, focus=400.0, aperture=40.0, k=1,
                    pixel_offset=None, w=W, h=H, **extra):
    """The tutorial's page-4 camera for a W x H image, on a k-times film."""
    d = {"type": "conic", "lens": lens, "fov": fov, "focus_distance": focus,
         "aperture": aperture, "near_clip": 0.0, "far_clip": 2000.0,
         "to_world": mi.ScalarTransform4f().translate([w / 2, h / 2, 0]).scale([-1, 1, 1]),
         "film": {"type": "hdrfilm", "width": k * w, "height": k * h,
                  "rfilter": {"type": "box"}}, **extra}
    if pixel_offset is not None:
        d["pixel_offset_x"], d["pixel_offset_y"] = pixel_offset
    return d


def spec_ray(fx, fy, u1, u2, fov, focus, aperture, w=W, h=H):
    """facts.md F3/§2.4 in float64: origin and direction of the page-4 ray of sub-sample
    (fx, fy) with DOF draws (u1, u2)."""
    pd = (w / 2) / math.tan(math.radians(fov) / 2)
    o = np.array([w / 2, h / 2, 0.0])
    d0 = np.stack([(fx - w / 2) / pd, (fy - h / 2) / pd, np.ones_like(fx)], -1)
    d0 /= np.linalg.norm(d0, axis=-1, keepdims=True)
    focus_point = o + focus * d0
    origin = o + aperture * np.stack([u1, u2, np.zeros_like(u1)], -1)
    d = focus_point - origin
    return origin, d / np.linalg.norm(d, axis=-1, keepdims=True)


def rays(mi, sensor, s2, s3):
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(*s2), mi.Point2f(*s3))
    return np.array(ray.o).T, np.array(ray.d).T, np.array(ray.maxt)


def test_tutorial_lens_rays_follow_the_spec_construction(llvm):
    mi = llvm
    rng = np.random.default_rng(1)
    n = 2000
    s2, s3 = rng.random((2, n)), rng.random((2, n))
    sensor = mi.load_dict(tutorial_camera(mi, fov=90.0, focus=450.0, aperture=10.0))
    o, d, maxt = rays(mi, sensor, s2, s3)
    # Film position (x right, rows down) -> tutorial coordinates (y up).
    o_ref, d_ref = spec_ray(s2[0] * W, (1 - s2[1]) * H, s3[0], s3[1], 90.0, 450.0, 10.0)
    assert np.abs(o - o_ref).max() < 1e-4
    assert np.abs(d - d_ref).max() < 2e-6
    assert np.allclose(maxt, 2000.0)


def test_tutorial_probe_rays(llvm):
    """The auto-exposure probes of facts.md F6: un-jittered rays (sample3 = 0) through
    pixel corners (i s, j s), s = max(W, H)/16, some above the image (y > H)."""
    mi = llvm
    sensor = mi.load_dict(tutorial_camera(mi, fov=90.0, focus=450.0, aperture=10.0))
    i, j = np.mgrid[0:16, 0:16].reshape(2, -1).astype(np.float64) * (max(W, H) / 16)
    o, d, _ = rays(mi, sensor, (i / W, 1 - j / H), np.zeros((2, i.size)))
    o_ref, d_ref = spec_ray(i, j, 0 * i, 0 * i, 90.0, 450.0, 0.0)
    assert (j > H).any()
    assert np.abs(o - o_ref).max() < 1e-5 and np.abs(d - d_ref).max() < 2e-6


def test_tutorial_grid_with_fixed_pixel_offset(llvm):
    """A 2W x 2H film with pixel_offset (0, 1): film pixel (c, r) is the tutorial's
    sub-sample (c/2, (2H-1-r)/2), whatever the jitter inside the film pixel."""
    mi = llvm
    sensor = mi.load_dict(tutorial_camera(mi, aperture=0.0, k=2, pixel_offset=(0.0, 1.0)))
    r, c = np.mgrid[0:2 * H, 0:2 * W].reshape(2, -1).astype(np.float64)
    jitter = np.random.default_rng(2).uniform(0.01, 0.99, (2, c.size))
    s2 = ((c + jitter[0]) / (2 * W), (r + jitter[1]) / (2 * H))
    o, d, _ = rays(mi, sensor, s2, np.full((2, c.size), 0.5))
    o_ref, d_ref = spec_ray(c / 2, (2 * H - 1 - r) / 2, 0 * c, 0 * c, 30.0, 400.0, 0.0)
    assert np.abs(o - o_ref).max() < 1e-5
    assert np.abs(d - d_ref).max() < 2e-6


@pytest.mark.parametrize("lens", ["disc", "tutorial"])
def test_zero_aperture_is_the_builtin_pinhole(llvm, lens):
    mi = llvm
    to_world = mi.ScalarTransform4f().look_at([1, 2, 3], [0, 0.5, 0], [0, 1, 0])
    film = {"type": "hdrfilm", "width": 40, "height": 30}
    pinhole = mi.load_dict({"type": "perspective", "fov": 50.0, "fov_axis": "y",
                            "to_world": to_world, "film": film})
    conic = mi.load_dict({"type": "conic", "lens": lens, "fov": 50.0, "fov_axis": "y",
                          "focus_distance": 3.0, "to_world": to_world, "film": film})
    assert not conic.needs_aperture_sample()
    rng = np.random.default_rng(3)
    s2 = rng.random((2, 500))
    o_ref, d_ref, _ = rays(mi, pinhole, s2, rng.random((2, 500)))
    o, d, _ = rays(mi, conic, s2, rng.random((2, 500)))
    assert np.abs(d - d_ref).max() < 1e-6
    if lens == "tutorial":      # clipped along the ray, not at the near plane
        eye = np.array([1.0, 2.0, 3.0])
        o_ref = eye + 0.01 * d_ref
    assert np.abs(o - o_ref).max() < 1e-6


@pytest.mark.parametrize("name", ["aperture", "aperture_radius"])
def test_disc_lens_matches_builtin_thinlens_rays(llvm, name):
    """External reference: the built-in thinlens with the same radius, given as the disc
    lens's ``aperture`` or as thinlens's own name ``aperture_radius``."""
    mi = llvm
    common = {"fov": 40.0, "focus_distance": 3.0, "near_clip": 0.1, "far_clip": 50.0,
              "to_world": mi.ScalarTransform4f().look_at([0, 1, -4], [0, 0, 0], [0, 1, 0]),
              "film": {"type": "hdrfilm", "width": 32, "height": 24}}
    thinlens = mi.load_dict({"type": "thinlens", "aperture_radius": 0.2, **common})
    conic = mi.load_dict({"type": "conic", name: 0.2, **common})
    rng = np.random.default_rng(4)
    s2, s3 = rng.random((2, 1000)), rng.random((2, 1000))
    ref, mine = rays(mi, thinlens, s2, s3), rays(mi, conic, s2, s3)
    assert np.abs(mine[0] - ref[0]).max() < 1e-5
    assert np.abs(mine[1] - ref[1]).max() < 1e-6
    assert np.allclose(mine[2], ref[2], rtol=1e-5)
    if name == "aperture_radius":
        assert float(mi.traverse(conic)["aperture_radius"][0]) == pytest.approx(0.2)


def dof_scene(mi, sensor):
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "moment", "direct": {"type": "direct"}},
        "sensor": sensor,
        "light": {"type": "constant", "radiance": 1.0},
        "floor": {"type": "rectangle",
                  "to_world": mi.ScalarTransform4f().translate([0, -0.5, 3]).rotate([1, 0, 0], -80).scale(4),
                  "bsdf": {"type": "diffuse", "reflectance": {
                      "type": "checkerboard", "to_uv": mi.ScalarTransform4f().scale(8)}}},
        "ball": {"type": "sphere", "center": [0.4, 0.0, 1.5], "radius": 0.3,
                 "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.9, 0.3, 0.1]}}},
    })


def test_disc_lens_renders_like_builtin_thinlens(llvm):
    """Per-pixel two-sample z-test (moment integrator, Sidak alpha 0.01 over all pixels)."""
    mi = llvm
    common = {"fov": 45.0, "focus_distance": 3.0,
              "to_world": mi.ScalarTransform4f().look_at([0, 0.3, -0.5], [0, 0, 3], [0, 1, 0]),
              "sampler": {"type": "independent"},
              "film": {"type": "hdrfilm", "width": 40, "height": 30, "rfilter": {"type": "box"}}}
    ref = dof_scene(mi, {"type": "thinlens", "aperture_radius": 0.08, **common})
    mine = dof_scene(mi, {"type": "conic", "aperture": 0.08, **common})
    result = zstat.two_sample(zstat.render_moments(mi, ref, 64, seed=1),
                              zstat.render_moments(mi, mine, 64, seed=2))
    assert result.passed, str(result)
    # The test has power: a lens twice as wide is rejected.
    wide = dof_scene(mi, {"type": "conic", "aperture": 0.16, **common})
    assert not zstat.two_sample(zstat.render_moments(mi, ref, 64, seed=1),
                                zstat.render_moments(mi, wide, 64, seed=3)).passed


def blur_moments(mi, sensor, depth, radius, spp=256):
    """Centroid and per-axis second moments (film pixels, x right, y down) of the image
    of a small emitting disc facing the camera on the optical axis at ``depth``."""
    to_world = (mi.ScalarTransform4f().translate([W / 2, H / 2, depth])
                .rotate([1, 0, 0], 180).scale(radius))
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "direct"}, "sensor": sensor,
        "dot": {"type": "disk", "to_world": to_world,
                "emitter": {"type": "area", "radiance": 1.0}}})
    img = np.array(mi.render(scene, spp=spp, seed=5))[..., 0].astype(np.float64)
    y, x = np.mgrid[0:img.shape[0], 0:img.shape[1]] + 0.5
    total = img.sum()
    cx, cy = (img * x).sum() / total, (img * y).sum() / total
    # + 1/12: the spread of a uniform distribution over one pixel, lost by binning.
    mx = (img * (x - cx) ** 2).sum() / total + 1 / 12
    my = (img * (y - cy) ** 2).sum() / total + 1 / 12
    return cx, cy, mx, my


@pytest.mark.parametrize("lens", ["disc", "tutorial"])
def test_blur_of_a_point_matches_the_thin_lens_formula(llvm, lens):
    """A point at depth z images as the aperture scaled by A |1/z - 1/F| PD on the image
    (PD: image-plane distance in pixels): a disc of that radius (second moment r^2/4
    per axis) or a square of that side (s^2/12 per axis) whose corner is the sharp
    image point, extending left and down for a point nearer than the focus. A small
    disc is that point's blur convolved with its sharp image: second moments add."""
    mi = llvm
    fov, focus, depth, aperture, radius = 30.0, 400.0, 200.0, 40.0, 5.0
    sensor = tutorial_camera(mi, lens=lens, fov=fov, focus=focus, aperture=aperture)
    cx, cy, mx, my = blur_moments(mi, sensor, depth, radius)
    pd = (W / 2) / math.tan(math.radians(fov / 2))
    blur = aperture * abs(1 / depth - 1 / focus) * pd
    dot_m2 = (radius * pd / depth) ** 2 / 4               # sharp image: a uniform disc
    if lens == "disc":
        expect_m2, shift = blur**2 / 4, 0.0
    else:
        expect_m2, shift = blur**2 / 12, blur / 2
    assert blur > 10                                       # a real blur, many pixels
    for m2 in (mx, my):
        assert math.sqrt(m2 - dot_m2) == pytest.approx(math.sqrt(expect_m2), rel=0.02)
    assert cx == pytest.approx(W / 2 - shift, abs=0.3)
    assert cy == pytest.approx(H / 2 + shift, abs=0.3)


@pytest.mark.parametrize("params, needle", [
    ({"fov": 0.0}, "'fov'"),
    ({"fov": 180.0}, "'fov'"),
    ({"fov": 190.0}, "'fov'"),
    ({"aperture": -1.0}, "'aperture'"),
    ({"focus_distance": -2.0}, "'focus_distance'"),
    ({"aperture": 1.0, "focus_distance": 0.0}, "'focus_distance'"),
    ({"lens": "fisheye"}, "'lens'"),
    ({"near_clip": -1.0}, "'near_clip'"),
    ({"pixel_offset_x": 0.5}, "'pixel_offset_y'"),
    ({"pixel_offset_x": 0.5, "pixel_offset_y": 1.5}, "'pixel_offset_y'"),
    ({"fov_axis": "z"}, "'fov_axis'"),
    ({"aperture": float("inf")}, "'aperture'"),
    ({"fov": "wide"}, "'fov' must be a number"),
    ({"aperture": True}, "'aperture' must be a number"),
    ({"aperture": 1e39}, "'aperture'"),
    ({"aperture": 1.0, "focus_distance": float("inf")}, "'focus_distance'"),
    ({"aperture": 1.0, "far_clip": float("inf")}, "'focus_distance' must be finite"),
])
def test_bad_parameters_give_one_clear_error(llvm, params, needle):
    mi = llvm
    with pytest.raises(RuntimeError) as e:
        mi.load_dict({"type": "conic", "fov": 45.0, **params})
    assert needle in str(e.value).strip().splitlines()[-1]


@pytest.mark.parametrize("lens", ["disc", "tutorial"])
@pytest.mark.parametrize("params", [{"far_clip": float("inf")}, {"far_clip": 1e30},
                                    {"aperture": 1e30, "focus_distance": 10.0},
                                    {"aperture": 1e-3, "focus_distance": 1e30},
                                    {"aperture": 1e19, "focus_distance": 1.0},
                                    {"aperture": 1e19, "focus_distance": 1e-19,
                                     "near_clip": 1.0, "far_clip": float("inf")}])
def test_extreme_distances_give_finite_unit_rays(llvm, lens, params):
    """A pinhole whose focus distance defaults to an infinite or huge far_clip, and huge
    apertures or focus distances, used to give NaN or zero directions (float32 overflow of
    the focus or aperture point; found by the thin_lens stability sweep); a ray nearly
    parallel to the lens met the near plane beyond float32 (found by the long property run)."""
    mi = llvm
    camera = mi.load_dict({"type": "conic", "lens": lens, "fov": 60.0, **params})
    rng = np.random.default_rng(2)
    s3 = rng.random((2, 100))
    s3[:, 0] = 0.5                  # the disc's centre
    ray, _ = camera.sample_ray(0.0, 0.5, mi.Point2f(rng.random((2, 100))), mi.Point2f(s3))
    o, d = ray.o.numpy(), ray.d.numpy()
    assert np.isfinite(o).all() and np.isfinite(d).all()
    assert (ray.maxt.numpy() >= 0).all()
    np.testing.assert_allclose(np.linalg.norm(d, axis=0), 1.0, rtol=1e-5)


def test_scaled_to_world_is_rejected(llvm):
    mi = llvm
    with pytest.raises(RuntimeError, match="'to_world' must be a rotation"):
        mi.load_dict({"type": "conic", "to_world": mi.ScalarTransform4f().scale(2)})


def test_cli_reports_a_bad_fov_in_one_line(tmp_path):
    scene = tmp_path / "bad.xml"
    scene.write_text('<scene version="3.0.0">\n  <sensor type="conic">\n'
                     '    <float name="fov" value="190"/>\n  </sensor>\n</scene>\n')
    result = run_cli("render", scene, "-o", tmp_path / "out")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "bad.xml (line 2" in lines[0] and "'fov' must be in (0, 180)" in lines[0]
    assert "Traceback" not in lines[0]
