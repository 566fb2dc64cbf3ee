"""The `cubemap` environment: lookups against facts.md F12 computed here from the bundled
faces (read with this file's own TGA reader), row order, decodes, light sampling
(chi2, eval = weight * pdf, a lit sphere against built-in `envmap`), the background
mode, bad input."""

from __future__ import annotations

import functools
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from support import zstat
from support import run_cli

FACES = ("up", "down", "right", "left", "forward", "backward")
FILES = dict(zip(FACES, ("alpup.tga", "alpdown.tga", "alpright.tga", "alpleft.tga",
                         "alpforward.tga", "alpback.tga")))


# -- an independent implementation of facts.md F12 (numpy, float64) ---------------------

def read_tga(path: Path) -> np.ndarray:
    """Pixels of an uncompressed 24-bit TGA in STORED order, as B, G, R bytes / 255 turned
    into RGB; the origin bits are ignored, as the tutorial's loader does."""
    data = Path(path).read_bytes()
    assert data[2] == 2 and data[16] == 24
    w, h = data[12] | data[13] << 8, data[14] | data[15] << 8
    start = 18 + data[0]
    pixels = np.frombuffer(data[start:start + w * h * 3], np.uint8).reshape(h, w, 3)
    return pixels[..., ::-1] / 255.0


def write_tga(path: Path, rgb: np.ndarray, top_left: bool = False, footer: bool = True) -> None:
    """Write rows in the given order (stored order), as 24-bit BGR; ``footer``: the
    TGA 2.0 footer (Mitsuba's reader needs it, the tutorial's does not)."""
    h, w = rgb.shape[:2]
    header = bytes([0, 0, 2] + [0] * 9 + [w & 255, w >> 8, h & 255, h >> 8, 24,
                                           0x20 if top_left else 0])
    tail = bytes(8) + b"TRUEVISION-XFILE.\0" if footer else b""
    Path(path).write_bytes(header + np.ascontiguousarray(rgb[..., ::-1], np.uint8).tobytes() + tail)


