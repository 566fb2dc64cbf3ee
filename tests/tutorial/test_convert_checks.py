"""The converter's own finite-value check (codermind.tutorial.finite), independent of the
port's parser: a parsed scene whose value is made NaN or infinite is refused with file and
line before any model choice."""

from __future__ import annotations

import math

import pytest

import codermind_ref
from codermind.errors import CodermindError
from codermind.tutorial.convert import convert_scene

TEXT = """Scene { Version.Major = 1; Version.Minor = 1; Image.Width = 8; Image.Height = 8;
NumberOfMaterials = 1; NumberOfSpheres = 1; NumberOfLights = 1; }
Material0 { Diffuse = 1, 1, 1; Reflection = 0.5; Specular = 1, 1, 1; Power = 60; }
Sphere0 { Center = 4, 4, 0; Size = 2; Material.Id = 0; }
Light0 { Position = 0, 4, -10; Intensity = 1, 1, 1; }
"""


@pytest.mark.parametrize("change, where", [
    (lambda s: setattr(s.lights[0], "position", (math.nan, 4.0, -10.0)), ":5: Light0.Position"),
    (lambda s: setattr(s.materials[0], "reflection", math.inf), ":3: Material0.Reflection"),
    (lambda s: setattr(s.spheres[0], "size", 1e39), ":4: Sphere0.Size"),
])
def test_convert_refuses_non_finite(tmp_path, change, where):
    path = tmp_path / "s.txt"
    path.write_text(TEXT)
    scene = codermind_ref.parse_scene(path)
    change(scene)
    with pytest.raises(CodermindError) as e:
        convert_scene(scene, None)
    assert str(e.value).startswith(f"{path}{where}: must be finite in float32")
