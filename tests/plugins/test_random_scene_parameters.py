"""Scene parameters and loading of random scenes nobody tuned anything to (drawn by
tests/support/random_scenes.py): every traversed parameter of our plugins round-trips through
``mi.traverse`` and ``params.update()``, a misspelled parameter of any of our plugins is
refused in one line, and ``print(scene)`` works; with one fixed scene per plugin, each
parameter written back as its own value changes no bit of the render.

CI runs the "ci" hypothesis profile (a few derandomized scenes per property); failing
examples are reported as drawn (no shrinking: each example loads and renders a scene)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import assume, given, strategies as st

from support import random_scenes as rs
from support import examples


@pytest.fixture(scope="module")
def assets(tmp_path_factory):
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    return rs.write_assets(mi, tmp_path_factory.mktemp("assets"))


# -- mi.traverse ------------------------------------------------------------------------------

#: Parameters our plugins inherit from Mitsuba's base classes (the mesh's buffers, the
#: emitter's and camera's generic ones): Mitsuba's to expose, not ours.
INHERITED = ("sampling_weight", "shutter_open", "shutter_open_time", "silhouette_sampling_weight",
             "faces", "vertex_positions", "vertex_normals", "vertex_texcoords")


def ours(params) -> list[tuple[str, object]]:
    """``(key, plugin object)`` of every traversed parameter that belongs to one of our
    plugins (its node is an object of a class of the codermind package), without the
    parameters they inherit (``INHERITED``)."""
    return [(key, params.properties[key][2]) for key in params.keys()
            if type(params.properties[key][2]).__module__.startswith("codermind.")
            and key.rsplit(".", 1)[-1] not in INHERITED]


def is_transform(value) -> bool:
    return "Transform" in type(value).__name__


def fresh(mi, value):
    """A new object equal to ``value`` (Mitsuba skips writing the very same variable)."""
    if isinstance(value, mi.TensorXf):
        return mi.TensorXf(np.array(value))
    if is_transform(value):
        return type(value)(mi.Matrix4f(np.array(value.matrix, dtype=np.float32)))
    return type(value)(np.array(value))


def perturbed(mi, key: str, value):
    """A valid value near ``value`` that differs from it."""
    name = key.rsplit(".", 1)[1]
    if is_transform(value):
        # a turn about y (premultiplied: rigid cameras stay rigid, the cube map's
        # translation-free to_world stays so)
        return mi.Transform4f().rotate([0, 1, 0], 7.0) @ fresh(mi, value)
    if isinstance(value, mi.TensorXf):
        return mi.TensorXf(np.array(value) * 0.9)
    a = np.array(value, dtype=np.float64)
    if name in ("octaves", "max_depth"):               # integers (1-64, >= -1)
        return type(value)(a - 1 if a[0] > 1 else a + 1)
    if name == "centers":
        return type(value)(a + 0.05 * (np.abs(a).max() + 1e-3))
    if isinstance(value, mi.Point3f):
        shift = 0.1 * (float(np.abs(a).max()) + 1.0)
        return mi.Point3f(*(float(c) * 0.9 + shift for c in a.ravel()))
    return type(value)(np.where(a == 0, 1e-3, a * 0.9))


def state(plugin) -> dict:
    """The plugin object's own attributes as numbers (what it renders with), without the
    values ``mi.traverse`` hands out (``_exposed``), and its ``to_string`` (which shows what
    its Mitsuba base class keeps, such as a camera's ``to_world``)."""
    try:
        out = {"to_string": plugin.to_string()}
    except Exception:     # noqa: BLE001 (a plugin whose to_string fails: print's property)
        out = {}
    for k, v in vars(plugin).items():
        if k == "_exposed":
            continue
        try:
            out[k] = np.array(v.matrix if is_transform(v) else v, dtype=np.float64)
        except (TypeError, ValueError):
            continue
    return out


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        a[k] == b[k] if isinstance(a[k], str) else np.array_equal(a[k], b[k], equal_nan=True)
        for k in a)


def deterministic(mi, scene) -> np.ndarray:
    """A render that is the same bit for bit each time: one sample per pixel (the scene's
    film must have a ``box`` filter). With several samples splatted into one pixel (more
    spp, or a wider filter) the film's atomic additions run in whatever order the threads
    reach them, and the last bits of a pixel change from render to render."""
    return np.array(mi.render(scene, spp=1, seed=0))