def spec_uv(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Face index (FACES order), u, v of facts.md F12 for directions d (n, 3)."""
    a, b, c = d.T
    is_x = (abs(a) >= abs(b)) & (abs(a) >= abs(c))
    is_y = ~is_x & (abs(b) >= abs(c))
    is_z = ~is_x & ~is_y
    face, u, v = np.zeros(len(d), int), np.zeros(len(d)), np.zeros(len(d))
    with np.errstate(divide="ignore", invalid="ignore"):
        table = [  # (mask, face, u, v) straight from the table of facts.md F12.2
            (is_x & (a > 0), 2, 1 - (c / a + 1) / 2, (b / a + 1) / 2),
            (is_x & (a <= 0), 3, 1 - (c / a + 1) / 2, 1 - (b / a + 1) / 2),
            (is_y & (b > 0), 0, (a / b + 1) / 2, 1 - (c / b + 1) / 2),
            (is_y & (b <= 0), 1, 1 - (a / b + 1) / 2, (c / b + 1) / 2),
            (is_z & (c > 0), 4, (a / c + 1) / 2, (b / c + 1) / 2),
            (is_z & (c <= 0), 5, (a / c + 1) / 2, 1 - (b / c + 1) / 2),
        ]
    for mask, f, fu, fv in table:
        face[mask], u[mask], v[mask] = f, fu[mask], fv[mask]
    return face, u, v


def spec_lookup(tex: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Raw bilinear texel fetch of §2.11 (before decodes); tex is (6, S, S, 3) with
    texture row v = 0 first."""
    face, u, v = spec_uv(d)
    s = tex.shape[1]

    def split(t):
        x = s * np.abs(t)
        i0 = x.astype(int)
        return np.clip(i0, 0, s - 1), np.clip(i0 + 1, 0, s - 1), (x - i0)[:, None]

    i0, i1, wx = split(u)
    j0, j1, wy = split(v)
    top = tex[face, j0, i0] * (1 - wx) + tex[face, j0, i1] * wx
    bottom = tex[face, j1, i0] * (1 - wx) + tex[face, j1, i1] * wx
    return top * (1 - wy) + bottom * wy


def spec_decode(c, srgb, exposed, exposure):
    if srgb:
        c = c**2.2
    if exposed:
        c = -np.log(1.001 - c)
    return c / exposure


# -- helpers --------------------------------------------------------------------------

def bundled(tutorial_dir: Path, **params) -> dict:
    return {"type": "cubemap", **{k: str(tutorial_dir / "page4" / f) for k, f in FILES.items()},
            **params}


def bundled_texture(tutorial_dir: Path) -> np.ndarray:
    return np.stack([read_tga(tutorial_dir / "page4" / FILES[name]) for name in FACES])


def plugin_lookup(mi, emitter, d: np.ndarray) -> np.ndarray:
    si = mi.SurfaceInteraction3f()
    si.wi = -mi.Vector3f(*np.asarray(d, np.float32).T)
    return np.array(emitter.eval(si)).T.astype(np.float64).reshape(len(d), 3)


def probe_directions(rng) -> np.ndarray:
    """Centres, edge midpoints, corners (ties), points just inside edges, random ones;
    normalized in float32, so the expectation sees exactly the plugin's input."""
    dirs = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            for p in (-1, -0.999, -0.5, 0, 0.37, 0.999, 1):
                for q in (-1, -0.999, -0.25, 0, 0.61, 0.999, 1):
                    d = np.zeros(3)
                    d[axis], d[(axis + 1) % 3], d[(axis + 2) % 3] = sign, p, q
                    dirs.append(d)
    dirs = np.concatenate([np.array(dirs), rng.normal(size=(3000, 3))])
    dirs = dirs.astype(np.float32)
    return (dirs / np.linalg.norm(dirs, axis=1, keepdims=True)).astype(np.float32).astype(np.float64)


# -- lookups ----------------------------------------------------------------------------

def test_lookup_equals_spec_on_bundled_faces(llvm, tutorial_dir):
    mi = llvm
    d = probe_directions(np.random.default_rng(11))
    mine = plugin_lookup(mi, mi.load_dict(bundled(tutorial_dir)), d)
    ref = spec_lookup(bundled_texture(tutorial_dir), d)
    # float32 (u, v) vs float64: 512 * 1e-7 texel of interpolation difference at most.
    assert np.abs(mine - ref).max() < 1e-4
    # The probes hit every face, and the texture varies: a wrong orientation would show.
    assert len(set(spec_uv(d)[0])) == 6 and ref.std() > 0.1


def test_decodes_exposure_and_scale(llvm, tutorial_dir):
    mi = llvm
    d = probe_directions(np.random.default_rng(12))
    raw = plugin_lookup(mi, mi.load_dict(bundled(tutorial_dir)), d)
    decoded = plugin_lookup(mi, mi.load_dict(bundled(
        tutorial_dir, srgb=True, exposed=True, exposure=2.0, scale=3.0)), d)
    assert np.allclose(decoded, 3.0 * spec_decode(raw, True, True, 2.0), rtol=1e-4, atol=1e-6)
    srgb_only = plugin_lookup(mi, mi.load_dict(bundled(tutorial_dir, srgb=True)), d)
    assert np.allclose(srgb_only, raw**2.2, rtol=1e-5, atol=1e-7)


def test_to_world_rotates_the_cube(llvm, tutorial_dir):
    mi = llvm
    rotation = mi.ScalarTransform4f().rotate(list(np.array([0.3, 1, 0.2]) / np.linalg.norm([0.3, 1, 0.2])), 70)
    d = probe_directions(np.random.default_rng(13))[:500]
    r = np.array(rotation.matrix)[:3, :3]
    plain = plugin_lookup(mi, mi.load_dict(bundled(tutorial_dir)), d)
    rotated = plugin_lookup(mi, mi.load_dict(bundled(tutorial_dir, to_world=rotation)), d @ r.T)
    interior = np.sort(np.abs(d), axis=1)
    interior = interior[:, 2] - interior[:, 1] > 1e-3        # away from face seams
    assert np.abs(plain - rotated)[interior].max() < 1e-3


@pytest.mark.parametrize("top_left", [False, True], ids=["bottom-left", "top-left"])
@pytest.mark.parametrize("footer", [True, False], ids=["tga2", "tga1"])
def test_tga_rows_are_read_in_stored_order(llvm, tmp_path, top_left, footer):
    """Texture row v = 0 is the first stored row, whatever the TGA's origin bit says,
    with or without the TGA 2.0 footer."""
    mi = llvm
    stored = (np.arange(16 * 3).reshape(4, 4, 3) * 5).astype(np.uint8)
    write_tga(tmp_path / "face.tga", stored, top_left, footer)
    emitter = mi.load_dict({"type": "cubemap", **{k: str(tmp_path / "face.tga") for k in FACES}})
    # +z face, (u, v) = (1/4, 1/4) and (1/4, 3/4): texels (1, 1) and (1, 3) exactly.
    values = plugin_lookup(mi, emitter, np.array([[-0.5, -0.5, 1.0], [-0.5, 0.5, 1.0]]))
    assert np.allclose(values * 255, stored[[1, 3], 1], atol=1e-3)


def test_other_formats_have_v0_at_the_bottom_row(llvm, tmp_path):
    mi = llvm
    top_down = (np.arange(16 * 3).reshape(4, 4, 3) * 5).astype(np.uint8)
    mi.Bitmap(top_down).write(str(tmp_path / "face.png"))
    emitter = mi.load_dict({"type": "cubemap", **{k: str(tmp_path / "face.png") for k in FACES}})
    values = plugin_lookup(mi, emitter, np.array([[-0.5, -0.5, 1.0]]))   # v row 1
    assert np.allclose(values[0] * 255, top_down[4 - 1 - 1, 1], atol=1e-3)


# -- as a light -------------------------------------------------------------------------

def synthetic_faces(mi, size=6, seed=21):
    """Small random faces, some texels black, a few bright: a lumpy distribution."""
    rng = np.random.default_rng(seed)
    faces = {}
    for name in FACES:
        texels = rng.random((size, size, 3)) ** 3
        texels[rng.random((size, size)) < 0.2] = 0
        faces[name] = mi.Bitmap(texels.astype(np.float32))
    return faces


def test_to_world_through_traverse_equals_the_scene_one(llvm):
    """``to_world`` written through ``mi.traverse`` turns the cube as the same
    ``to_world`` given in the scene does: the same lookups, sampled directions, pdfs and
    weights (to float rounding), so the same renders; a scaling matrix is rejected in one
    line. Evidence [ours]: the constructor's path against the update's."""
    mi = llvm
    rotation = mi.ScalarTransform4f().rotate([2 / 3, 2 / 3, 1 / 3], 33)
    faces = synthetic_faces(mi)
    given = mi.load_dict({"type": "cubemap", **faces, "to_world": rotation})
    updated = mi.load_dict({"type": "cubemap", **faces})
    params = mi.traverse(updated)
    np.testing.assert_allclose(np.array(params["to_world"].matrix)[..., 0], np.eye(4))
    params["to_world"] = mi.Transform4f(rotation.matrix)
    params.update()
    rng = np.random.default_rng(8)
    d = probe_directions(rng)[:500]
    np.testing.assert_allclose(plugin_lookup(mi, updated, d), plugin_lookup(mi, given, d),
                               rtol=1e-5, atol=1e-6)
    it = mi.Interaction3f()
    it.p = mi.Point3f(*rng.normal(size=(3, 1000)))
    sample = mi.Point2f(*rng.random((2, 1000)))
    (ds_u, w_u), (ds_g, w_g) = (e.sample_direction(it, sample) for e in (updated, given))
    np.testing.assert_allclose(np.array(ds_u.d), np.array(ds_g.d), atol=1e-5)
    np.testing.assert_allclose(np.array(ds_u.pdf), np.array(ds_g.pdf), rtol=1e-4)
    np.testing.assert_allclose(np.array(w_u), np.array(w_g), rtol=1e-4, atol=1e-6)
    plain = plugin_lookup(mi, mi.load_dict({"type": "cubemap", **faces}), d)
    assert np.abs(plugin_lookup(mi, updated, d) - plain).max() > 0.05
    params["to_world"] = mi.Transform4f().scale(2.0)
    with pytest.raises(ValueError, match=r"^cubemap: 'to_world' must be a rotation or "
                                         r"reflection \(no scale\)$"):
        params.update()


def test_chi2_light_sampling(llvm):
    mi = llvm
    from mitsuba.chi2 import ChiSquareTest, EmitterAdapter, SphericalDomain
    params = {"type": "cubemap", "srgb": True, **synthetic_faces(mi),
              "to_world": mi.ScalarTransform4f().rotate([2 / 3, 2 / 3, 1 / 3], 33)}
    sample, pdf = EmitterAdapter("cubemap", params)
    test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf,
                         sample_dim=2, ires=16, seed=3)
    assert test.run(), test.messages


