"""The ``blob`` shape without a mesh (``tessellate`` false): ``analytic_hit`` against closed
forms and the independent zone solver (blob_reference, float64), its interactions, its
parameters, and ``tutorialpath`` rendering it as it renders the blob's mesh."""

from __future__ import annotations

import numpy as np
import pytest

from support import blob_reference as ref

R = 80.0
PAGE4 = np.array([(160, 290, 320), (400, 290, 480), (250, 140, 400)], float)


def analytic_blob(mi, centers, **extra):
    d = {"type": "blob", "radius": R, "tessellate": False}
    for i, c in enumerate(centers):
        d[f"center{i}"] = mi.ScalarPoint3f(*map(float, c))
    d.update(extra)
    return mi.load_dict(d)


def rays(mi, o, d):
    f32 = lambda a: [a[:, k].astype(np.float32) for k in range(3)]  # noqa: E731
    return mi.Ray3f(mi.Point3f(*f32(o)), mi.Vector3f(*f32(d)))


def random_lines(rng, lo, hi, n):
    o = rng.uniform(lo, hi, size=(n, 3))
    d = rng.normal(size=(n, 3))
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def test_one_source_is_the_sphere_of_radius_r(llvm):
    """[closed form] One source of the zone field: f(x) = 1.9 - 0.9 x = 1 at x = 1, the
    sphere |p| = R. Rays from outside hit its near root, rays from inside its far root, the
    rest miss (inf), all to float32 rounding at t ~ 2R."""
    mi = llvm
    shape = analytic_blob(mi, [[0, 0, 0]])
    rng = np.random.default_rng(5)
    o, d = random_lines(rng, -2.5 * R, 2.5 * R, 8000)
    b = np.einsum("ij,ij->i", o, d)
    c = np.einsum("ij,ij->i", o, o) - R * R
    disc = b * b - c
    root = np.sqrt(np.maximum(disc, 0))
    near, far = -b - root, -b + root
    expect = np.where(disc < 0, np.inf, np.where(near > 0.01, near,
                                                 np.where(far > 0.01, far, np.inf)))
    t = np.array(shape.analytic_hit(rays(mi, o, d), 0.01, mi.Float(np.inf), True))
    clear = np.abs(disc) > 1e-2 * R * R          # not tangent within float32's reach
    assert (c < 0).sum() > 100 and np.isfinite(expect[clear]).sum() > 500
    assert np.array_equal(np.isfinite(t[clear]), np.isfinite(expect[clear]))
    both = clear & np.isfinite(expect)
    assert np.abs(t[both] - expect[both]).max() < 2e-3


def test_first_hit_agrees_with_the_zone_solver(llvm):
    """[independent solver] Page 4's three sources: the first crossing beyond 0.01 of lines
    through the blob's box against blob_reference.first_hit (float64 roots zone by zone)."""
    mi = llvm
    shape = analytic_blob(mi, PAGE4)
    rng = np.random.default_rng(9)
    o, d = random_lines(rng, PAGE4.min(0) - 2 * R, PAGE4.max(0) + 2 * R, 3000)
    expect = ref.first_hit(o, d, PAGE4, R, "tutorial", tmin=0.01)
    t = np.array(shape.analytic_hit(rays(mi, o, d), 0.01, mi.Float(np.inf), True))
    assert np.isfinite(expect).sum() > 500
    agree = (np.isfinite(t) == np.isfinite(expect))
    both = np.isfinite(t) & np.isfinite(expect)
    # a line that only grazes a lobe (tangent within float32's rounding) may go either way
    # (on 20000 such lines: none; median |dt| 1.2e-5, max 4.7e-4 at t ~ 300)
    assert agree.mean() > 0.999
    err = np.abs(t[both] - expect[both])
    assert np.median(err) < 1e-4 and err.max() < 2e-3


def test_many_sources_agree_with_the_zone_solver(llvm):
    """[independent solver] Six sources at random (another bound level, crossings of
    several sources interleaved along a ray; the walk moves one source per step): the first
    crossing against blob_reference.first_hit, as for page 4's three."""
    mi = llvm
    rng = np.random.default_rng(21)
    centers = rng.uniform(-1.5 * R, 1.5 * R, size=(6, 3))
    shape = analytic_blob(mi, centers)
    o, d = random_lines(rng, centers.min(0) - 2 * R, centers.max(0) + 2 * R, 3000)
    expect = ref.first_hit(o, d, centers, R, "tutorial", tmin=0.01)
    t = np.array(shape.analytic_hit(rays(mi, o, d), 0.01, mi.Float(np.inf), True))
    assert np.isfinite(expect).sum() > 500 and (~np.isfinite(expect)).sum() > 100
    assert (np.isfinite(t) == np.isfinite(expect)).mean() > 0.999
    both = np.isfinite(t) & np.isfinite(expect)
    err = np.abs(t[both] - expect[both])
    assert np.median(err) < 1e-4 and err.max() < 2e-3


