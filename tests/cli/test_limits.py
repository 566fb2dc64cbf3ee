"""Limits checked before work starts (codermind_cli.limits): absurd sizes refused within a few
seconds in one line without a traceback, --workers capped, --spp 2^32 planned without a loop
over every integer, a cube-map face whose header claims more than its file holds refused
before it is read."""

from __future__ import annotations

import time

import pytest

from support import ROOT, run_cli

SMALL = """Scene { Version.Major = 1; Version.Minor = %s; Image.Width = %d; Image.Height = %d;
NumberOfMaterials = 1; NumberOfSpheres = 1; NumberOfLights = 1; %s }
Material0 { Diffuse = 1, 1, 1; Reflection = 0.5; }
Sphere0 { Center = 4, 4, 0; Size = 2; Material.Id = 0; }
Light0 { Position = 0, 4, -10; Intensity = 1, 1, 1; }
"""


def one_line_refusal(r, text):
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert text in lines[0], lines[0]


@pytest.mark.parametrize("args, text", [
    (("--workers", "100000"), "argument --workers: must be in [1, "),
    (("--complexity", "1000000000000"), "GiB, more than the"),
])
def test_reference_refuses_runaway_requests(tmp_path, args, text):
    scene = tmp_path / "s.txt"
    scene.write_text(SMALL % ("3", 8, 8, "Perspective.Type = conic;"))
    t0 = time.monotonic()
    r = run_cli("reference", scene, "-o", tmp_path / "o", *args, cwd=tmp_path)
    assert time.monotonic() - t0 < 30
    one_line_refusal(r, text)
    assert not (tmp_path / "o.tga").exists()


def test_reference_refuses_huge_image(tmp_path):
    scene = tmp_path / "s.txt"
    scene.write_text(SMALL % ("1", 100000, 100000, ""))
    r = run_cli("reference", scene, "-o", tmp_path / "o", cwd=tmp_path, timeout=60)
    one_line_refusal(r, "100000x100000 pixels at complexity 1 needs about")


def test_memory_limit_is_raised_by_the_environment(tmp_path):
    scene = tmp_path / "s.txt"
    scene.write_text(SMALL % ("1", 8, 8, ""))
    r = run_cli("reference", scene, "-o", tmp_path / "o", cwd=tmp_path,
                env={"CODERMIND_MAX_MEMORY": "0.01"})
    one_line_refusal(r, "allowed (CODERMIND_MAX_MEMORY=0.01)")


def test_render_refuses_huge_film_and_spp(tmp_path):
    xml = tmp_path / "plain.xml"
    xml.write_text("""<scene version="3.0.0"><default name="w" value="8"/>
<integrator type="path"/><sensor type="perspective"><film type="hdrfilm">
<integer name="width" value="$w"/><integer name="height" value="$w"/></film></sensor></scene>""")
    t0 = time.monotonic()
    r = run_cli("render", xml, "-D", "w=100000", "-o", tmp_path / "o", cwd=tmp_path)
    one_line_refusal(r, "rendering 100000x100000 pixels at 4 spp needs about")
    r = run_cli("render", xml, "--spp", "1000000000000", "-o", tmp_path / "o", cwd=tmp_path)
    one_line_refusal(r, "would take about")
    assert time.monotonic() - t0 < 120


def test_sampler_plan_of_2_pow_32_does_not_stall():
    from codermind.passes import divisors_of, sampler_plan
    from codermind.variants import set_variant
    set_variant("scalar_rgb")
    import mitsuba as mi
    t0 = time.monotonic()
    assert divisors_of(2 ** 32) == [2 ** k for k in range(33)]
    sampler = mi.load_dict({"type": "stratified", "sample_count": 4})
    plan = sampler_plan(sampler, 2 ** 32, 1 << 20)
    assert sum(plan) == 2 ** 32 and time.monotonic() - t0 < 60


def test_cube_face_header_checked_before_reading(tmp_path):
    from codermind_ref.tga import TgaError, read_face
    face = tmp_path / "face.tga"
    header = bytearray(18)
    header[2], header[16] = 2, 24
    header[12:16] = (0x7f, 0x7f, 0x7f, 0x7f)          # 32639 x 32639: claims 3.2 GB
    face.write_bytes(bytes(header) + b"\0" * 30)
    with pytest.raises(TgaError, match="more than the"):
        read_face(face)
    header[12:16] = (0x10, 0x00, 0x10, 0x00)          # 16 x 16 claims 768 bytes, has 30
    face.write_bytes(bytes(header) + b"\0" * 30)
    with pytest.raises(TgaError, match="truncated"):
        read_face(face)


def test_max_memory_option_lowers_and_raises_the_limit(tmp_path):
    scene = tmp_path / "s.txt"
    scene.write_text(SMALL % ("1", 8, 8, ""))
    r = run_cli("reference", scene, "-o", tmp_path / "o", "--max-memory", "0.01", cwd=tmp_path)
    one_line_refusal(r, "allowed (--max-memory 0.01)")
    r = run_cli("reference", scene, "-o", tmp_path / "o", "--max-memory", "4", cwd=tmp_path,
                env={"CODERMIND_MAX_MEMORY": "0.01"})
    assert r.returncode == 0, r.stderr          # the option wins over the environment