def test_sampled_weight_times_pdf_is_radiance(llvm, tutorial_dir):
    mi = llvm
    emitter = mi.load_dict(bundled(tutorial_dir, srgb=True, exposed=True,
                                   to_world=mi.ScalarTransform4f().rotate([0, 1, 0], 40)))
    rng = np.random.default_rng(5)
    n = 4000
    it = mi.Interaction3f()
    it.p = mi.Point3f(*rng.normal(size=(3, n)))
    ds, weight = emitter.sample_direction(it, mi.Point2f(*rng.random((2, n))))
    pdf = np.array(ds.pdf)
    assert np.all(pdf > 0)
    assert np.allclose(np.array(emitter.pdf_direction(it, ds)), pdf, rtol=1e-4)
    radiance = np.array(emitter.eval_direction(it, ds))
    assert np.allclose(np.array(weight) * pdf, radiance, rtol=1e-4, atol=1e-6)
    # The shadow-ray target lies beyond the default scene sphere (radius 1e5).
    assert np.all(np.array(ds.dist) >= 2e5)


def latlong_from_spec(tex: np.ndarray, decode: dict, width: int) -> np.ndarray:
    """The cube-map radiance of facts.md F12 at the texel centres of a lat-long map in the layout
    of built-in `envmap` (row 0: +y; d = (sin phi sin theta, cos theta, -cos phi sin theta))."""
    h = width // 2
    v, u = (np.mgrid[0:h, 0:width] + 0.5) / np.array([h, width])[:, None, None]
    theta, phi = v * np.pi, u * 2 * np.pi
    d = np.stack([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)], -1)
    rgb = spec_decode(spec_lookup(tex, d.reshape(-1, 3)), **decode)
    return rgb.reshape(h, width, 3).astype(np.float32)


