"""Errors that name their file and line (Mitsuba's own messages for a property given twice,
an invalid version or bytes that are not UTF-8 name neither), and an empty tutorial scene,
which renders black instead of failing inside the integrator."""

from __future__ import annotations

import numpy as np
import pytest

from support import run_cli

XML = """<scene version="{version}">
  <integrator type="path">
    <integer name="max_depth" value="2"/>
    {extra}
  </integrator>
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>
    <integer name="height" value="4"/></film></sensor>
</scene>
"""


@pytest.mark.parametrize("version, extra, line, text", [
    ("3.0.0", '<integer name="max_depth" value="3"/>', 4, "specified multiple times"),
    ("3.0", "", 1, "invalid version number"),
    ("3.0.0", '<string name="note" value="caf\xe9"/>', 4, "not valid UTF-8 (byte 0xe9"),
])
def test_xml_load_errors_name_file_and_line(tmp_path, version, extra, line, text):
    from codermind.errors import CodermindError
    from codermind.scene import load_scene
    from codermind.variants import set_variant
    set_variant("scalar_rgb")
    path = tmp_path / "bad.xml"
    path.write_bytes(XML.format(version=version, extra=extra).encode("latin-1"))
    with pytest.raises(CodermindError) as e:
        load_scene(path)
    assert str(e.value).startswith(f"{path}:{line}: ") and text in str(e.value)


def test_empty_tutorial_scene_renders_black(tmp_path):
    scene = tmp_path / "empty.txt"
    scene.write_text("Scene { Version.Major = 1; Version.Minor = 1; Image.Width = 4;\n"
                     "Image.Height = 4; NumberOfMaterials = 0; }\n")
    r = run_cli("convert", scene, "-o", tmp_path / "empty.xml", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = run_cli("render", tmp_path / "empty.xml", "-o", tmp_path / "out", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "see above" not in r.stderr and "Traceback" not in r.stderr
    import mitsuba as mi
    image = np.array(mi.Bitmap(str(tmp_path / "out.exr")))
    assert np.all(image[..., :3] == 0)