@examples(ci=2, long=100, shrink=False)
@given(spec=rs.scenes())
def test_our_parameters_round_trip_through_traverse(llvm, assets, spec):
    """Evidence: Mitsuba's ``SceneParameters`` against the plugins' ``traverse`` and
    ``parameters_changed``: each traversed parameter of our plugins, written back as its own
    value (a new object) and ``update()``d, gives the same render bit for bit; a perturbed
    valid value changes the plugin's state or its render; the old value back gives the first
    render bit for bit again."""
    mi = llvm
    spec = copy.deepcopy(spec)
    spec["scene"]["sensor"]["film"]["rfilter"] = {"type": "box"}     # see deterministic()
    try:    # with tutorialpath, whose own parameters are ours too
        scene = rs.load(mi, rs.build(spec, mi, assets, name="tutorialpath"))
    except (ValueError, RuntimeError):            # a refusal (another property)
        assume(False)
    params = mi.traverse(scene)

    def image():
        return deterministic(mi, scene)

    before = image()
    for key, plugin in ours(params):
        value = fresh(mi, params[key])
        params[key] = fresh(mi, value)
        params.set_dirty(key)
        params.update()
        assert np.array_equal(image(), before, equal_nan=True), f"{key}: own value"
        old = state(plugin)
        params[key] = perturbed(mi, key, value)
        params.update()
        assert not _same(state(plugin), old) or \
            not np.array_equal(image(), before, equal_nan=True), f"{key}: nothing changed"
        params[key] = fresh(mi, value)
        params.update()
        assert np.array_equal(image(), before, equal_nan=True), f"{key}: old value back"
        before = image()


UNKNOWN_PARAMETER_PLUGINS = sorted(rs.OURS - {"tutorialpath"})


@pytest.mark.parametrize("plugin", UNKNOWN_PARAMETER_PLUGINS)
@examples(ci=2, long=30, shrink=False)
@given(data=st.data())
def test_unknown_parameter_is_refused(llvm, assets, plugin, data):
    """Evidence: Mitsuba's own check for unreferenced properties (or the plugin's): a scene
    in which one parameter of a ``plugin`` node is misspelled fails to load with one line
    that names the plugin type and the misspelled name in quotes."""
    mi = llvm
    spec = data.draw(rs.scenes().filter(lambda s: plugin in rs.types(s)), label="spec")
    try:
        rs.load(mi, rs.build(spec, mi, assets))
    except (ValueError, RuntimeError):
        assume(False)                              # refused as it is: nothing to misspell
    path, key, typo = data.draw(st.sampled_from(rs.misspellings(spec, plugin)),
                                label="misspelling")
    answer = rs.refuses_typo(mi, spec, assets, path, key, typo)
    assert answer["refused"], f"{path}: '{typo}' for '{key}' was accepted"
    assert answer["names_it"], answer["message"]


@pytest.mark.parametrize("key,value", [("max_depth", 3), ("exact_hits", False),
                                       ("min_distance", 0.1), ("quirks", "strict")])
def test_unknown_tutorialpath_parameter_is_refused(llvm, key, value):
    """Evidence: as above, for the integrator (not part of the random scenes): each of its
    parameters misspelled (its last letter dropped) beside the right one."""
    mi = llvm
    typo = key[:-1]
    with pytest.raises(RuntimeError) as error:
        mi.load_dict({"type": "tutorialpath", key: value, typo: value})
    message = rs.refusal(error.value)
    assert "\n" not in message and "tutorialpath" in message and f'"{typo}"' in message


@examples(ci=3, long=100, shrink=False)
@given(spec=rs.scenes())
def test_print_scene_works(llvm, assets, spec):
    """Evidence: ``str(scene)`` (Mitsuba's own ``Scene::to_string``, which calls every
    plugin's ``to_string``) returns and names the scene."""
    mi = llvm
    try:
        scene = rs.load(mi, rs.build(spec, mi, assets))
    except (ValueError, RuntimeError):
        assume(False)
    text = str(scene)
    assert text.startswith("Scene[")


def _own_value_back(mi, scene, key) -> tuple[np.ndarray, np.ndarray]:
    """The render before and after writing parameter ``key``'s own value back."""
    params = mi.traverse(scene)
    before = deterministic(mi, scene)
    params[key] = fresh(mi, params[key])
    params.set_dirty(key)
    params.update()
    return before, deterministic(mi, scene)


#: A number float32 does not hold exactly, whose float32 copy differs from it in arithmetic
#: (1 - A in double, rounded, is not 1 - float32(A) in float32).
A = 0.8857504840250512
#: A placement float32 does not hold exactly (a turn, a scale, a shift).
PLACEMENT = [["translate", [0.3, 0.1, 0.2]], ["rotate", [0.267261, 0.534522, 0.801784], 37.0],
             ["scale", [1.3, 1.3, 1.3]]]


def _rgb(value) -> dict:
    return {"type": "rgb", "value": value}


def _look(*extra) -> dict:
    return {"transform": [["look_at", [0, 0, 4], [0, 0, 0], [0, 1, 0]], *extra]}