@functools.lru_cache(maxsize=1)
def bundled_latlong(tutorial_dir: Path) -> np.ndarray:
    """The page-4 sky (srgb and exposed decodes) as a 2048 x 1024 lat-long map."""
    decode = {"srgb": True, "exposed": True, "exposure": 1.0}
    return latlong_from_spec(bundled_texture(tutorial_dir), decode, 2048)


def lit_sphere(mi, emitter: dict, integrator: dict | None = None) -> object:
    """A white diffuse sphere filling the frame, direct lighting only (path, depth 2)."""
    return mi.load_dict({
        "type": "scene",
        "integrator": integrator or {"type": "moment", "path": {"type": "path", "max_depth": 2}},
        "sensor": {"type": "perspective", "fov": 20.0,
                   "to_world": mi.ScalarTransform4f().look_at([0.5, 1.0, -3.6], [0, 0, 0], [0, 1, 0]),
                   "sampler": {"type": "independent"},
                   "film": {"type": "hdrfilm", "width": 24, "height": 24, "rfilter": {"type": "box"}}},
        "ball": {"type": "sphere", "bsdf": {"type": "diffuse", "reflectance": 0.8}},
        "env": emitter})


def test_lights_a_sphere_like_builtin_envmap(llvm, tutorial_dir):
    """The same radiance as a 2048 x 1024 lat-long map sampled from the cube map of facts.md F12:
    the two differ only by the lat-long's bilinear resampling, far below the noise of
    the irradiance (a smooth integral of the radiance)."""
    mi = llvm
    ref = lit_sphere(mi, {"type": "envmap", "bitmap": mi.Bitmap(bundled_latlong(tutorial_dir))})
    mine = lit_sphere(mi, bundled(tutorial_dir, srgb=True, exposed=True))
    ref_moments = zstat.render_moments(mi, ref, 256, seed=1)
    result = zstat.two_sample(ref_moments, zstat.render_moments(mi, mine, 256, seed=2))
    assert result.passed, str(result)
    # Power: the cube turned by 90 degrees is rejected.
    turned = lit_sphere(mi, bundled(tutorial_dir, srgb=True, exposed=True,
                                    to_world=mi.ScalarTransform4f().rotate([0, 1, 0], 90)))
    assert not zstat.two_sample(ref_moments, zstat.render_moments(mi, turned, 256, seed=3)).passed


