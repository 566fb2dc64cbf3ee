"""The ``blob`` shape in Mitsuba: loading (XML, dict), parameters, to_world, errors, ray hits
against an independent exact solver, the silhouette of a sphere, scalar_rgb."""

from __future__ import annotations

import numpy as np
import pytest

from support import blob_reference as ref

R = 80.0
PAGE4 = np.array([(160, 290, 320), (400, 290, 480), (250, 140, 400)], float)


def blob_dict(mi, centers, **extra):
    d = {"type": "blob", "radius": R}
    for i, c in enumerate(centers):
        d[f"center{i}"] = mi.ScalarPoint3f(*map(float, c))
    d.update(extra)
    return d


def mesh_arrays(mesh):
    import drjit as dr
    params = __import__("mitsuba").traverse(mesh)
    v = np.array(dr.unravel(__import__("mitsuba").Point3f, params["vertex_positions"])).T
    f = np.array(params["faces"]).reshape(-1, 3)
    return v.astype(np.float64), f


def test_load_from_xml(llvm):
    mi = llvm
    scene = mi.load_string("""
        <scene version="3.0.0">
            <shape type="blob" id="glass">
                <point name="center0" x="160" y="290" z="320"/>
                <point name="center1" x="400" y="290" z="480"/>
                <point name="center2" x="250" y="140" z="400"/>
                <float name="radius" value="80"/>
                <float name="max_error" value="0.5"/>
                <string name="field" value="tutorial"/>
                <bsdf type="dielectric"/>
            </shape>
        </scene>""")
    (shape,) = scene.shapes()
    assert shape.id() == "glass"
    assert "Dielectric" in str(shape.bsdf())
    bbox = shape.bbox()
    # the blob reaches past each source's sphere of radius R
    assert bbox.min.x < 160 - R and bbox.max.x > 400 + R - 1


def test_load_dict_with_to_world(llvm):
    mi = llvm
    centers = np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0]])
    plain = mi.load_dict(blob_dict(mi, centers, max_error=0.2, field="exact"))
    moved = mi.load_dict(blob_dict(
        mi, centers, max_error=0.4, field="exact",
        to_world=mi.ScalarTransform4f().translate([5, 6, 7]).scale(2.0)))
    v0, _ = mesh_arrays(plain)
    v1, f1 = mesh_arrays(moved)
    # a uniform scale of 2 with max_error 0.4 is the same object-space mesh
    assert v1.shape == v0.shape
    assert np.abs(v1 - (2 * v0 + [5, 6, 7])).max() < 1e-3
    # still outward after the transform
    n = np.cross(v1[f1[:, 1]] - v1[f1[:, 0]], v1[f1[:, 2]] - v1[f1[:, 0]])
    assert np.einsum("ij,ij->i", n, v1[f1].mean(1) - [105, 6, 7]).sum() > 0


def test_mirror_to_world_keeps_faces_outward(llvm):
    mi = llvm
    m = mi.load_dict(blob_dict(mi, [[0, 0, 0]], max_error=1.0, field="exact",
                               to_world=mi.ScalarTransform4f().scale([-1, 1, 1])))
    v, f = mesh_arrays(m)
    vol = np.einsum("ij,ij->i", np.cross(v[f[:, 0]], v[f[:, 1]]), v[f[:, 2]]).sum() / 6
    assert vol > 0


def test_vertex_normals_are_kept(llvm):
    mi = llvm
    import drjit as dr
    m = mi.load_dict(blob_dict(mi, PAGE4, max_error=1.0))
    params = mi.traverse(m)
    v, _ = mesh_arrays(m)
    n = np.array(dr.unravel(mi.Normal3f, params["vertex_normals"])).T
    g = -ref.exact_gradient(v, PAGE4, R)
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", n, g).min() > 0.9999
    flat = mi.load_dict(blob_dict(mi, PAGE4, max_error=1.0, normals="flat"))
    assert not flat.has_vertex_normals()


