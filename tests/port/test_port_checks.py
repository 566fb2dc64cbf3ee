"""The port's finite-value check (codermind_ref.checks): a NaN, infinite or float32-overflowing
number is refused with file and line; a finite value outside the plugins' ranges is rendered
(as the original) with a warning line."""

from __future__ import annotations

import pytest

from codermind_ref import SceneError, parse_scene

COUNTS = "NumberOfMaterials = 1;\nNumberOfSpheres = 1;\nNumberOfLights = 1;\n"


def scene_text(material="Diffuse = 1, 0.5, 0.25; Reflection = 0.5;",
               light="Position = 5, 6, 7; Intensity = 2, 2, 2;", sphere="Size = 4;"):
    return (f"Scene {{\n  Version.Major = 1;\n  Version.Minor = 1;\n{COUNTS}}}\n"
            f"Material0 {{ {material} }}\n"
            f"Sphere0 {{ Center = 1, 2, 3; {sphere} Material.Id = 0; }}\n"
            f"Light0 {{\n  {light}\n}}\n")


def write(tmp_path, text):
    path = tmp_path / "s.txt"
    path.write_text(text)
    return path


@pytest.mark.parametrize("kwargs, where, label", [
    (dict(light="Position = nan, 6, 7; Intensity = 2, 2, 2;"), 11, "Light0.Position"),
    (dict(light="Position = 5, 6, 7; Intensity = inf, 2, 2;"), 11, "Light0.Intensity"),
    (dict(material="Diffuse = 1, 1, 1; Reflection = -inf;"), 8, "Material0.Reflection"),
    (dict(material="Diffuse = 1, 1, 1; Reflection = 0; Specular = 1, nan, 1;"), 8,
     "Material0.Specular"),
    (dict(sphere="Size = 1e39;"), 9, "Sphere0.Size"),          # inf in the original's float
])
def test_non_finite_refused_with_file_and_line(tmp_path, kwargs, where, label):
    path = write(tmp_path, scene_text(**kwargs))
    with pytest.raises(SceneError) as e:
        parse_scene(path)
    assert str(e.value).startswith(f"{path}:{where}: {label}: must be finite")
    assert "\n" not in str(e.value)


def test_page4_values_checked(tmp_path):
    text = ("Scene { Version.Major = 1; Version.Minor = 3; NumberOfMaterials = 1;\n"
            "Perspective.Type = conic;\nPerspective.ClearPoint = nan; }\n"
            "Material0 { Diffuse = 1, 1, 1; Bumplevel = 0.5; }\n")
    path = write(tmp_path, text)
    with pytest.raises(SceneError, match=r"s.txt:3: Perspective.ClearPoint: must be finite"):
        parse_scene(path)


def test_out_of_range_rendered_with_a_warning(tmp_path):
    path = write(tmp_path, scene_text(material="Diffuse = 1, -1, 1; Reflection = 2;"))
    scene = parse_scene(path)
    assert scene.materials[0].reflection == 2.0             # the original's value, unchanged
    warnings = [w for w in scene.warnings if "plugins" in w]
    assert any(w.startswith(f"{path}:8: Material0.Reflection = 2 is outside [0, 1]")
               for w in warnings)
    assert any("Material0.Diffuse = 1, -1, 1 has a negative channel" in w for w in warnings)


def test_clean_scene_has_no_range_warning(tmp_path):
    assert parse_scene(write(tmp_path, scene_text())).warnings == []