def test_light_tracing_matches_builtin_envmap(llvm, tutorial_dir):
    """sample_ray (rays from the scene's bounding sphere, given by attach_scene) through
    the particle tracer: the sphere's mean brightness as with envmap's sample_ray."""
    mi = llvm
    from codermind.scene import attach_emitters
    means = []
    for env in ({"type": "envmap", "bitmap": mi.Bitmap(bundled_latlong(tutorial_dir))},
                bundled(tutorial_dir, srgb=True, exposed=True)):
        scene = lit_sphere(mi, env, {"type": "ptracer", "max_depth": 2})
        attach_emitters(scene)
        means.append(np.array(mi.render(scene, spp=1024, seed=4)).mean(axis=(0, 1)))
    assert means[0].min() > 0.3
    assert np.allclose(means[1], means[0], rtol=0.02)


# -- background mode ----------------------------------------------------------------------

def test_background_mode_is_seen_but_never_sampled(llvm, tutorial_dir):
    mi = llvm
    emitter = mi.load_dict(bundled(tutorial_dir, mode="background"))
    assert emitter.sampling_weight() == 0.0
    it = mi.Interaction3f()
    ds, weight = emitter.sample_direction(it, mi.Point2f(0.3, 0.7))
    assert np.all(np.array(ds.pdf) == 0) and np.all(np.array(weight) == 0)
    ds.d = mi.Vector3f(0, 0, 1)
    assert np.all(np.array(emitter.pdf_direction(it, ds)) == 0)
    # A scene with a point light: the light is always the one sampled; the camera sees
    # the cube map (forward face centre straight ahead).
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "direct", "bsdf_samples": 0},
        "sensor": {"type": "perspective", "fov": 0.01,
                   "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}}},
        "light": {"type": "point", "position": [0, 5, 0], "intensity": 1.0},
        "env": bundled(tutorial_dir, mode="background")})
    pixel = np.array(mi.render(scene, spp=4)).ravel()
    centre = plugin_lookup(mi, emitter, np.array([[0.0, 0.0, 1.0]]))[0]
    assert np.allclose(pixel, centre, rtol=2e-3)
    index, weight, _ = scene.sample_emitter(mi.Float(np.linspace(0, 0.999, 50)))
    assert np.all(np.array(index) == 0) and np.allclose(np.array(weight), 1.0)


# -- files, errors, scene bounds -------------------------------------------------------------

def test_relative_face_names_resolve_next_to_the_scene(llvm, tutorial_dir, tmp_path):
    mi = llvm
    for f in FILES.values():
        shutil.copy(tutorial_dir / "page4" / f, tmp_path / f)
    faces = "".join(f'<string name="{k}" value="{f}"/>' for k, f in FILES.items())
    (tmp_path / "scene.xml").write_text(
        f'<scene version="3.0.0"><emitter type="cubemap">{faces}</emitter>'
        '<shape type="sphere"><float name="radius" value="7"/></shape></scene>')
    from codermind.scene import load_scene
    scene = load_scene(tmp_path / "scene.xml")
    emitter = scene.environment()
    assert emitter.names[0] == str(tmp_path / "alpup.tga")
    # load_scene hands the scene's bounding sphere to the emitter.
    assert float(emitter.bsphere_radius[0]) == pytest.approx(7 * math.sqrt(3), rel=1e-3)


def faces_dict(folder: Path, **override) -> dict:
    return {"type": "cubemap", **{k: str(folder / f) for k, f in FILES.items()}, **override}


@pytest.mark.parametrize("case, needle", [
    ("missing-parameter", "'backward'"),
    ("missing-file", "face 'left': file"),
    ("unreadable", "face 'down': cannot read"),
    ("size", "face 'forward'"),
    ("exposure", "'exposure'"),
    ("mode", "'mode'"),
    ("scale", "'scale'"),
    ("infinite-exposure", "'exposure'"),
])
def test_bad_input_gives_one_clear_error(llvm, tutorial_dir, tmp_path, case, needle):
    mi = llvm
    params = faces_dict(tutorial_dir / "page4")
    if case == "missing-parameter":
        del params["backward"]
    elif case == "missing-file":
        params["left"] = str(tmp_path / "nothere.tga")
    elif case == "unreadable":
        (tmp_path / "garbage.tga").write_bytes(b"not an image at all")
        params["down"] = str(tmp_path / "garbage.tga")
    elif case == "size":
        write_tga(tmp_path / "small.tga", np.zeros((8, 8, 3), np.uint8))
        params["forward"] = str(tmp_path / "small.tga")
    elif case == "exposure":
        params["exposure"] = 0.0
    elif case == "scale":
        params["scale"] = float("nan")
    elif case == "infinite-exposure":
        params["exposure"] = float("inf")
    else:
        params["mode"] = "sky"
    with pytest.raises(RuntimeError) as e:
        mi.load_dict(params)
    last = str(e.value).strip().splitlines()[-1]
    assert needle in last, last