def test_tmin_and_tmax_bound_the_crossing(llvm):
    """A ray leaving a surface point outwards does not find the point itself beyond the
    blob epsilon; one that leaves it inwards finds the far side; tmax before the hit: inf."""
    mi = llvm
    shape = analytic_blob(mi, [[0, 0, 0]])
    o = np.array([[0.0, 0.0, R], [0.0, 0.0, R], [0.0, 0.0, -3 * R]])
    d = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    t = np.array(shape.analytic_hit(rays(mi, o, d), 0.01, mi.Float([np.inf, np.inf, 1.5 * R]),
                                    True))
    assert t[0] == np.inf and abs(t[1] - 2 * R) < 1e-3 and t[2] == np.inf


def test_interaction_normal_is_the_exact_gradient(llvm):
    """[independent formula] ``interaction`` at the hit: p on the ray at t, the shading
    normal along -grad sum R^2/d^2 (normals = exact, facts.md F11.4), wi = -d in its frame."""
    mi = llvm
    shape = analytic_blob(mi, PAGE4)
    rng = np.random.default_rng(4)
    o, d = random_lines(rng, PAGE4.min(0) - 2 * R, PAGE4.max(0) + 2 * R, 1000)
    ray = rays(mi, o, d)
    t = shape.analytic_hit(ray, 0.01, mi.Float(np.inf), True)
    hit = np.isfinite(np.array(t))
    si = shape.interaction(ray, t, mi.Bool(hit))
    p = np.array(si.p).T[hit]
    assert np.abs(p - (o + np.array(t)[:, None] * d)[hit]).max() < 2e-3
    g = -ref.exact_gradient(p, PAGE4, R)
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    assert np.abs(np.array(si.sh_frame.n).T[hit] - g).max() < 1e-4
    wi = np.array(si.wi).T[hit]
    local = np.stack([np.einsum("ij,ij->i", -d[hit], np.array(a).T[hit])
                      for a in (si.sh_frame.s, si.sh_frame.t, si.sh_frame.n)], 1)
    assert np.abs(wi - local).max() < 1e-5
    assert np.array(si.is_valid())[hit].all() and not np.array(si.is_valid())[~hit].any()


def test_scalar_variant_finds_the_sphere(scalar):
    mi = scalar
    shape = analytic_blob(mi, [[0, 0, 0]])
    ray = mi.Ray3f(mi.Point3f(0, 0, -3 * R), mi.Vector3f(0, 0, 1))
    t = shape.analytic_hit(ray, 0.01, float("inf"), True)
    assert abs(t - 2 * R) < 1e-3
    si = shape.interaction(ray, t, True)
    assert abs(si.sh_frame.n[2] + 1) < 1e-6


@pytest.mark.parametrize("extra, message", [
    ({"field": "exact"}, "needs field = 'tutorial'"),
    ({"tessellate": 1}, "'tessellate' must be a boolean"),
])
def test_bad_parameters_are_named(llvm, extra, message):
    with pytest.raises(Exception, match=message):
        analytic_blob(llvm, [[0, 0, 0]], **extra)


def _sphere_scene(mi, integrator: dict, tessellate: bool, light: bool = True) -> dict:
    """A diffuse blob sphere over a plane, lit by a point light above (its shadow on the
    plane), seen from the front, on a constant sky."""
    blob = {"type": "blob", "radius": R, "center0": mi.ScalarPoint3f(0, 0, 0),
            "tessellate": tessellate, "max_error": 0.05,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.5, 0.3]}}}
    scene = {
        "type": "scene", "integrator": integrator, "blob": blob,
        "sensor": {"type": "perspective", "fov": 50,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 120, -400],
                                                              target=[0, -40, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 48, "height": 36, "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": 4}},
        "floor": {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate(
            [0, -R, 0]).rotate([1, 0, 0], 90).scale(400)},
        "sky": {"type": "constant", "radiance": 0.2},
    }
    if light:
        scene["light"] = {"type": "point", "position": [60, 400, 0], "intensity": 4e4}
    return scene


def test_tutorialpath_renders_it_as_the_exact_hits_mesh(llvm):
    """``tutorialpath`` on the analytic sphere and on its mesh with exact hits (max_error
    0.05), the same seed: the same image (a few silhouette pixels aside), the sphere's
    shading and its shadow on the floor included."""
    mi = llvm
    tp = {"type": "tutorialpath", "max_depth": 3}
    img = {k: np.array(mi.render(mi.load_dict(_sphere_scene(mi, tp, k == "mesh")), seed=1))
           for k in ("analytic", "mesh")}
    diff = np.abs(img["analytic"] - img["mesh"]).max(-1)
    assert np.quantile(diff, 0.98) < 1e-3 * img["mesh"].max()
    assert img["mesh"].std() > 0.1 * img["mesh"].mean()       # not a blank image