@pytest.mark.parametrize("extra, message", [
    ({"radius": -1.0}, "'radius'"),
    ({"field": "smooth"}, "'field'"),
    ({"normals": "bent"}, "'normals'"),
    ({"max_error": 0.0}, "'max_error'"),
])
def test_bad_parameters_are_named(llvm, extra, message):
    mi = llvm
    with pytest.raises(Exception, match=message):
        mi.load_dict(blob_dict(mi, [[0, 0, 0]], **extra))


def test_bad_centres_are_named(llvm):
    mi = llvm
    with pytest.raises(Exception, match="no source centre"):
        mi.load_dict({"type": "blob", "radius": 1.0})
    with pytest.raises(Exception, match="'center1' is missing"):
        mi.load_dict({"type": "blob", "radius": 1.0, "center0": mi.ScalarPoint3f(0, 0, 0),
                      "center2": mi.ScalarPoint3f(1, 0, 0)})
    with pytest.raises(Exception, match="'center1' must be finite"):
        mi.load_dict(blob_dict(mi, [[0, 0, 0], [1, float("nan"), 0]]))
    with pytest.raises(Exception, match="unreferenced property"):
        mi.load_dict(blob_dict(mi, [[0, 0, 0]], radiuss=2.0))


def _one_line(text: str, start: str) -> str:
    """The one line of ``text`` (a Mitsuba error, which wraps the plugin's traceback) that
    holds the ValueError starting with ``start``."""
    lines = [ln for ln in str(text).splitlines() if start in ln]
    assert len(lines) == 1, text
    return lines[0][lines[0].index(start):]


def test_runaway_max_error_is_refused_promptly(llvm):
    """max_error 1e-7 on the page-4 blob (the mesher alone, stopped by its 5 M cap, takes
    131 s, 6.3 M triangles and 3.4 GB there, and misses max_error) is refused before
    meshing, within 3 s, in one line that names 'max_error', the cost and the limit. The
    max_error it names for a smaller limit loads with about that many triangles. The same
    refusal through mi.traverse, which leaves the blob as it was."""
    import re
    import time
    mi = llvm
    t0 = time.perf_counter()
    with pytest.raises(RuntimeError) as error:
        mi.load_dict(blob_dict(mi, PAGE4, max_error=1e-7))
    seconds = time.perf_counter() - t0
    line = _one_line(error.value, "blob: 'max_error'")
    print(f"{seconds:.2f} s: {line}")           # shown with pytest -s
    assert seconds < 3.0
    assert re.search(r"about \S+e\+1\d triangles, .* TB of memory", line)
    assert "'max_triangles' 2e+06" in line
    # the max_error it names for a limit of 20 000 loads, with about that many triangles
    with pytest.raises(RuntimeError) as error:
        mi.load_dict(blob_dict(mi, PAGE4, max_error=1e-7, max_triangles=20000))
    line = _one_line(error.value, "blob: 'max_error'")
    fits = float(re.search(r"raise max_error to (\S+) or more", line).group(1))
    scene = mi.load_dict({"type": "scene", "blob": blob_dict(mi, PAGE4, max_error=fits,
                                                             max_triangles=20000)})
    (blob,) = scene.shapes()
    faces = blob.face_count()
    assert 20000 / 1.25 < faces < 20000 * 1.25

    params = mi.traverse(scene)
    params["blob.max_error"] = mi.Float(1e-7)
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match=r"^blob: 'max_error' 1e-07 would need [^\n]*$"):
        params.update()
    assert time.perf_counter() - t0 < 3.0
    assert blob.face_count() == faces and blob.max_error == float(np.float32(fits))


