"""Scene parameters of every plugin through ``mi.traverse``, as Mitsuba's built-ins expose
theirs (issue 15): each plugin lists its parameters, and each one written there and
``update()``d changes the next render (writing the old value back restores the image,
so the change came from that parameter). Evidence: Mitsuba's own
``SceneParameters`` machinery and renders, tiny (16x16, 2 spp, fixed seed)."""

from __future__ import annotations

import numpy as np
import pytest

SIZE, SPP = 16, 2


def _camera(mi, **extra):
    return {"type": "perspective", "fov": 50,
            "to_world": mi.ScalarTransform4f().look_at([0, 0, 5], [0, 0, 0], [0, 1, 0]),
            "film": {"type": "hdrfilm", "width": SIZE, "height": SIZE,
                     "rfilter": {"type": "box"}}, **extra}


def _scene(mi, obj=None, bsdf=None, sensor=None, emitters=None, integrator="path"):
    """A sphere (or ``obj``) with ``bsdf`` in front of ``sensor``, lit by a point light
    and a constant environment (or ``emitters``)."""
    shape = obj or {"type": "sphere", "radius": 1.0}
    if bsdf is not None:
        shape = {**shape, "bsdf": bsdf}
    d = {"type": "scene", "integrator": {"type": integrator, "max_depth": 4},
         "sensor": sensor or _camera(mi), "obj": shape,
         "floor": {"type": "rectangle", "to_world": mi.ScalarTransform4f()
                   .translate([0, 0, -2]).scale(4), "bsdf": {"type": "diffuse"}}}
    d.update(emitters or {"light": {"type": "point", "position": [2, 3, 4],
                                    "intensity": {"type": "rgb", "value": 20.0}},
                          "env": {"type": "constant", "radiance": 0.3}})
    return d


def _faces(mi):
    rng = np.random.default_rng(1)
    return {name: mi.Bitmap(rng.uniform(0.1, 0.9, (4, 4, 3)).astype(np.float32))
            for name in ("up", "down", "right", "left", "forward", "backward")}


SCENES = {
    "blinnphong": lambda mi: _scene(mi, bsdf={"type": "blinnphong"}),
    "tutorial": lambda mi: _scene(mi, bsdf={
        "type": "tutorial", "diffuse": {"type": "rgb", "value": 0.5},
        "specular": {"type": "rgb", "value": 0.5}, "power": 20.0, "reflection": 0.3,
        "refraction": 0.3, "density": 1.3}),
    "noisebump": lambda mi: _scene(mi, bsdf={
        "type": "noisebump", "bumplevel": 0.3, "frequency": 2.0,
        "nested": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.6}}}),
    "perlin": lambda mi: _scene(mi, bsdf={"type": "diffuse", "reflectance": {
        "type": "perlin", "frequency": 2.0, "scale": 0.5, "offset": 0.5}}),
    "turbulence": lambda mi: _scene(mi, bsdf={"type": "diffuse", "reflectance": {
        "type": "turbulence", "frequency": 1.0, "octaves": 3,
        "color0": {"type": "rgb", "value": 0.8}, "color1": {"type": "rgb", "value": 0.1}}}),
    "marble": lambda mi: _scene(mi, bsdf={"type": "diffuse", "reflectance": {
        "type": "marble", "frequency": 1.0, "octaves": 3, "stripe_frequency": 2.0,
        "color0": {"type": "rgb", "value": 0.8}, "color1": {"type": "rgb", "value": 0.1}}}),
    "conic": lambda mi: _scene(mi, sensor=_camera(mi, type="conic", aperture_radius=0.2,
                                                  focus_distance=3.0)),
    "conic_tutorial": lambda mi: _scene(mi, sensor=_camera(
        mi, type="conic", lens="tutorial", aperture=0.3, focus_distance=3.0)),
    "tutorialortho": lambda mi: _scene(mi, sensor={
        "type": "tutorialortho", "near_clip": 0.0, "far_clip": 20.0,
        "to_world": mi.ScalarTransform4f().translate([0, 0, 5]).scale([2, 2, -1]),
        "film": {"type": "hdrfilm", "width": SIZE, "height": SIZE}}),
    "cubemap": lambda mi: _scene(mi, emitters={"env": {"type": "cubemap", **_faces(mi)}}),
    "tutorialpoint": lambda mi: _scene(mi, emitters={"light": {
        "type": "tutorialpoint", "position": [2, 3, 4],
        "intensity": {"type": "rgb", "value": 20.0}}}),
    "blob": lambda mi: _scene(mi, obj={"type": "blob", "centers": "-0.6 0 0  0.6 0 0",
                                       "radius": 0.8, "max_error": 0.01}),
}

