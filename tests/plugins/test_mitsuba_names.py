"""Mitsuba's names and behaviour (issue 15): the noise textures inside the built-in
``bumpmap`` (their ``eval_1_grad`` against the closed form of Perlin's gradient at lattice
points), the projective integrators with ``conic``, ``perlin``'s scale/offset, the blob's
``centers``. ``aperture_radius`` on ``conic`` against the built-in ``thinlens`` is checked in
test_conic.py, beside the disc lens's ``aperture``."""

from __future__ import annotations

import numpy as np
import pytest

from test_blob_plugin import R, PAGE4, blob_dict, mesh_arrays


def _camera_common(mi):
    return {"fov": 40.0, "focus_distance": 3.0, "near_clip": 0.1, "far_clip": 50.0,
            "to_world": mi.ScalarTransform4f().look_at([0, 1, -4], [0, 0, 0], [0, 1, 0]),
            "film": {"type": "hdrfilm", "width": 32, "height": 24}}


@pytest.mark.parametrize("extra", [{"aperture": 0.1}, {"lens": "tutorial"}])
def test_conic_aperture_radius_is_for_the_disc_lens_only(llvm, extra):
    mi = llvm
    with pytest.raises(RuntimeError, match="conic: 'aperture_radius' .* cannot be combined"):
        mi.load_dict({"type": "conic", "aperture_radius": 0.2, **extra,
                      **_camera_common(mi)})


def _bump_scene(mi, texture):
    return {"type": "scene", "integrator": {"type": "path", "max_depth": 3},
            "sensor": {"type": "perspective", "fov": 40, "to_world": mi.ScalarTransform4f()
                       .look_at([0, 0, 4], [0, 0, 0], [0, 1, 0]),
                       "film": {"type": "hdrfilm", "width": 16, "height": 16}},
            "light": {"type": "point", "position": [2, 2, 3], "intensity": 10.0},
            "ball": {"type": "sphere", "bsdf": {"type": "bumpmap", "texture": texture,
                                                "bsdf": {"type": "diffuse"}}}}


@pytest.mark.parametrize("kind", ["perlin", "turbulence", "marble"])
def test_noise_textures_work_in_builtin_bumpmap(llvm, kind):
    """Before eval_1_grad existed this raised 'tried to call a pure virtual function' and
    the next render in the process failed too: render with the bump, then without."""
    mi = llvm
    texture = {"type": kind, "frequency": 3.0}
    bumped = np.array(mi.render(mi.load_dict(_bump_scene(mi, texture)), spp=2, seed=0))
    no_bump = _bump_scene(mi, texture)
    no_bump["ball"] = {"type": "sphere", "bsdf": {"type": "diffuse"}}
    flat = np.array(mi.render(mi.load_dict(no_bump), spp=2, seed=0))
    assert np.isfinite(bumped).all() and np.isfinite(flat).all()
    assert np.abs(bumped - flat).max() > 1e-2        # the bump changes the shading
    plain = mi.load_dict({**_bump_scene(mi, texture), "ball": {"type": "sphere"}})
    assert np.isfinite(np.array(mi.render(plain, spp=1))).all()


def test_perlin_gradient_at_lattice_points_is_a_perlin_edge_vector(llvm):
    """Closed form: at an integer point Perlin's improved noise is locally g . (p - corner)
    (the fade has zero slope there), so its gradient is that corner's gradient vector,
    one of the 12 cube-edge directions: two components +-1, one 0."""
    import drjit as dr
    mi = llvm
    rng = np.random.default_rng(2)
    pts = rng.integers(-50, 50, (3, 200)).astype(np.float64)
    tex = mi.load_dict({"type": "perlin"})
    si = dr.zeros(mi.SurfaceInteraction3f, pts.shape[1])
    si.p = mi.Point3f(pts)
    si.dp_du, si.dp_dv = mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0)
    gxy = np.array(tex.eval_1_grad(si))
    si.dp_du = mi.Vector3f(0, 0, 1)
    gz = np.array(tex.eval_1_grad(si))[0]
    g = np.stack([gxy[0], gxy[1], gz])
    assert np.abs(np.sort(np.abs(g), axis=0) - np.array([[0], [1], [1]])).max() < 2e-3