def test_max_triangles_lets_a_larger_mesh_through(llvm):
    """A mesh the estimate puts at about 40 000 triangles is refused under max_triangles
    20 000 and built under 80 000 (with that many triangles, within the estimate's
    accuracy); max_triangles itself must be a number >= 1."""
    from codermind.blobmesh import estimate_cost
    mi = llvm
    centers = PAGE4 + np.array([[0.0, 30.0, 0.0], [0, 0, 0], [0, 0, 0]])
    e = 0.15 * estimate_cost(centers, R, "tutorial", 0.15).triangles / 40000
    with pytest.raises(RuntimeError) as error:
        mi.load_dict(blob_dict(mi, centers, max_error=e, max_triangles=20000))
    assert "'max_triangles' 2e+04" in _one_line(error.value, "blob: 'max_error'")
    blob = mi.load_dict(blob_dict(mi, centers, max_error=e, max_triangles=80000))
    assert 40000 / 1.25 < blob.face_count() < 40000 * 1.25
    assert blob.max_triangles == 80000
    for bad in (0.5, float("nan"), -1.0):
        with pytest.raises(RuntimeError) as error:
            mi.load_dict(blob_dict(mi, centers, max_triangles=bad))
        _one_line(error.value, "blob: 'max_triangles' must be finite in float32 and >= 1")


@pytest.mark.parametrize("key,value", [
    ("radius", float("nan")), ("radius", float("inf")), ("radius", 0.0), ("radius", -1.0),
    ("max_error", float("nan")), ("max_error", float("inf")), ("max_error", -0.1),
    ("max_error", 0.0)])
def test_absurd_values_are_refused_in_one_line(llvm, key, value):
    """Non-finite or non-positive radius and max_error: one line naming the parameter, when
    loading and through mi.traverse."""
    mi = llvm
    message = f"blob: '{key}' must be finite in float32 and > 0, got {value:g}"
    with pytest.raises(RuntimeError) as error:
        mi.load_dict(blob_dict(mi, [[0, 0, 0]], **{key: value}))
    assert _one_line(error.value, f"blob: '{key}'") == message
    scene = mi.load_dict({"type": "scene", "blob": blob_dict(mi, [[0, 0, 0]], max_error=2.0)})
    params = mi.traverse(scene)
    params[f"blob.{key}"] = mi.Float(value)
    with pytest.raises(ValueError, match=f"^{message}$"):
        params.update()


def exact_normal(p, centers, kind):
    """Outward unit normal of the true surface at p (zone field: one-sided at creases)."""
    if kind == "exact":
        g = -ref.exact_gradient(p, centers, R)
    else:
        d = p[:, None, :] - centers[None]
        x = (d ** 2).sum(-1) / R**2
        k = np.clip(np.searchsorted(ref.SPEC_X, x, side="right"), 1, len(ref.SPEC_X) - 1)
        slope = (ref.SPEC_F[k] - ref.SPEC_F[k - 1]) / (ref.SPEC_X[k] - ref.SPEC_X[k - 1])
        slope = np.where(x >= 10, 0.0, slope)
        g = -(slope[..., None] * d).sum(1)
    return g / np.linalg.norm(g, axis=1, keepdims=True)