def test_shadow_rays_see_the_analytic_blob(llvm):
    """[closed form] Shadow rays from floor points to the light are blocked exactly where
    the segment passes within R of the sphere's centre."""
    mi = llvm
    from codermind.integrators.tutorialpath import TutorialIntegrator
    shape = analytic_blob(mi, [[0, 0, 0]])
    rng = np.random.default_rng(2)
    p = np.column_stack([rng.uniform(-300, 300, 4000), np.full(4000, -R),
                         rng.uniform(-300, 300, 4000)])
    light = np.array([60.0, 400.0, 0.0])
    v = light - p
    dist = np.linalg.norm(v, axis=1)
    d = v / dist[:, None]
    ray = rays(mi, p, d)
    ray.maxt = mi.Float(dist.astype(np.float32))
    blocked = np.array(TutorialIntegrator._occluded([shape], ray, mi.Bool(True)))
    s = np.clip(-np.einsum("ij,ij->i", p, d), 0, dist)
    miss = np.linalg.norm(p + s[:, None] * d, axis=1) - R      # closest approach - R
    clear = np.abs(miss) > 0.05
    assert 200 < blocked.sum() < 3800
    assert np.array_equal(blocked[clear], (miss < 0)[clear])


def test_other_integrators_see_no_untessellated_blob(llvm):
    """As documented: ``path`` renders the scene as if the blob were absent."""
    mi = llvm
    pt = {"type": "path", "max_depth": 3}
    with_blob = np.array(mi.render(mi.load_dict(_sphere_scene(mi, pt, False)), seed=1))
    without = _sphere_scene(mi, pt, False)
    del without["blob"]
    assert np.array_equal(with_blob, np.array(mi.render(mi.load_dict(without), seed=1)))


def _lines_through_a_core(mi, n=50):
    """Rays along +x through source A's core (A at the origin), at heights 0 to 0.9 R."""
    h = np.linspace(0.0, 0.9 * R, n)
    o = np.column_stack([np.full(n, -5 * R), h, np.zeros(n)])
    d = np.tile([1.0, 0.0, 0.0], (n, 1))
    return o, d, rays(mi, o, d)


def test_strict_lone_core_is_hit(llvm):
    """[facts.md F11] One source alone: the float32 running bound in its core sums to 1, so
    strict and clean find the same sphere on every ray."""
    mi = llvm
    shape = analytic_blob(mi, [[0, 0, 0]])
    _, _, ray = _lines_through_a_core(mi)
    clean = np.array(shape.analytic_hit(ray, 0.01, mi.Float(np.inf), True))
    strict = np.array(shape.analytic_hit(ray, 0.01, mi.Float(np.inf), True, strict=True))
    assert np.isfinite(clean).all() and np.abs(strict - clean).max() < 1e-3


def test_strict_holes_after_another_zone_zero(llvm):
    """[facts.md F11, step 3] A ray that has entered and left another source's zone 0 before a
    lone source's core has a float32 bound of 0.99999994 there: strict skips the core (the
    original's holes), clean hits it; the port's strict blob (codermind_ref.blob,
    float32_sums) has the same holes on the same rays."""
    mi = llvm
    from codermind_ref import blob as port_blob
    centers = np.array([[0.0, 0.0, 0.0], [-240.0, 232.0, 0.0]])
    shape = analytic_blob(mi, centers)
    o, d, ray = _lines_through_a_core(mi)
    clean = np.isfinite(np.array(shape.analytic_hit(ray, 0.01, mi.Float(np.inf), True)))
    strict = np.isfinite(np.array(shape.analytic_hit(ray, 0.01, mi.Float(np.inf), True,
                                                     strict=True)))
    holes = clean & ~strict
    assert clean.all() and holes.sum() >= 10
    # the port needs three sources: the third far away, crossing nothing
    port_centers = np.vstack([centers, [[1e5, 1e5, 1e5]]])
    _, port_hit = port_blob.hit(o.T.copy(), d.T.copy(), np.full(len(o), np.inf), port_centers,
                                R, float32_sums=True)
    assert np.array_equal(port_hit, strict)


def test_strict_hits_agree_with_the_port_on_page4(llvm):
    """[port, strict] Page 4's blob seen from in front (rays from behind the camera plane
    towards points around it): hits and holes of the strict walk against the port's strict
    intersection, ray by ray (on 200000 such rays: 689 holes, 1 ray differs)."""
    mi = llvm
    from codermind_ref import blob as port_blob
    shape = analytic_blob(mi, PAGE4)
    rng = np.random.default_rng(9)
    n = 40000
    target = rng.uniform(PAGE4.min(0) - 1.2 * R, PAGE4.max(0) + 1.2 * R, size=(n, 3))
    o = np.tile([320.0, 240.0, -1000.0], (n, 1))
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ray = rays(mi, o, d)
    clean = np.isfinite(np.array(shape.analytic_hit(ray, 0.01, mi.Float(np.inf), True)))
    t = np.array(shape.analytic_hit(ray, 0.01, mi.Float(np.inf), True, strict=True))
    t_port, port_hit = port_blob.hit(o.T.copy(), d.T.copy(), np.full(n, np.inf), PAGE4, R,
                                     float32_sums=True)
    strict = np.isfinite(t)
    assert (clean & ~strict).sum() > 50                      # the holes exist ...
    assert (strict != port_hit).sum() <= 3                   # ... where the port has them
    both = strict & port_hit
    # the original's roots carry its float32 polynomial sums (not reproduced): ~1e-3
    assert np.median(np.abs(t[both] - t_port[both])) < 1e-2
