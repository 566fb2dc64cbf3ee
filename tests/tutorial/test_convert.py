"""`codermind convert`: the original tutorial scenes convert and render through Mitsuba; the
converted page-1 (and page-2) images equal the port's strict bytes up to a measured residual;
errors, notes and file names."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from support import run_cli

#: Measured (see test_page1_bytes_match_the_port): 48 of 921,600 bytes differ (339 while
#: Embree chose between tied spheres, 1194 with Mitsuba's spawn offsets, min_distance 0).
PAGE1_MAX_BYTES = 80


def convert(tmp_path: Path, scene: Path, name: str, *options: str) -> Path:
    out = tmp_path / f"{name}.xml"
    result = run_cli("convert", scene, "-o", out, *options)
    assert result.returncode == 0, result.stderr
    return out


def render_tutorial(xml: Path, **defines):
    from codermind.tutorial import render as tr
    scene, settings = tr.load(xml, **defines)
    return tr.render(scene, settings, seed=0)


def port_strict(scene: Path):
    import codermind_ref as ref
    return ref.render(ref.parse_scene(scene), mode="strict")


def test_page1_bytes_match_the_port(llvm, tmp_path, tutorial_dir):
    """The page-1 bytes against the port's strict output (which equals expected.png).

    Measured (the converter's min_distance 0.1, the tutorial's epsilon along the ray; the
    scene's spheres traced by tutorialpath, which keeps the first of two spheres at the same
    t, as the tutorial does): 48 bytes (26 pixels) of 921,600 differ, 11 of them by one
    level (float32 arithmetic in another order). The 20 pixels that differ by more lie on a
    sphere's silhouette (integer pixels exactly on the circle, e.g. (153, 350): a tangent
    ray that the tutorial's float test hits and Mitsuba's misses); none on column x = 320,
    the scene's mirror plane, where a ray hits the two upper spheres at exactly the same t
    (through Embree, Mitsuba's BVH took the other sphere on 99 of them: 339 bytes); none
    elsewhere. With Mitsuba's spawn offsets (min_distance 0) 1194 bytes differed, 700 by
    one level, and 49 pixels in the inter-reflection region between the spheres, where the
    offset moves multi-bounce hit points.
    """
    scene = tutorial_dir / "page1" / "scene.txt"
    res = render_tutorial(convert(tmp_path, scene, "page1"))
    port = port_strict(scene)
    ours = res.image.rgb8
    diff = np.abs(ours.astype(int) - port.rgb8.astype(int))
    assert ours.shape == (480, 640, 3)
    assert 0 < (diff > 0).sum() <= PAGE1_MAX_BYTES
    assert (diff == 1).sum() <= 25
    ys, xs = np.nonzero(diff.max(-1) > 1)
    ty = 479 - ys
    edge = np.min([np.abs(np.hypot(xs - s.center[0], ty - s.center[1]) - s.size)
                   for s in port.scene.spheres], axis=0)
    tie = xs == 320
    silhouette = (edge < 1) & ~tie
    rest = ~tie & ~silhouette
    assert tie.sum() == 0 and silhouette.sum() <= 25 and rest.sum() <= 5
    # the TGA layout is the original's (the port's writer, same pixels)
    from codermind.tutorial.image import tga_bytes
    from codermind_ref import tga
    assert tga_bytes(port.rgb8) == tga.encode(port.rgb8_tga)
    # and the linear radiance agrees to float32 rounding on most pixels
    rel = np.abs(res.linear - port.linear) / np.maximum(port.linear, 1e-3)
    assert np.median(rel[port.linear > 0.05]) < 1e-6


def test_page2_bytes_match_the_port(llvm, tmp_path, tutorial_dir):
    """Page 2 (2x2 sub-samples, exposure, sRGB, strip): measured 67 differing bytes of
    921,600 (14 by one level; 25 pixels by more, none on the tie column x = 320), the same
    causes as page 1 (412 bytes while Embree chose between tied spheres; 1551 bytes, 757 by
    one level, with Mitsuba's spawn offsets)."""
    scene = tutorial_dir / "page2" / "scene.txt"
    res = render_tutorial(convert(tmp_path, scene, "page2"))
    port = port_strict(scene)
    diff = np.abs(res.image.rgb8.astype(int) - port.rgb8.astype(int))
    assert res.linear.shape == (960, 1280, 3)
    assert 0 < (diff > 0).sum() <= 100 and (diff == 1).sum() <= 30
    assert (diff.max(-1) > 1)[:, 320].sum() == 0        # the tie column: the first sphere
    assert (diff[-10:] == 0).all()          # the calibration strip


def test_page4_converts_and_renders(llvm, tmp_path, tutorial_dir):
    pytest.importorskip("codermind.shapes.blob")
    out = tmp_path / "sub" / "page4.xml"
    out.parent.mkdir()
    result = run_cli("convert", tutorial_dir / "page4" / "scene.txt", "-o", out)
    assert result.returncode == 0, result.stderr
    text = out.read_text()
    # faces named relative to the XML's folder, and found from there
    assert re.search(r'name="up" value="\.\./[^"]*page4/alpup\.tga"', text)
    res = render_tutorial(out, blob0_max_error=0.5)
    assert res.linear.shape == (960, 1280, 3) and np.isfinite(res.linear).all()
    assert 1.5 < res.exposure < 3.0      # the port's page-4 exposure is about 2.2
    assert 60 < res.image.rgb8.mean() < 200


def test_page4_without_blob_agrees_with_the_port_in_expectation(llvm, tmp_path, tutorial_dir):
    """Lens, roulette, textures, bump and sky against the port's clean mode: per-sub-sample
    z-test of the linear radiance (every 8th pixel, 16 rays each side, same exposure)."""
    import codermind_ref as ref
    folder = tmp_path / "scene"
    shutil.copytree(tutorial_dir / "page4", folder)
    text = (folder / "scene.txt").read_text().replace("NumberOfBlobs = 1", "NumberOfBlobs = 0")
    (folder / "scene.txt").write_text(text)
    from codermind.tutorial import render as tr
    scene, settings = tr.load(convert(tmp_path, folder / "scene.txt", "p4"))
    res = tr.render(scene, settings, spp=16, seed=3, variance=True)
    port = ref.render(ref.parse_scene(folder / "scene.txt"), mode="clean", seed=3, complexity=16,
                      stride=8, exposure=res.exposure)
    h, w = len(port.ys), len(port.xs)
    rows = [2 * 480 - 1 - (2 * y + b) for y in port.ys for b in (0, 1)]
    cols = [2 * x + a for x in port.xs for a in (0, 1)]
    port_rows = [2 * h - 1 - (2 * j + b) for j in range(h) for b in (0, 1)]
    ours, var = res.linear[rows][:, cols], res.variance[rows][:, cols]
    theirs, their_var = port.linear[port_rows], port.variance[port_rows]
    z = (ours - theirs) / np.sqrt(var + their_var + 1e-12)
    assert abs(np.mean(z)) < 0.05
    assert 0.9 < np.std(z) < 1.15
    assert (np.abs(z) > 5).mean() < 1e-3


def test_parse_error_is_one_line_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text("Scene\n{\n  Version.Major = 1;\n  Version.Minor = 0\n}\n")
    result = run_cli("convert", bad, "-o", tmp_path / "bad.xml")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1
    assert re.match(r"codermind: error: .*bad\.txt:\d+: ", result.stderr)
    assert not (tmp_path / "bad.xml").exists()


def test_version_1_2_is_refused_with_a_hint(tmp_path):
    scene = tmp_path / "p3.txt"
    scene.write_text("Scene { Version.Major = 1; Version.Minor = 2; }\n")
    result = run_cli("convert", scene, "-o", tmp_path / "p3.xml")
    assert result.returncode == 2 and "p3.txt:1:" in result.stderr and "1.3" in result.stderr


def test_what_mitsuba_cannot_express_names_the_line(tmp_path):
    scene = tmp_path / "s.txt"
    scene.write_text("Scene { Version.Major = 1; Version.Minor = 0; NumberOfMaterials = 1;\n"
                     "NumberOfSpheres = 1; }\nMaterial0 {\n Diffuse = 1;\n Reflection = 1.5;\n}\n"
                     "Sphere0 { Center = 1, 2, 3; Size = 4; }\n")
    result = run_cli("convert", scene, "-o", tmp_path / "s.xml")
    assert result.returncode == 2
    assert "s.txt:5: Reflection = 1.5" in result.stderr


def test_unfaithful_things_are_listed_and_warned(tmp_path, tutorial_dir):
    folder = tmp_path / "scene"
    shutil.copytree(tutorial_dir / "page4", folder)
    text = (folder / "scene.txt").read_text()
    text = text.replace("Perspective.Type = conic;", "")
    text = text.replace("Center2 = 250.0, 140.0, 400.0;", "")
    (folder / "scene.txt").write_text(text)
    out = tmp_path / "s.xml"
    result = run_cli("convert", folder / "scene.txt", "-o", out)
    assert result.returncode == 0, result.stderr
    xml = out.read_text()
    header = xml.split("-->")[0]
    for needle in ("orthographic mode", "Center2 not set", "SQUARED distance",
                   "auto exposure traces", "applies it twice"):
        assert needle in header
        assert needle in result.stderr
    assert "warning:" in result.stderr                     # the parser's own warning
    assert '<point name="center2" x="0" y="0" z="0"/>' in xml
    assert 'type="tutorialortho" id="camera"' in xml and 'z="-10000"' in xml


def test_every_element_names_its_source_line(tmp_path, tutorial_dir):
    out = convert(tmp_path, tutorial_dir / "page2" / "scene.txt", "p2")
    xml = out.read_text()
    assert "<!-- Material1 (scene.txt:" in xml
    assert '<float name="power" value="60"/>  <!-- Power, line' in xml
    assert "<!-- codermind-tutorial: page=2 width=640 height=480 lights=sum -->" in xml
    for tag in ("<shape", "<emitter", "<bsdf", "<sensor", "<integrator"):
        for line in xml.splitlines():
            if line.strip().startswith(tag):
                assert "<!--" in line, line


def test_probe_rays_are_the_tutorials(llvm, tmp_path, tutorial_dir):
    """The probes sensor of a converted page-4 scene gives facts.md F6.3's rays: from (W/2, H/2, 0)
    towards normalize((x - W/2)/PD, (y - H/2)/PD, 1) for x, y = i s, j s (past the top)."""
    import mitsuba as mi
    from codermind.tutorial import render as tr
    from codermind.tutorial.image import probe_film_positions, probe_positions
    folder = tmp_path / "scene"
    shutil.copytree(tutorial_dir / "page4", folder)
    text = (folder / "scene.txt").read_text().replace("NumberOfBlobs = 1", "NumberOfBlobs = 0")
    (folder / "scene.txt").write_text(text)
    scene, settings = tr.load(convert(tmp_path, folder / "scene.txt", "p4"))
    sensor = tr.probe_sensor(scene, settings)
    film = probe_film_positions(640, 480)
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(film[:, 0], film[:, 1]), mi.Point2f(0, 0))
    o, d = np.array(ray.o).T, np.array(ray.d).T
    xy = probe_positions(640, 480)
    pd = 320 / np.tan(np.radians(45))
    want = np.stack([(xy[:, 0] - 320) / pd, (xy[:, 1] - 240) / pd, np.ones(256)], axis=1)
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    assert np.allclose(o, [320, 240, 0], atol=1e-4)
    assert np.allclose(d, want, atol=2e-6)
    assert xy[:, 1].max() == 600 and float(np.array(ray.maxt)[0]) == pytest.approx(2000)


def test_page4_orthographic_mode_shows_one_texel(llvm, tmp_path, tutorial_dir):
    """Without Perspective.Type = conic the original's rays start at z = -10000 and reach
    t = 2000: every pixel is the cube-map texel straight ahead; its probes (z = -1000) see the
    objects, so the exposure is not the sky's."""
    folder = tmp_path / "scene"
    shutil.copytree(tutorial_dir / "page4", folder)
    text = (folder / "scene.txt").read_text().replace("Perspective.Type = conic;", "")
    text = text.replace("NumberOfBlobs = 1", "NumberOfBlobs = 0")
    (folder / "scene.txt").write_text(text)
    from codermind.tutorial import render as tr
    scene, settings = tr.load(convert(tmp_path, folder / "scene.txt", "ortho"))
    res = tr.render(scene, settings, seed=0)
    rgb8 = res.image.rgb8[:-10]
    assert (rgb8 == rgb8[0, 0]).all()
    sky = tr.render(scene, settings, seed=0, exposure="render").exposure
    assert res.exposure != pytest.approx(sky, rel=0.01)
