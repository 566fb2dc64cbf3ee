"""The port's scene parser (facts.md F1): syntax, defaults, errors with file:line, warnings."""

from __future__ import annotations

import numpy as np
import pytest

from codermind_ref import SceneError, parse_scene
from codermind_ref import cnumbers


def scene_file(tmp_path, body: str, version: str = "1.1", scene_keys: str = "", name="s.txt"):
    major, minor = version.split(".")
    text = (f"Scene {{\n  Version.Major = {major};\n  Version.Minor = {minor};\n{scene_keys}}}\n"
            + body)
    path = tmp_path / name
    path.write_text(text)
    return path


ONE_SPHERE = """
Material0 { Diffuse = 1, 0.5, 0.25; Reflection = 0.5; }
Sphere0 { Center = 1, 2, 3; Size = 4; Material.Id = 0; }
Light0 { Position = 5, 6, 7; Intensity = 2; }
"""
COUNTS = "NumberOfMaterials = 1;\nNumberOfSpheres = 1;\nNumberOfLights = 1;\n"


def test_tutorial_scenes_parse_without_warnings(tutorial_dir):
    for page, version in ((1, (1, 0)), (2, (1, 1)), (4, (1, 3))):
        scene = parse_scene(tutorial_dir / f"page{page}" / "scene.txt")
        assert scene.page == page and scene.version == version
        assert scene.warnings == []
    scene = parse_scene(tutorial_dir / "page4" / "scene.txt")
    assert scene.camera.fov == 90.0 and scene.camera.type == "conic"     # "90.0f" reads as 90
    assert scene.camera.clear_point == 450.0 and scene.camera.dispersion == 10.0
    assert (scene.tonemap.midpoint, scene.tonemap.power, scene.tonemap.black) == (0.7, 3.0, 0.1)
    assert scene.cubemap.exposed and scene.cubemap.srgb and scene.cubemap.exposure == 1.0
    assert scene.cubemap.faces["Up"].shape == (512, 512, 3)
    assert [m.type for m in scene.materials] == ["turbulence", "gouraud", "marble", "gouraud"]
    assert scene.blobs[0].centers[2] == (250.0, 140.0, 400.0) and scene.blobs[0].size == 80.0


def test_values_and_source_lines(tmp_path):
    scene = parse_scene(scene_file(tmp_path, ONE_SPHERE, scene_keys=COUNTS))
    m, s, light = scene.materials[0], scene.spheres[0], scene.lights[0]
    assert m.diffuse == (1.0, 0.5, 0.25) and m.reflection == 0.5
    assert s.center == (1.0, 2.0, 3.0) and s.size == 4.0 and s.material_id == 0
    assert light.position == (5.0, 6.0, 7.0)
    assert light.intensity == (2.0, 2.0, 2.0)                  # a scalar colour is s,s,s
    assert scene.line_of("Sphere0") == 10 and scene.line_of("Scene", "NumberOfLights") == 6
    assert s.section.entries["Size"].value == "4" and s.section.line_of("Size") == 10


def test_defaults(tmp_path):
    body = "Material0 { }\nSphere0 { }\nLight0 { }\n"
    scene = parse_scene(scene_file(tmp_path, body, version="1.3", scene_keys=COUNTS))
    assert (scene.width, scene.height) == (640, 480)
    m, s, light = scene.materials[0], scene.spheres[0], scene.lights[0]
    assert m.diffuse == m.specular == m.diffuse2 == (0.0, 0.0, 0.0)
    assert (m.reflection, m.power, m.bumplevel, m.density, m.refraction) == (0, 0, 0, 0, 0)
    assert m.type == "gouraud" and s.center == (0.0, 0.0, 0.0) and s.size == 0.0
    assert light.position == light.intensity == (0.0, 0.0, 0.0)
    assert scene.camera.type == "orthographic" and scene.camera.fov == 45.0
    assert scene.camera.clear_point == 1.0 and scene.camera.dispersion == 0.0
    assert (scene.tonemap.midpoint, scene.tonemap.power, scene.tonemap.black) == (0.6, 3.0, 0.1)
    assert scene.complexity == 1 and scene.cubemap.faces is None
    assert not scene.cubemap.exposed and scene.cubemap.exposure == 1.0
    # page 4's orthographic mode is broken (facts.md F13): said in a warning
    assert any("Perspective.Type" in w for w in scene.warnings)


def test_whitespace_comments_first_value_wins(tmp_path):
    body = ("Material0 {\n  Diffuse = 0 .2 5 , 0.5,\t1 ; // comment ; } {\n"
            "  Reflection = 0.25;\n  Reflection = 0.75;\n}\n"
            "Spher\ne0 { Cen ter = 1,2,3; Size = 1 0; }\nLight0 { }\n")
    scene = parse_scene(scene_file(tmp_path, body, scene_keys=COUNTS))
    assert scene.materials[0].diffuse == (0.25, 0.5, 1.0)
    assert scene.materials[0].reflection == 0.25                # first value wins
    assert scene.spheres[0].center == (1.0, 2.0, 3.0) and scene.spheres[0].size == 10.0
    assert any(":11: 'Reflection' repeated" in w and "line 10" in w for w in scene.warnings)