#: (scene, key, new value): every parameter each plugin exposes. The prefix names the
#: plugin's node in the scene (obj.bsdf, sensor, env, ...).
T = lambda mi, *t: mi.Transform4f().translate(list(t))  # noqa: E731
CASES = [
    ("blinnphong", "obj.bsdf.diffuse_reflectance.value", lambda mi: mi.Float(0.1)),
    ("blinnphong", "obj.bsdf.specular_reflectance.value", lambda mi: mi.Float(0.7)),
    ("blinnphong", "obj.bsdf.exponent", lambda mi: mi.Float(3.0)),
    ("tutorial", "obj.bsdf.diffuse.value", lambda mi: mi.Float(0.1)),
    ("tutorial", "obj.bsdf.specular.value", lambda mi: mi.Float(1.5)),
    ("tutorial", "obj.bsdf.power", lambda mi: mi.Float(3.0)),
    ("tutorial", "obj.bsdf.reflection", lambda mi: mi.Float(0.7)),
    ("tutorial", "obj.bsdf.refraction", lambda mi: mi.Float(0.0)),
    ("tutorial", "obj.bsdf.density", lambda mi: mi.Float(2.0)),
    ("noisebump", "obj.bsdf.bumplevel", lambda mi: mi.Float(0.8)),
    ("noisebump", "obj.bsdf.frequency", lambda mi: mi.Float(5.0)),
    ("noisebump", "obj.bsdf.to_world", lambda mi: T(mi, 0.3, 0.2, 0.1)),
    ("noisebump", "obj.bsdf.nested_bsdf.reflectance.value", lambda mi: mi.Float(0.2)),
    ("perlin", "obj.bsdf.reflectance.frequency", lambda mi: mi.Float(5.0)),
    ("perlin", "obj.bsdf.reflectance.to_world", lambda mi: T(mi, 0.3, 0.2, 0.1)),
    ("perlin", "obj.bsdf.reflectance.scale", lambda mi: mi.Float(0.2)),
    ("perlin", "obj.bsdf.reflectance.offset", lambda mi: mi.Float(0.2)),
] + [
    (tex, f"obj.bsdf.reflectance.{key}", value)
    for tex in ("turbulence", "marble")
    for key, value in [("color0.value", lambda mi: mi.Float(0.3)),
                       ("color1.value", lambda mi: mi.Float(0.5)),
                       ("frequency", lambda mi: mi.Float(3.0)),
                       ("octaves", lambda mi: mi.Float(1)),
                       ("to_world", lambda mi: T(mi, 0.3, 0.2, 0.1))]
] + [
    ("marble", "obj.bsdf.reflectance.stripe_frequency", lambda mi: mi.Float(5.0)),
    ("conic", "sensor.x_fov", lambda mi: mi.Float(30.0)),
    ("conic", "sensor.to_world", lambda mi: mi.Transform4f().look_at([1, 0, 5], [0, 0, 0],
                                                                      [0, 1, 0])),
    ("conic", "sensor.aperture_radius", lambda mi: mi.Float(0.0)),
    ("conic", "sensor.focus_distance", lambda mi: mi.Float(8.0)),
    ("conic", "sensor.near_clip", lambda mi: mi.Float(4.5)),
    ("conic", "sensor.far_clip", lambda mi: mi.Float(4.5)),
    ("conic_tutorial", "sensor.aperture", lambda mi: mi.Float(0.0)),
    ("conic_tutorial", "sensor.x_fov", lambda mi: mi.Float(30.0)),
    ("conic_tutorial", "sensor.to_world", lambda mi: mi.Transform4f().look_at(
        [1, 0, 5], [0, 0, 0], [0, 1, 0])),
    ("conic_tutorial", "sensor.focus_distance", lambda mi: mi.Float(8.0)),
    ("conic_tutorial", "sensor.near_clip", lambda mi: mi.Float(4.5)),
    ("conic_tutorial", "sensor.far_clip", lambda mi: mi.Float(4.5)),
    ("tutorialortho", "sensor.to_world", lambda mi: mi.Transform4f().translate([0.5, 0, 5])
     .scale([2, 2, -1])),
    ("tutorialortho", "sensor.near_clip", lambda mi: mi.Float(4.5)),
    ("tutorialortho", "sensor.far_clip", lambda mi: mi.Float(4.5)),
    ("cubemap", "env.data", lambda mi: mi.TensorXf(np.full((6, 4, 4, 3), 0.2, np.float32))),
    ("cubemap", "env.scale", lambda mi: mi.Float(3.0)),
    ("cubemap", "env.exposure", lambda mi: mi.Float(3.0)),
    ("cubemap", "env.to_world", lambda mi: mi.Transform4f().rotate([0, 1, 0], 90)),
    ("tutorialpoint", "light.position", lambda mi: mi.Point3f(-2, 3, 4)),
    ("tutorialpoint", "light.intensity.value", lambda mi: mi.Float(5.0)),
    ("blob", "obj.centers", lambda mi: mi.Float([-0.3, 0.2, 0, 0.9, 0, 0, 0, -0.8, 0])),
    ("blob", "obj.radius", lambda mi: mi.Float(0.5)),
    ("blob", "obj.max_error", lambda mi: mi.Float(0.002)),
]