def _own_value_scene(case: str) -> dict:
    """A small scene with our plugins in it, every parameter at a value float32 does not
    hold exactly: ``materials`` (every BSDF and texture but noisebump, the disc-lens
    camera, the point light and the cube map), a camera alone (``tutorial_lens``,
    ``tutorialortho``), or ``noisebump`` or ``blob`` alone."""
    place = {"transform": PLACEMENT}
    texture = {"frequency": 2.3 * A, "to_world": place}
    camera = {"type": "perspective", "fov": 45.0, "to_world": _look()}
    scene = {"type": "scene",
             "ball": {"type": "sphere", "bsdf": {"type": "diffuse", "reflectance": _rgb(0.5)}},
             "light": {"type": "point", "position": [2.0, 2.0, 3.0], "intensity": 10.0},
             "env": {"type": "constant", "radiance": 0.2}}
    if case == "materials":
        camera = {"type": "conic", "lens": "disc", "fov": 39.34393771573857,
                  "focus_distance": 4.644701971626153, "near_clip": 0.0137,
                  "far_clip": 48.28556444861665, "aperture_radius": 0.0123, "to_world": _look()}
        scene["ball"]["bsdf"] = {"type": "tutorial", "diffuse": {
            "type": "marble", "octaves": 4, "color0": _rgb(0.8), "color1": _rgb(0.1),
            "stripe_frequency": 3.1 * A, **texture}, "specular": _rgb(0.7),
            "power": 13.7 * A, "reflection": 0.5 * A, "refraction": 0.4 * A, "density": 1.0 + A}
        scene["left"] = {"type": "sphere", "center": [-1.2, 0.0, 0.5], "radius": 0.5,
                         "bsdf": {"type": "diffuse", "reflectance": {
                             "type": "perlin", "scale": 0.5 * A, "offset": 0.5 * A, **texture}}}
        scene["right"] = {"type": "sphere", "center": [1.2, 0.0, 0.5], "radius": 0.5,
                          "bsdf": {"type": "blinnphong", "diffuse_reflectance": {
                              "type": "turbulence", "octaves": 4, "color0": _rgb(0.5),
                              "color1": _rgb(0.1), **texture},
                              "specular_reflectance": _rgb(0.4), "exponent": 31.3 * A}}
        scene["light"] = {"type": "tutorialpoint", "position": [2.0 * A, 2.0, 3.0],
                          "intensity": _rgb(3.0 * A)}
        scene["env"] = {"type": "cubemap", "scale": A, "exposure": 1.3 * A, "to_world": {
            "transform": [["rotate", [0.267261, 0.534522, 0.801784], 37.0]]},
            **{face: f"@sky/sky{face}.exr" for face in rs.FACES}}
    elif case == "tutorial_lens":
        camera = {"type": "conic", "lens": "tutorial", "fov": 39.34393771573857,
                  "focus_distance": 4.644701971626153, "near_clip": 0.0137,
                  "far_clip": 48.28556444861665, "aperture": 0.0123, "to_world": _look()}
    elif case == "tutorialortho":
        camera = {"type": "tutorialortho", "near_clip": 0.0137, "far_clip": 48.28556444861665,
                  "to_world": _look(["scale", [1.37, 1.37, 1.0]])}
    elif case == "noisebump":
        scene["ball"]["bsdf"] = {"type": "noisebump", "bumplevel": A, "frequency": 3.3 * A,
                                 "to_world": place, "nested": scene["ball"]["bsdf"]}
    elif case == "blob":
        scene["ball"] = {"type": "blob", "centers": "-0.3 0.1 0  0.4 -0.1 0.1", "radius": 0.55,
                         "bsdf": scene["ball"]["bsdf"]}
    camera["film"] = {"type": "hdrfilm", "width": 16, "height": 16, "rfilter": {"type": "box"}}
    return {"scene": {**scene, "sensor": camera}, "max_depth": 3}


@pytest.mark.parametrize("case", ["materials", "tutorial_lens", "tutorialortho", "noisebump",
                                  "blob"])
def test_parameter_written_back_leaves_the_render_bit_for_bit(llvm, assets, case):
    """Evidence: the plugins' own render before and after (the round-trip property above on
    fixed scenes whose parameters float32 does not hold exactly): each parameter of our
    plugins written back through ``mi.traverse`` as the value it hands out changes no bit of
    the render."""
    mi = llvm
    spec = _own_value_scene(case)
    scene = rs.load(mi, rs.build(spec, mi, assets))
    params = mi.traverse(scene)
    keys = [key for key, _ in ours(params)]
    assert len(keys) >= 3
    before = deterministic(mi, scene)
    for key in keys:                   # all at once: one more kernel to compile, not one a key
        params[key] = fresh(mi, params[key])
        params.set_dirty(key)
    params.update()
    if not np.array_equal(deterministic(mi, scene), before):
        changed = []                   # which: each alone, on a scene of its own
        for key in keys:
            alone = rs.load(mi, rs.build(spec, mi, assets))
            if not np.array_equal(*_own_value_back(mi, alone, key)):
                changed.append(key)
        assert not changed, "the render changed"
        pytest.fail("the render changed with all parameters written back, with none alone")
