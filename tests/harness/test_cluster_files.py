"""What travels to cluster workers: only the files inside a scene's folder, or inside a folder
the user allows (``--allow-files``). A scene that names a file elsewhere (``/etc/passwd`` as
a cube face) is refused in one line naming the scene's file and line, before anything is
sent. Evidence: the refusal itself (no rendering involved)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from support import run_cli
from support.port_scenes import write_cubemap, write_scene

from codermind_harness.bundle import Bundle, OutsideError
from codermind_harness.runner import RemoteRunner

XML = """<scene version="3.0.0">
    <emitter type="envmap">
        <string name="filename" value="{face}"/>
    </emitter>
</scene>
"""


def test_a_file_outside_the_xml_folder_is_refused_with_its_line(tmp_path):
    xml = tmp_path / "s.xml"
    xml.write_text(XML.format(face="/etc/passwd"))
    with pytest.raises(OutsideError) as e:
        Bundle.of(xml)
    assert f"{xml}:3: /etc/passwd is outside the scene's folder" in str(e.value)
    assert "--allow-files" in str(e.value)


def test_a_link_inside_the_folder_to_a_file_outside_is_refused(tmp_path):
    (tmp_path / "faces").mkdir()
    os.symlink("/etc/passwd", tmp_path / "faces" / "up.exr")
    xml = tmp_path / "s.xml"
    xml.write_text(XML.format(face="faces/up.exr"))
    with pytest.raises(OutsideError):
        Bundle.of(xml)


def test_files_inside_the_folder_or_an_allowed_one_travel(tmp_path):
    (tmp_path / "scene").mkdir()
    (tmp_path / "shared").mkdir()
    (tmp_path / "scene" / "a.exr").write_bytes(b"A")
    (tmp_path / "shared" / "b.exr").write_bytes(b"B")
    xml = tmp_path / "scene" / "s.xml"
    xml.write_text(XML.format(face="a.exr"))
    assert [data for _, data in Bundle.of(xml).files] == [b"A"]
    xml.write_text(XML.format(face="../shared/b.exr"))
    with pytest.raises(OutsideError):
        Bundle.of(xml)
    assert [data for _, data in Bundle.of(xml, allow=[tmp_path / "shared"]).files] == [b"B"]


def _page4_with_outside_faces(tmp_path):
    (tmp_path / "faces").mkdir()
    (tmp_path / "scene").mkdir()
    keys = write_cubemap(tmp_path / "faces").replace("= ", "= ../faces/")
    return write_scene(tmp_path / "scene", "1.3", "Image.Width = 4;\nImage.Height = 4;\n" + keys,
                       "")


def test_the_port_job_refuses_cube_faces_outside_the_scene_folder(tmp_path):
    import codermind_ref as ref
    path = _page4_with_outside_faces(tmp_path)
    scene = ref.parse_scene(path)
    runner = RemoteRunner()
    with pytest.raises(OutsideError) as e:
        ref.render(scene, "clean", 0, 1, tile_map=runner.tile_map)
    assert f"{path}:" in str(e.value) and "up.tga is outside the scene's folder" in str(e.value)
    allowed = RemoteRunner(allow=[tmp_path / "faces"])
    image = ref.render(scene, "clean", 0, 1, tile_map=allowed.tile_map)
    assert np.isfinite(image.linear).all()


@pytest.mark.skipif(not __import__("importlib").util.find_spec("distributed"),
                    reason="needs the cluster extra")
def test_reference_on_a_cluster_refuses_faces_outside_the_scene_folder_in_one_line(tmp_path):
    path = _page4_with_outside_faces(tmp_path)
    r = run_cli("reference", path, "-o", tmp_path / "o", "--cluster", "local:1", cwd=tmp_path,
                timeout=120)
    assert r.returncode == 2, r.stderr
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("codermind: error:")]
    assert len(errors) == 1 and "outside the scene's folder" in errors[0], r.stderr
    assert "Traceback" not in r.stderr
    assert not list(tmp_path.glob("o*"))