def test_number_reading_like_atof_atol():
    assert cnumbers.read_float("90.0f") == (90.0, None)
    assert cnumbers.read_float("1e3") == (1000.0, None)
    assert cnumbers.read_float("abc")[0] == 0.0 and cnumbers.read_float("abc")[1]
    assert cnumbers.read_float("1.5x") [0] == 1.5 and cnumbers.read_float("1.5x")[1]
    assert cnumbers.read_int("640") == (640, None)
    assert cnumbers.read_int("640.9")[0] == 640 and cnumbers.read_int("640.9")[1]
    assert cnumbers.read_bool("true") == (True, None)
    assert cnumbers.read_bool("True")[0] is False and cnumbers.read_bool("True")[1]
    assert cnumbers.read_colour("0.5") == ((0.5, 0.5, 0.5), None)
    assert cnumbers.read_colour("0.1,0.2,0.3") == ((0.1, 0.2, 0.3), None)
    assert cnumbers.read_colour("0.5,0.7")[0] == (0.5, 0.5, 0.5)      # not 3 numbers: scalar
    assert cnumbers.read_point("1,2")[0] == (0.0, 0.0, 0.0)            # points need 3
    assert cnumbers.read_point("1,2")[1]


def test_warnings_unknown_keys_sections_numbers(tmp_path):
    body = (ONE_SPHERE.replace("Reflection = 0.5;", "Reflection = 0.5; Specular = 1;")
            .replace("Size = 4;", "Size = 4x; Colour = 1;")
            + "Sphere1 { Size = 1; }\nCamera { Fov = 3; }\nBlob0 { Size = 1; }\n")
    scene = parse_scene(scene_file(tmp_path, body, version="1.0", scene_keys=COUNTS))
    text = "\n".join(scene.warnings)
    assert "s.txt:9: unknown key 'Specular' in section 'Material0'" in text  # not a 1.0 key
    assert "s.txt:10: unknown key 'Colour'" in text
    assert "s.txt:10: Size: '4x' is not a clean number; read as 4" in text
    assert "s.txt:12: section 'Sphere1' is beyond NumberOfSpheres = 1" in text
    assert "s.txt:13: unknown section 'Camera'" in text
    assert "s.txt:14: unknown section 'Blob0'" in text                   # no blobs in 1.0
    assert scene.spheres[0].size == 4.0 and len(scene.spheres) == 1      # values unchanged
    assert len(scene.warnings) == 6


@pytest.mark.parametrize("body, line, message", [
    ("Material0 { Diffuse = 1 }\n", 5, "missing ';' after 'Diffuse = 1'"),
    ("Material0 {\n Diffuse = 1;\n Power = 2\n Reflection = 1;\n}\n", 7,
     "missing ';' after 'Power = 2Reflection'"),
    ("Material0 { Diffuse = 1;\n", 5, "not closed (missing '}')"),
    ("Material0 { = 1; }\n", 5, "empty key"),
    ("Material0 { Diffuse = ; }\n", 5, "empty value for 'Diffuse'"),
    ("Material0 { Diffuse; }\n", 5, "expected 'Key = value;'"),
    ("Material0 { }\n\nMaterial0 { }\n", 7, "duplicate section 'Material0' (first at line 5)"),
    ("Diffuse = 1;\n", 5, "expected 'Name { ... }' at top level"),
])
def test_syntax_errors(tmp_path, body, line, message):
    path = scene_file(tmp_path, body)
    with pytest.raises(SceneError) as e:
        parse_scene(path)
    assert e.value.line == line and message in e.value.message
    assert str(e.value).startswith(f"{path}:{line}: ")