@pytest.mark.parametrize("kind", ["tutorial", "exact"])
def test_ray_hits_agree_with_an_exact_solver(llvm, kind):
    """Rays at the mesh against rays at the true surface (zone method / polynomial roots),
    aimed at surface points, half of them at 1 to 6 degrees from the tangent plane.
    What is compared, with e = max_error:
    * every hit point on the mesh lies within e of the true surface, and every true hit
      point within e of the mesh (so a ray may miss one and hit the other only where it
      grazes both within e);
    * where both are hit and the ray meets the true surface at more than ~17 degrees from
      its tangent plane, the two hits are within e of each other measured along the
      surface normal: |t_mesh - t_true| |d . n| <= e (along the ray the distance grows
      without bound as the ray turns tangent, so it is not compared there)."""
    mi = llvm
    e = 0.15
    scene = mi.load_dict({"type": "scene", "blob": blob_dict(mi, PAGE4, max_error=e, field=kind)})
    v, f = mesh_arrays(scene.shapes()[0])
    rng = np.random.default_rng(7)
    targets = ref.surface_samples(PAGE4, R, kind, 500, rng)[:800]
    n_t = exact_normal(targets, PAGE4, kind)
    # random directions at the surface, half of them grazing (1 to 6 degrees from tangent)
    d = rng.normal(size=targets.shape)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    grazing = np.arange(len(targets)) % 2 == 1
    tangent = d - np.einsum("ij,ij->i", d, n_t)[:, None] * n_t
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    angle = np.radians(rng.uniform(1, 6, len(targets)))
    d[grazing] = (np.cos(angle)[:, None] * tangent - np.sin(angle)[:, None] * n_t)[grazing]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = targets - 3 * R * d
    t_true = ref.first_hit(o, d, PAGE4, R, kind)
    rays = mi.Ray3f(mi.Point3f(*[o[:, k].astype(np.float32) for k in range(3)]),
                    mi.Vector3f(*[d[:, k].astype(np.float32) for k in range(3)]))
    si = scene.ray_intersect(rays)
    t_mesh = np.where(np.array(si.is_valid()), np.array(si.t, dtype=np.float64), np.inf)
    hit_m, hit_t = np.isfinite(t_mesh), np.isfinite(t_true)
    assert hit_t.mean() > 0.99  # each ray was aimed at a surface point
    slack = 1e-3  # float32 ray origins about 500 units from the origin
    p_m = o[hit_m] + t_mesh[hit_m, None] * d[hit_m]
    dist_m = ref.distance_to_surface_local(p_m, PAGE4, R, kind, 4 * e)
    far = dist_m > 0.9 * e
    dist_m[far] = ref.distance_to_surface_cone(p_m[far], PAGE4, R, kind, 4 * e, rng)
    assert dist_m.max() <= e + slack
    p_t = o[hit_t] + t_true[hit_t, None] * d[hit_t]
    assert ref.distance_to_mesh(p_t, v, f).max() <= e + slack
    both = hit_m & hit_t
    n_hit = exact_normal(o[both] + t_true[both, None] * d[both], PAGE4, kind)
    cos = np.abs(np.einsum("ij,ij->i", n_hit, d[both]))
    steep = cos > 0.3
    sep = np.abs(t_mesh[both] - t_true[both]) * cos
    assert steep.sum() > 200 and (~steep).sum() > 200
    assert sep[steep].max() <= e + slack
    # one hit and one miss only for rays that graze the surface (within 6 degrees)
    odd = np.nonzero(hit_m != hit_t)[0]
    t_any = np.where(hit_t[odd], t_true[odd], t_mesh[odd])
    n_odd = exact_normal(o[odd] + t_any[:, None] * d[odd], PAGE4, kind)
    assert (np.abs(np.einsum("ij,ij->i", n_odd, d[odd])) < np.sin(np.radians(6))).all()


def test_sphere_silhouette_area(llvm):
    """One source, exact field: a sphere of radius R. The rendered silhouette (a white
    emitter seen by an orthographic camera, 256x256 px, 64 spp) matches pi R^2 within 0.5%;
    the built-in sphere in the same set-up checks the set-up."""
    mi = llvm
    e = 0.002 * R
    size = 1.25 * R

    def coverage(shape):
        scene = mi.load_dict({
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 1},
            "sensor": {"type": "orthographic",
                       "to_world": mi.ScalarTransform4f().look_at(
                           origin=[0, 0, -5 * R], target=[0, 0, 0], up=[0, 1, 0])
                       @ mi.ScalarTransform4f().scale([size, size, 1]),
                       "film": {"type": "hdrfilm", "width": 256, "height": 256,
                                "rfilter": {"type": "box"}, "pixel_format": "luminance"},
                       "sampler": {"type": "stratified", "sample_count": 64}},
            "shape": shape,
        })
        img = np.array(mi.render(scene, seed=1))
        return img.sum() * (2 * size / 256) ** 2

    white = {"type": "area", "radiance": 1.0}
    sphere = coverage({"type": "sphere", "radius": R, "emitter": white})
    blob = coverage(blob_dict(mi, [[0, 0, 0]], max_error=e, field="exact", emitter=white))
    exact = np.pi * R * R
    assert abs(sphere / exact - 1) < 1e-3
    assert abs(blob / exact - 1) < 5e-3
    # inscribed mesh: no larger than the sphere, smaller by at most ~2 e / R
    assert blob <= sphere * 1.0005
    assert blob >= exact * (1 - 2 * e / R - 1e-3)


