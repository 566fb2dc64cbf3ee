"""``tutorialpath``'s own ray queries against a scene of spheres
(``codermind.integrators._spheres``), checked against Mitsuba's ``scene.ray_intersect`` and
``scene.ray_test`` through Embree (external evidence: Mitsuba's own sphere), and the tie rule
against the tutorial's (facts.md F4.1: the first sphere listed wins a tie)."""

from __future__ import annotations

import numpy as np

SCENE = {"type": "scene",
         "a": {"type": "sphere", "center": [0, 0, 0], "radius": 80.0},
         "b": {"type": "sphere", "center": [150, 10, 30], "radius": 60.0}}


def rays(mi, rng, n):
    o = rng.uniform(-300, 600, (n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    f32 = lambda a: [a[:, k].astype(np.float32) for k in range(3)]  # noqa: E731
    ray = mi.Ray3f(mi.Point3f(*f32(o)), mi.Vector3f(*f32(d)))
    ray.maxt = mi.Float(rng.uniform(10, 2000, n).astype(np.float32))
    return ray


def scene_of(mi, **extra):
    d = dict(SCENE)
    d["c"] = {"type": "sphere",                  # a unit sphere scaled and moved
              "to_world": mi.ScalarTransform4f().translate([400.5, 290.25, 480.125])
              @ mi.ScalarTransform4f().scale(100.0)}
    d.update(extra)
    return mi.load_dict(d)


def test_hits_are_mitsubas_to_the_bit(llvm):
    """[Mitsuba's own sphere] 200000 random rays with random maxt: the same hits, and t, p,
    the normals, uv and the shape bit for bit (the sphere's float32 arithmetic and its own
    compute_surface_interaction)."""
    mi = llvm
    import drjit as dr
    from codermind.integrators._spheres import Spheres
    scene = scene_of(mi)
    spheres = Spheres.of(scene, [])
    ray = rays(mi, np.random.default_rng(0), 200000)
    expect = scene.ray_intersect(ray, mi.RayFlags.All, True)
    got = spheres.intersect(ray, mi.RayFlags.All, True)
    t0, t1 = np.array(expect.t), np.array(got.t)
    hit = np.isfinite(t0)
    assert hit.sum() > 5000 and np.array_equal(hit, np.isfinite(t1))
    assert np.array_equal(t0[hit], t1[hit])
    for name in ("p", "n", "uv", "dp_du"):
        assert np.array_equal(np.array(getattr(expect, name))[:, hit],
                              np.array(getattr(got, name))[:, hit]), name
    assert np.array_equal(np.array(expect.sh_frame.n)[:, hit], np.array(got.sh_frame.n)[:, hit])
    ids = lambda si: np.array(dr.reinterpret_array(mi.UInt32, si.shape))  # noqa: E731
    assert np.array_equal(ids(expect), ids(got))


def test_shadow_tests_are_mitsubas(llvm):
    """[Mitsuba's own sphere] ``test`` against ``scene.ray_test`` on the same rays."""
    mi = llvm
    from codermind.integrators._spheres import Spheres
    scene = scene_of(mi)
    ray = rays(mi, np.random.default_rng(1), 200000)
    expect = np.array(scene.ray_test(ray, True))
    got = np.array(Spheres.of(scene, []).test(ray, True))
    assert expect.sum() > 5000 and np.array_equal(expect, got)


def test_a_tie_goes_to_the_first_sphere_listed(llvm):
    """[facts.md F4.1] Two spheres mirrored about the plane x = 0, a ray along that plane meets
    both at exactly the same t: the first listed is hit, whichever it is."""
    mi = llvm
    from codermind.integrators._spheres import Spheres
    ray = mi.Ray3f(mi.Point3f(0.0, 0.0, -100.0), mi.Vector3f(0.0, 0.0, 1.0))
    for first, second in ((-30.0, 30.0), (30.0, -30.0)):
        scene = mi.load_dict({"type": "scene",
                              "one": {"type": "sphere", "center": [first, 0, 0], "radius": 50.0},
                              "two": {"type": "sphere", "center": [second, 0, 0], "radius": 50.0}})
        si = Spheres.of(scene, []).intersect(ray, mi.RayFlags.All, True)
        assert abs(si.t[0] - 60.0) < 1e-4
        assert si.p.x[0] == 0.0 and (si.n.x[0] > 0) == (first < 0)   # the first one's normal


def test_other_shapes_leave_the_queries_to_mitsuba(llvm):
    """A scene with any shape that is not a sphere (here a rectangle) is not traced here."""
    mi = llvm
    from codermind.integrators._spheres import Spheres
    scene = scene_of(mi, floor={"type": "rectangle"})
    assert Spheres.of(scene, []) is None
    assert Spheres.of(scene_of(mi), []) is not None