def test_cli_names_a_missing_face_in_one_line(tmp_path):
    faces = "".join(f'<string name="{k}" value="{f}"/>' for k, f in FILES.items())
    (tmp_path / "scene.xml").write_text(
        f'<scene version="3.0.0">\n<emitter type="cubemap">{faces}</emitter>\n</scene>\n')
    result = run_cli("render", tmp_path / "scene.xml", "-o", tmp_path / "out")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "face 'up': file 'alpup.tga' not found" in lines[0], result.stderr


@pytest.mark.parametrize("exposure", [1e38, 1e-30])
def test_sampling_is_finite_for_very_dim_or_bright_maps(llvm, exposure):
    """The sampling weights are relative: a map divided by 1e38 (radiance near the float32
    minimum) gave an all-zero distribution and NaN samples (found by the property tests)."""
    mi = llvm
    import drjit as dr
    emitter = mi.load_dict({"type": "cubemap", "exposure": exposure, **synthetic_faces(mi)})
    n = 1000
    rng = np.random.default_rng(2)
    it = dr.zeros(mi.Interaction3f, n)
    ds, weight = emitter.sample_direction(it, mi.Point2f(rng.random((2, n))))
    assert np.isfinite(ds.d.numpy()).all() and np.isfinite(ds.p.numpy()).all()
    assert np.isfinite(weight.numpy()).all() and (ds.pdf.numpy() > 0).mean() > 0.5
    # the sampled directions follow the same distribution as at exposure 1
    plain = mi.load_dict({"type": "cubemap", **synthetic_faces(mi)})
    ds1, _ = plain.sample_direction(it, mi.Point2f(rng.random((2, n))))
    assert np.allclose(ds.pdf.numpy(), plain.pdf_direction(it, ds).numpy(), rtol=1e-4)


def test_an_odd_value_is_quoted_on_the_error_line(llvm, tutorial_dir):
    """A value with a line break is echoed escaped, so the one-line error still names the
    parameter (found by the long property run)."""
    params = faces_dict(tutorial_dir / "page4", mode="sky\nlight")
    with pytest.raises(RuntimeError) as e:
        llvm.load_dict(params)
    last = str(e.value).strip().splitlines()[-1]
    assert "'mode' must be 'light' or 'background', got 'sky\\nlight'" in last, last


@pytest.mark.parametrize("variant", ["llvm", "scalar"])
def test_a_non_finite_direction_looks_up_nothing(request, variant):
    """A direction with a NaN or inf component (a NaN shading normal upstream) gets no
    radiance and pdf 0 in both variants; in scalar_rgb its texel index was int(NaN), a
    ValueError that stopped the render (found by benchmarks/random_scenes.py)."""
    mi = request.getfixturevalue(variant)
    import drjit as dr
    emitter = mi.load_dict({"type": "cubemap", **synthetic_faces(mi)})
    jit = dr.is_jit_v(mi.Float)
    for d in ([float("nan"), 0.0, 0.0], [float("inf"), 1.0, 0.0], [0.0, float("nan"), 1.0],
              [float("-inf"), float("inf"), 0.0]):
        si = dr.zeros(mi.SurfaceInteraction3f) if jit else mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*d)
        it = dr.zeros(mi.Interaction3f) if jit else mi.Interaction3f()
        ds = dr.zeros(mi.DirectionSample3f) if jit else mi.DirectionSample3f()
        ds.d = mi.Vector3f(*d)
        for value in (emitter.eval(si), emitter.eval_direction(it, ds),
                      mi.Color3f(emitter.pdf_direction(it, ds))):
            assert np.array(value, dtype=np.float64).ravel().tolist() == [0.0, 0.0, 0.0], d