def test_renders_in_scalar_rgb(scalar):
    mi = scalar
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 60,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, -300],
                                                              target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 16, "height": 12},
                   "sampler": {"type": "independent", "sample_count": 4}},
        "light": {"type": "constant", "radiance": 1.0},
        "blob": blob_dict(mi, [[-40, 0, 0], [40, 0, 0]], max_error=2.0),
    })
    img = np.array(mi.render(scene))
    assert img.shape == (12, 16, 3) and np.isfinite(img).all()
    centre, corner = img[6, 8].mean(), img[0, 0].mean()
    assert centre < corner  # the diffuse blob (albedo 0.5) is darker than the sky


@pytest.mark.parametrize("variant", ["llvm", "scalar"])
def test_prints_like_a_mitsuba_shape(request, variant):
    """``print(scene)`` and ``str(blob)`` work (a Python shape without ``to_string`` makes
    nanobind fail: "get_trampoline(...Blob::to_string()): lookup failed") and say what the
    blob is: its own parameters and the mesh's size, as Mitsuba's shapes print theirs."""
    mi = request.getfixturevalue(variant)
    shift = mi.ScalarTransform4f().translate([1, 2, 3])
    d = blob_dict(mi, [[0, 0, 0], [100, 0, 0]], max_error=2.0, normals="field",
                  to_world=shift)
    blob = mi.load_dict(d)
    text = str(blob)
    print(text)     # shown with pytest -s
    for part in ("Blob[", "centers = 2", f"radius = {R:g}", 'field = "tutorial"',
                 'normals = "field"', "tessellate = true", "max_error = 2",
                 f"vertex_count = {blob.vertex_count()}", f"face_count = {blob.face_count()}",
                 "[0, 0, 0, 1]]", "bsdf = SmoothDiffuse["):
        assert part in text
    assert blob.face_count() > 100
    scene = mi.load_dict({"type": "scene", "blob": d})
    # nested, indented as a child, named by its key in the scene
    assert text.replace('id = ""', 'id = "blob"').replace("\n", "\n    ") in str(scene)


def _aimed_rays(mi, targets, rng, back, centre=np.zeros(3)):
    """Rays from ``back`` units before each target, towards it (steep: within 60 degrees
    of the inward direction through ``centre`` of the sphere-like blob)."""
    inward = centre - targets
    d = inward / np.linalg.norm(inward, axis=1, keepdims=True) + rng.normal(size=targets.shape) * 0.4
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = targets - back * d
    f32 = lambda a: [a[:, k].astype(np.float32) for k in range(3)]  # noqa: E731
    return o, d, mi.Ray3f(mi.Point3f(*f32(o)), mi.Vector3f(*f32(d)))


def test_exact_hit_on_a_sphere_is_the_closed_form(llvm):
    """One source, exact field: the blob is the sphere |p| = R. ``exact_hit`` moves the
    mesh's hits (max_error 0.01 R) onto it: t against the quadratic's root and the normal
    against p/R, both to float32 rounding, far closer than the mesh's own hits."""
    mi = llvm
    scene = mi.load_dict({"type": "scene", "blob": blob_dict(mi, [[0, 0, 0]], max_error=0.8,
                                                             field="exact")})
    shape = scene.shapes()[0]
    rng = np.random.default_rng(3)
    u = rng.normal(size=(400, 3))
    targets = R * u / np.linalg.norm(u, axis=1, keepdims=True)
    o, d, rays = _aimed_rays(mi, targets, rng, 2 * R)
    b = np.einsum("ij,ij->i", o, d)
    disc = b * b - (np.einsum("ij,ij->i", o, o) - R * R)
    t_true = -b - np.sqrt(np.maximum(disc, 0))
    si = scene.ray_intersect(rays)
    hit = shape.exact_hit(rays, si, si.is_valid())
    ok = np.array(si.is_valid()) & (disc > 0.05 * R * R)
    assert ok.sum() > 300
    t_mesh, t_exact = np.array(si.t)[ok], np.array(hit.t)[ok]
    assert np.abs(t_mesh - t_true[ok]).max() > 0.05           # the mesh is off by ~e
    assert np.abs(t_exact - t_true[ok]).max() < 1e-3           # float32 t near 2R
    p = np.array(hit.p).T[ok]
    n = np.array(hit.sh_frame.n).T[ok]
    assert np.abs(n - p / np.linalg.norm(p, axis=1, keepdims=True)).max() < 1e-4
    assert np.abs(np.array(hit.n).T[ok] - n).max() < 1e-6