def test_solid_texture_gradient_follows_to_world_and_frequency(llvm):
    """Chain rule: w(x) = noise(f M^-1 x) has gradient f M^-T grad noise; with M a scale
    by 2 and f = 3 the gradient at x is 1.5 times the unplaced texture's at 1.5 x."""
    import drjit as dr
    mi = llvm
    placed = mi.load_dict({"type": "perlin", "frequency": 3.0,
                           "to_world": mi.ScalarTransform4f().scale(2.0)})
    plain = mi.load_dict({"type": "perlin"})
    rng = np.random.default_rng(3)
    x = rng.uniform(-5, 5, (3, 100))

    def grad(tex, p):
        si = dr.zeros(mi.SurfaceInteraction3f, p.shape[1])
        si.p = mi.Point3f(p)
        si.dp_du, si.dp_dv = mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0)
        return np.array(tex.eval_1_grad(si))

    assert np.allclose(grad(placed, x), 1.5 * grad(plain, 1.5 * x), atol=5e-3)


@pytest.mark.parametrize("integrator", ["direct_projective", "prb_projective"])
def test_projective_integrators_stop_with_one_line_for_conic(llvm, integrator):
    import drjit as dr
    mi = llvm
    d = _bump_scene(mi, {"type": "perlin"})
    d["sensor"]["type"] = "conic"
    d["ball"] = {"type": "sphere", "bsdf": {"type": "diffuse"}}
    d["integrator"] = {"type": integrator}
    scene = mi.load_dict(d)
    params = mi.traverse(scene)
    key = "ball.to_world"       # a geometric parameter: the projective part runs
    dr.enable_grad(params[key])
    params.update()
    with pytest.raises(RuntimeError) as error:
        image = mi.render(scene, params, spp=1)
        dr.backward(image)
    # drjit.custom wraps the plugin's error: ours is the cause, in one line
    chain, e = [], error.value
    while e is not None:
        chain.append(str(e))
        e = e.__cause__ or e.__context__
    assert any(m.startswith("conic: the projective integrators") and "\n" not in m
               for m in chain), chain
    d["integrator"] = {"type": "path"}
    assert np.isfinite(np.array(mi.render(mi.load_dict(d), spp=1))).all()


def test_perlin_scale_and_offset(llvm):
    import drjit as dr
    mi = llvm
    raw = mi.load_dict({"type": "perlin", "frequency": 0.7})
    mapped = mi.load_dict({"type": "perlin", "frequency": 0.7, "scale": 0.5, "offset": 0.5})
    si = dr.zeros(mi.SurfaceInteraction3f, 1000)
    si.p = mi.Point3f(np.random.default_rng(1).uniform(-20, 20, (3, 1000)))
    a, b = np.array(raw.eval_1(si)), np.array(mapped.eval_1(si))
    assert np.allclose(b, 0.5 * a + 0.5, atol=1e-6)
    assert a.min() < 0 and b.min() >= 0         # the remap keeps a reflectance >= 0
    assert mapped.mean() == 0.5


def test_blob_centers_array_equals_numbered_centres(llvm):
    mi = llvm
    text = "  ".join(" ".join(str(x) for x in c) for c in PAGE4)
    numbered = mesh_arrays(mi.load_dict(blob_dict(mi, PAGE4, max_error=R / 50)))
    array = mesh_arrays(mi.load_dict({"type": "blob", "radius": R, "max_error": R / 50,
                                      "centers": text.replace("  ", ", ")}))
    assert np.array_equal(numbered[0], array[0]) and np.array_equal(numbered[1], array[1])


@pytest.mark.parametrize("extra,message", [
    ({"centers": "1 2"}, "blob: 'centers' must hold 3 numbers per centre, got 2"),
    ({"centers": "1 2 x"}, "blob: 'centers' must be 3N numbers"),
    ({"centers": "1 2 3", "center0": [0, 0, 0]}, "blob: give either 'centers' or"),
])
def test_blob_centers_errors(llvm, extra, message):
    mi = llvm
    with pytest.raises(RuntimeError, match=message):
        mi.load_dict({"type": "blob", "radius": 1.0, **extra})