#: Keys the plugins inherit from Mitsuba's base classes (not theirs to expose).
INHERITED = ("sampling_weight", "shutter_open", "shutter_open_time", "film.",
             "silhouette_sampling_weight", "faces", "vertex_", "bsdf.reflectance.value")
PREFIX = {"obj.bsdf": ("blinnphong", "tutorial", "noisebump"),
          "obj.bsdf.reflectance": ("perlin", "turbulence", "marble"),
          "sensor": ("conic", "conic_tutorial", "tutorialortho"),
          "env": ("cubemap",), "light": ("tutorialpoint",), "obj": ("blob",)}


def _prefix(name: str) -> str:
    return next(p for p, names in PREFIX.items() if name in names)


_cache: dict = {}


def _loaded(mi, name: str):
    """The scene (cached: loading the blob and compiling kernels is the cost), its
    parameters and its image."""
    if (mi.variant(), name) not in _cache:
        scene = mi.load_dict(SCENES[name](mi))
        params = mi.traverse(scene)
        _cache[(mi.variant(), name)] = scene, params, _render(mi, scene)
    return _cache[(mi.variant(), name)]


def _render(mi, scene) -> np.ndarray:
    return np.array(mi.render(scene, spp=SPP, seed=0), dtype=np.float64)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_every_parameter_is_listed(llvm, name):
    mi = llvm
    _, params, _ = _loaded(mi, name)
    prefix = _prefix(name) + "."
    exposed = {k for k in params.keys() if k.startswith(prefix)
               and not any(k[len(prefix):].startswith(i) for i in INHERITED)
               and (name != "blob" or not k.startswith("obj.bsdf."))}
    if prefix == "obj.bsdf.":       # the texture keys below belong to the texture tests
        exposed = {k for k in exposed if not k.startswith("obj.bsdf.reflectance.")
                   or name == "noisebump"}
    expected = {key for scene, key, _ in CASES if scene == name}
    assert exposed == expected


@pytest.mark.parametrize("name,key,value", CASES, ids=[f"{n}-{k.split('.', 1)[1]}"
                                                        for n, k, _ in CASES])
def test_changing_a_parameter_changes_the_render(llvm, name, key, value):
    mi = llvm
    scene, params, before = _loaded(mi, name)
    old = type(params[key])(params[key])
    params[key] = value(mi)
    params.update()
    try:
        after = _render(mi, scene)
    finally:
        params[key] = old
        params.update()
    assert np.isfinite(after).all()
    assert np.abs(after - before).max() > 1e-3, f"{key}: the image did not change"
    # the old value back gives the old image (to float rounding: a rebuilt blob's BVH)
    np.testing.assert_allclose(_render(mi, scene), before, rtol=0, atol=1e-5)


@pytest.mark.parametrize("key,value,message", [
    ("reflection", 1.5, "tutorial: 'reflection' must be finite in float32 and in [0, 1], "
                        "got 1.5"),
    ("power", -1.0, "tutorial: 'power' must be finite in float32 and >= 0, got -1"),
    ("density", float("nan"), "tutorial: 'density' must be finite in float32 and >= 0, "
                              "got nan"),
])
def test_invalid_value_is_rejected_in_one_line(llvm, key, value, message):
    """The same one-line message for a bad value in the scene and through mi.traverse
    (both go through ``params.check_float``)."""
    import re
    mi = llvm
    scene_dict = SCENES["tutorial"](mi)
    with pytest.raises(RuntimeError) as error:
        mi.load_dict({**scene_dict, "obj": {**scene_dict["obj"], "bsdf": {
            **scene_dict["obj"]["bsdf"], key: value}}})
    assert message in str(error.value)
    scene = mi.load_dict(scene_dict)
    params = mi.traverse(scene)
    params[f"obj.bsdf.{key}"] = mi.Float(value)
    with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
        params.update()


def test_blob_center_count_can_change(llvm):
    """Rebuilding from 2 to 3 centres: the mesh is another size, the scene still traces
    it (the render differs from the 2-centre one)."""
    mi = llvm
    scene = mi.load_dict(SCENES["blob"](mi))
    params = mi.traverse(scene)
    blob = next(s for s in scene.shapes() if s.id() == "obj")
    count = blob.face_count()
    params["obj.centers"] = mi.Float([-0.6, 0, 0, 0.6, 0, 0, 0, 0.9, 0])
    params.update()
    assert blob.face_count() != count
    assert len(params["obj.faces"]) == 3 * blob.face_count()
    # a ray straight down onto the third centre's top (y = 0.9 + ~0.8) now hits the blob
    ray = mi.Ray3f(mi.Point3f(0, 5, 0), mi.Vector3f(0, -1, 0))
    si = scene.ray_intersect(ray)
    assert float(si.p.y[0]) > 1.2