def test_exact_hit_agrees_with_the_zone_solver(llvm):
    """Tutorial field, page 4's sources: ``exact_hit`` from the mesh's hits lands on the
    zone method's first crossing (blob_reference.first_hit, float64) on steep rays, within
    float32's error, where the mesh (max_error 0.5) is off by up to 0.5 / |cos|."""
    mi = llvm
    e = 0.5
    scene = mi.load_dict({"type": "scene",
                          "blob": blob_dict(mi, PAGE4, max_error=e, field="tutorial")})
    shape = scene.shapes()[0]
    rng = np.random.default_rng(11)
    targets = ref.surface_samples(PAGE4, R, "tutorial", 400, rng)[:400]
    centre = PAGE4.mean(0)
    o, d, rays = _aimed_rays(mi, targets, rng, 3 * R, centre)
    t_true = ref.first_hit(o, d, PAGE4, R, "tutorial")
    si = scene.ray_intersect(rays)
    hit = shape.exact_hit(rays, si, si.is_valid())
    n = np.array(si.n).T
    cos = np.abs(np.einsum("ij,ij->i", n, d))
    ok = np.array(si.is_valid()) & np.isfinite(t_true) & (cos > 0.3)
    assert ok.sum() > 200
    err_mesh = np.abs(np.array(si.t)[ok] - t_true[ok])
    err_exact = np.abs(np.array(hit.t)[ok] - t_true[ok])
    assert err_mesh.max() > 0.05
    # the same crossing: the mesh within 2 e / |cos| of the solver's (a few rays graze a
    # lobe the solver's first crossing passes by; mesh and exact_hit agree there)
    same = err_mesh <= 2 * e / cos[ok]
    assert same.mean() > 0.9
    assert np.median(err_exact[same]) < 1e-3 and err_exact[same].max() < 2e-2
    assert np.median(err_mesh[same]) > 20 * np.median(err_exact[same])


def test_zone_field_is_the_spec_table(llvm):
    """[fact] The one-source field that ``exact_hit`` solves, f(x) and f'(x), against facts.md
    F11.1's knots (blob_reference.SPEC_X / SPEC_F, linear in between, 0 beyond x = 10)."""
    mi = llvm
    shape = mi.load_dict(blob_dict(mi, [[0, 0, 0]], field="tutorial"))
    x = np.concatenate([np.random.default_rng(2).uniform(0.2, 12.0, 20000), ref.SPEC_X[1:]])
    f, df = shape.surface.zone(mi.Float(x.astype(np.float32)))
    x32 = x.astype(np.float32).astype(np.float64)
    assert np.abs(np.array(f) - np.interp(x32, ref.SPEC_X, ref.SPEC_F, right=0.0)).max() < 1e-6
    inner = np.abs(x32[:, None] - ref.SPEC_X[None]).min(1) > 1e-4   # off the kinks
    k = np.searchsorted(ref.SPEC_X, x32[inner], side="right")
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(k >= len(ref.SPEC_X), 0.0,
                         (ref.SPEC_F[np.minimum(k, 10)] - ref.SPEC_F[k - 1])
                         / (ref.SPEC_X[np.minimum(k, 10)] - ref.SPEC_X[k - 1]))
    slope = np.where(x32[inner] < 1.0, -0.9, slope)
    assert np.abs(np.array(df)[inner] - slope).max() < 1e-5