@pytest.mark.parametrize("version, keys, body, line, message", [
    ("1.2", "", "", 3, "version 1.2 (page 3) is not supported"),
    ("2.0", "", "", 3, "does not match a tutorial program"),
    ("1.1", "NumberOfSpheres = 2;\n", "Sphere0 { }\n", 4, "no section 'Sphere1'"),
    ("1.1", "NumberOfMaterials = 1;\nNumberOfSpheres = 1;\n",
     "Material0 { }\nSphere0 {\n Material.Id = 1;\n}\n", 9, "Material.Id = 1 is out of range"),
    ("1.1", "NumberOfSpheres = 1;\n", "Sphere0 { }\n", 6, "Material.Id = 0 is out of range"),
    ("1.3", "Perspective.FOV = 189;\n", "", 4, "Perspective.FOV must be > 0 and < 189"),
    ("1.3", "Perspective.FOV = 0;\n", "", 4, "Perspective.FOV must be > 0"),
    ("1.3", "Tonemap.Midpoint = 1;\n", "", 4, "Tonemap.Midpoint must be strictly between 0 and 1"),
    ("1.3", "Tonemap.Power = 1.5;\n", "", 4, "Tonemap.Power must be >= 2"),
    ("1.3", "Complexity = 0;\n", "", 4, "Complexity must be >= 1"),
    ("1.3", "Cubemap.Down = nothere.tga;\n", "", 1, "Cubemap.Up is not set but other"),
    ("1.1", "Image.Width = 0;\n", "", 4, "Image.Width must be >= 1"),
])
def test_scene_errors(tmp_path, version, keys, body, line, message):
    path = scene_file(tmp_path, body, version=version, scene_keys=keys)
    with pytest.raises(SceneError) as e:
        parse_scene(path)
    assert e.value.line == line, str(e.value)
    assert message in e.value.message


def test_missing_scene_section_and_file(tmp_path):
    path = tmp_path / "empty.txt"
    path.write_text("// nothing\n")
    with pytest.raises(SceneError, match=r"empty.txt:1: no 'Scene' section"):
        parse_scene(path)
    with pytest.raises(SceneError, match=r"absent.txt:1: cannot read the scene file"):
        parse_scene(tmp_path / "absent.txt")


def _face(path, size=4, value=(10, 20, 30), kind=2, bpp=24, id_length=0):
    header = bytes([id_length, 0, kind, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                    size & 255, size >> 8, size & 255, size >> 8, bpp, 0])
    pixels = np.zeros((size, size, 3), np.uint8)
    pixels[:] = value[::-1]
    path.write_bytes(header + pixels.tobytes())


FACE_KEYS = "".join(f"Cubemap.{f} = {f.lower()}.tga;\n"
                    for f in ("Up", "Down", "Right", "Left", "Forward", "Backward"))


def test_cubemap_faces_load_relative_to_scene(tmp_path):
    for f in ("up", "down", "right", "left", "forward", "backward"):
        _face(tmp_path / f"{f}.tga")
    scene = parse_scene(scene_file(tmp_path, "", version="1.3",
                                   scene_keys="Perspective.Type = conic;\n" + FACE_KEYS))
    assert scene.warnings == []
    assert np.allclose(scene.cubemap.faces["Left"][0, 0], np.array([10, 20, 30]) / 255)
    assert scene.cubemap.paths["Up"] == tmp_path / "up.tga"


@pytest.mark.parametrize("face, kwargs, message", [
    ("left", None, "cube-map face not found"),
    ("left", {"kind": 10}, "TGA image type 10"),
    ("left", {"bpp": 32}, "32 bits per pixel"),
    ("left", {"size": 2}, "but the Up face is 4x4"),
    ("left", {"id_length": 3}, "image-ID field"),
])
def test_cubemap_face_errors(tmp_path, face, kwargs, message):
    for f in ("up", "down", "right", "left", "forward", "backward"):
        if f != face:
            _face(tmp_path / f"{f}.tga")
        elif kwargs is not None:
            _face(tmp_path / f"{f}.tga", **kwargs)
    path = scene_file(tmp_path, "", version="1.3",
                      scene_keys="Perspective.Type = conic;\n" + FACE_KEYS)
    with pytest.raises(SceneError) as e:
        parse_scene(path)
    assert e.value.line == 8 and "Cubemap.Left" in e.value.message   # the Left key's line
    assert message in e.value.message


def test_nested_block_is_ignored_with_a_warning(tmp_path):
    body = ("Material0 {\n Diffuse = 0.5;\n Inner { Diffuse = 1; }\n Reflection = 0.25;\n}\n"
            "Sphere0 { }\nLight0 { }\n")
    scene = parse_scene(scene_file(tmp_path, body, scene_keys=COUNTS))
    assert scene.materials[0].diffuse == (0.5, 0.5, 0.5) and scene.materials[0].reflection == 0.25
    assert scene.warnings == [f"{tmp_path / 's.txt'}:10: nested block 'Inner' in section "
                              "'Material0' is not supported (the original mangles its keys); ignored"]


def test_material_types(tmp_path):
    body = "".join(f"Material{i} {{ Type = {t}; }}\n"
                   for i, t in enumerate(("turbulence", "marble", "noise", "Marble", "gouraud")))
    scene = parse_scene(scene_file(tmp_path, body, version="1.3",
                                   scene_keys="Perspective.Type = conic;\nNumberOfMaterials = 5;\n"))
    assert [m.type for m in scene.materials] == ["turbulence", "marble", "noise", "gouraud", "gouraud"]
    assert scene.materials[3].type_text == "Marble"        # case-sensitive: unknown is gouraud