def test_exit_hit_is_the_chord_of_a_sphere(llvm):
    """One exact-field source is the sphere |p| = R. A ray leaving a point of it at angle
    a into the surface comes out after the chord 2 R sin(a), closed form, with the normal
    p / R there; given a miss (the mesh has no hit where a grazing chord runs between it
    and the surface), ``exit_hit`` finds it; a ray heading out gets no exit."""
    import drjit as dr
    mi = llvm
    R = 80.0
    shape = mi.load_dict({"type": "blob", "radius": R, "max_error": 0.5, "field": "exact",
                          "center0": mi.ScalarPoint3f(0, 0, 0)})
    blob = mi.load_dict({"type": "scene", "blob": shape}).shapes()[0]
    angles = np.radians([2.0, 20.0, 60.0, -10.0])      # negative: heading out
    o = np.stack([np.zeros(4), np.zeros(4), np.full(4, R)])        # on the sphere, normal +z
    d = np.stack([np.cos(angles), np.zeros(4), -np.sin(angles)])
    rays = mi.Ray3f(mi.Point3f(*o), mi.Vector3f(*d))
    miss = dr.zeros(mi.SurfaceInteraction3f, 4)
    miss.t = mi.Float(np.inf)
    out, ok = blob.exit_hit(rays, miss, mi.Float(np.inf), True)
    assert np.array(ok).tolist() == [True, True, True, False]
    t = np.array(out.t)[:3]
    assert np.allclose(t, 2 * R * np.sin(angles[:3]), rtol=1e-4)
    n, p = np.array(out.n)[:, :3], np.array(out.p)[:, :3]
    assert np.allclose(n, p / R, atol=1e-4)
    # before the next hit only: a nearer hit of the scene wins
    _, ok = blob.exit_hit(rays, miss, mi.Float(1.0), True)
    assert not np.array(ok).any()


def _sized_scene(mi, size: float, tessellate: bool, integrator: str) -> dict:
    T = mi.ScalarTransform4f
    return {"type": "scene", "integrator": {"type": integrator, "max_depth": 3},
            "sensor": {"type": "perspective", "fov": 40,
                       "to_world": T().look_at([0, 0, 4 * size], [0, 0, 0], [0, 1, 0]),
                       "film": {"type": "hdrfilm", "width": 8, "height": 8,
                                "rfilter": {"type": "box"}}},
            "blob": {"type": "blob", "centers": f"{-0.3 * size} 0 0 {0.3 * size} 0 0",
                     "radius": size, "tessellate": tessellate, "bsdf": {"type": "diffuse"}},
            "light": {"type": "point", "position": [0, 3 * size, 5 * size],
                      "intensity": 10 * size * size}}


@pytest.mark.parametrize("tessellate,integrator", [(True, "path"), (False, "tutorialpath")])
def test_renders_the_same_at_any_world_size(llvm, tessellate, integrator):
    """Closed form of scale invariance: the scene scaled by 1/100 (lengths, and the light's
    intensity by 1/100^2) gives the same image to float32 rounding. The exact normal's skip
    of a source near the point (the tutorial's |p - c|^2 <= 0.001 in pixels) once skipped
    every source of a blob of radius below about 0.03: black, or NaN under path."""
    mi = llvm
    unit = np.array(mi.render(mi.load_dict(_sized_scene(mi, 1.0, tessellate, integrator)),
                              spp=4, seed=0))
    small = np.array(mi.render(mi.load_dict(_sized_scene(mi, 0.01, tessellate, integrator)),
                               spp=4, seed=0))
    assert unit.max() > 0
    np.testing.assert_allclose(small, unit, rtol=0, atol=1e-4 * unit.max())


def test_own_values_written_back_rebuild_the_same_mesh(llvm):
    """The centres, radius and max_error that mi.traverse hands out (float32) are the ones
    the mesh was built from: written back, the vertex buffer is the same bit for bit."""
    mi = llvm
    import drjit as dr
    scene = mi.load_dict({"type": "scene", "blob": {
        "type": "blob", "centers": "0.1 0.2 0.3  0.7 0.1 0.3", "radius": 0.37,
        "max_error": 0.0013}})
    params = mi.traverse(scene)
    before = np.array(params["blob.vertex_positions"])
    for key in ("blob.centers", "blob.radius", "blob.max_error"):
        params[key] = type(params[key])(np.array(params[key]))
    params.update()
    assert np.array_equal(np.array(dr.detach(params["blob.vertex_positions"])), before)
