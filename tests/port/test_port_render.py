"""The port's renderer against the original output, closed forms and the rules of facts.md."""

from __future__ import annotations

import math

import numpy as np
import pytest

import codermind_ref as ref
from codermind_ref import driver, perlin, png, rng, tga, tonemap, transport
from codermind_ref.world import World
from support import ROOT
from support.port_scenes import uniform_cubemap, write_cubemap, write_scene


def srgb(v):
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def test_page1_strict_is_byte_identical_to_expected_png(tutorial_dir):
    scene = ref.parse_scene(tutorial_dir / "page1" / "scene.txt")
    result = ref.render(scene, "strict", workers=1)
    expected = png.decode((tutorial_dir / "page1" / "expected.png").read_bytes())
    assert result.rgb8.shape == expected.shape == (480, 640, 3)
    assert np.array_equal(result.rgb8, expected)
    # the TGA stores tutorial row y = 0 first: that is the PNG's bottom row
    assert np.array_equal(result.rgb8_tga, expected[::-1])
    data = tga.encode(result.rgb8_tga)
    assert data[:18] == bytes([0, 0, 2] + [0] * 9 + [128, 2, 224, 1, 24, 0])
    assert data[18:21] == bytes(expected[-1, 0, ::-1])          # B, G, R of pixel (0, 0)
    # page 1 has none of the quirks clean removes
    assert np.array_equal(ref.render(scene, "clean", workers=1).rgb8, expected)


def test_page2_and_page4_render_without_warnings(tutorial_dir):
    for page in (2, 4):
        scene = ref.parse_scene(tutorial_dir / f"page{page}" / "scene.txt")
        result = ref.render(scene, workers=1)              # the whole frame, as the original
        assert result.warnings == [] and result.rgb8.shape == (480, 640, 3)
        assert result.linear.shape == (960, 1280, 3) and np.isfinite(result.linear).all()
        assert (result.linear >= 0).all() and result.rgb8[:-10].std() > 20


def _lone_sphere_colour(p, c, r, light, intensity, diffuse, specular, power, d):
    n = (p - c) / r
    ld = light - p
    ld /= np.linalg.norm(ld)
    lambert = ld @ n
    h = (ld - d) / np.linalg.norm(ld - d)
    return lambert * intensity * diffuse + max(n @ h, 0.0) ** power * specular * intensity


def test_page2_lone_sphere_centre_pixel_closed_form(tmp_path):
    c, r = np.array([32.0, 24.0, 0.0]), 20.0
    light, intensity = np.array([10.0, 60.0, -50.0]), np.array([0.9, 1.0, 1.1])
    diffuse, specular, power = np.array([0.6, 0.4, 0.2]), np.array([0.5, 0.5, 0.5]), 20.0
    path = write_scene(tmp_path, "1.1", "Image.Width = 64;\nImage.Height = 48;\nNumberOfMaterials = 1;\n"
                       "NumberOfSpheres = 1;\nNumberOfLights = 1;\n",
                       "Material0 { Diffuse = 0.6, 0.4, 0.2; Specular = 0.5; Power = 20; }\n"
                       "Sphere0 { Center = 32, 24, 0; Size = 20; }\n"
                       "Light0 { Position = 10, 60, -50; Intensity = 0.9, 1.0, 1.1; }\n")
    result = ref.render(ref.parse_scene(path), rect=(32, 24, 33, 25))
    d = np.array([0.0, 0.0, 1.0])
    tone = np.zeros(3)
    for a in (0, 1):
        for b in (0, 1):
            fx, fy = 32 + a / 2, 24 + b / 2
            p = np.array([fx, fy, -math.sqrt(r * r - (fx - 32) ** 2 - (fy - 24) ** 2)])
            colour = _lone_sphere_colour(p, c, r, light, intensity, diffuse, specular, power, d)
            # display order: sub-sample (a, b) of the only pixel sits at row 1 - b, column a
            assert result.linear[1 - b, a] == pytest.approx(colour, rel=2e-6)
            tone += 0.25 * (1 - np.exp(-colour))
    assert result.tonemapped[0, 0] == pytest.approx(tone, rel=1e-5)
    expected = [int(min(255 * srgb(v), 255)) for v in tone]
    assert np.abs(result.rgb8[0, 0].astype(int) - expected).max() <= 1   # float32 vs double
    assert (result.variance == 0).all()


def test_page4_lone_sphere_with_fixed_exposure_closed_form(tmp_path):
    path = write_scene(tmp_path, "1.3", "Image.Width = 64;\nImage.Height = 48;\n"
                       "Perspective.Type = conic;\nPerspective.FOV = 90;\nTonemap.Midpoint = 0.5;\n"
                       "Tonemap.Power = 2.5;\nTonemap.Black = 0.2;\nNumberOfMaterials = 1;\n"
                       "NumberOfSpheres = 1;\nNumberOfLights = 1;\n",
                       "Material0 { Diffuse = 0.6, 0.4, 0.2; Specular = 0.5; Power = 20; }\n"
                       "Sphere0 { Center = 32, 24, 100; Size = 30; }\n"
                       "Light0 { Position = 32, 80, 0; Intensity = 2; }\n")
    scene = ref.parse_scene(path)
    e = 1.7
    result = ref.render(scene, rect=(32, 24, 33, 25), exposure=e, complexity=3)
    c, r = np.array([32.0, 24.0, 100.0]), 30.0
    eye, pd = np.array([32.0, 24.0, 0.0]), 32.0 / math.tan(math.radians(45))
    tone = np.zeros(3)
    tm = scene.tonemap
    n_mid = -math.log(1 - tm.midpoint)
    s = -(1 + tm.black / n_mid ** (tm.power - 1))
    for a in (0, 1):
        for b in (0, 1):
            d = np.array([(32 + a / 2 - 32) / pd, (24 + b / 2 - 24) / pd, 1.0])
            d /= np.linalg.norm(d)
            oc = c - eye
            t = d @ oc - math.sqrt((d @ oc) ** 2 - oc @ oc + r * r)
            colour = _lone_sphere_colour(eye + t * d, c, r, np.array([32.0, 80.0, 0.0]),
                                         np.full(3, 2.0), np.array([0.6, 0.4, 0.2]),
                                         np.full(3, 0.5), 20.0, d)
            assert result.linear[1 - b, a] == pytest.approx(colour, rel=1e-6)
            x = e * colour
            tone += 0.25 * (1 - np.exp(s * x ** tm.power / (tm.black + x ** (tm.power - 1))))
    assert result.exposure == e
    assert result.tonemapped[0, 0] == pytest.approx(tone, rel=1e-12)
    assert result.rgb8[0, 0].tolist() == [int(255 * srgb(v)) for v in tone]
    # no randomness on this path: zero spread (up to the rounding of sum x^2 - (sum x)^2 / n)
    assert np.allclose(result.variance, 0, atol=1e-12)


@pytest.mark.parametrize("midpoint, power, black", [(0.7, 3.0, 0.1), (0.5, 2.0, 0.5),
                                                    (0.2, 4.5, 1.0), (0.6, 3.0, 0.0)])
def test_tone_curve_maps_n_to_midpoint(midpoint, power, black):
    tm = ref.scene.Tonemap(midpoint, power, black)
    n = -math.log(1 - midpoint)
    assert tonemap.curve(np.array([n]), tm)[0] == pytest.approx(midpoint, abs=1e-14)
    assert tonemap.curve(np.array([0.0]), tm)[0] == 0.0
    c = np.linspace(0.01, 5, 50)
    assert np.all(np.diff(tonemap.curve(c, tm)) >= 0)      # monotone
    if black == 0:
        assert np.allclose(tonemap.curve(c, tm), 1 - np.exp(-c))


def test_bytes_truncate_and_clamp():
    v = np.array([0.0, 0.999 / 255, 1 / 255, 0.5, 1.0, 7.0, -0.5 / 255, np.nan])
    assert tonemap.to_bytes(v).tolist() == [0, 0, 1, 127, 255, 255, 0, 0]


def test_calibration_strip_bytes(tutorial_dir):
    for page in (2, 4):
        scene = ref.parse_scene(tutorial_dir / f"page{page}" / "scene.txt")
        result = ref.render(scene, rect=(0, 0, 640, 12), stride=1, exposure=1.0, complexity=1)
        rows = result.rgb8_tga
        for y in range(10):
            for x in (0, 5, 9, 10, 15, 19, 20, 639):
                expected = 186 if (x // 10) % 2 else (255 if y % 2 else 0)
                assert rows[y, x].tolist() == [expected] * 3, (page, x, y)
        assert not np.array_equal(rows[10], tonemap.strip(np.array([10]), result.xs)[0][:, None]
                                  .repeat(3, 1))


def test_perlin_noise_reference_value():
    assert float(perlin.noise(3.14, 42, 7)) == 0.13691995878400012
    assert perlin.noise(np.array([1.0, -3.0]), np.array([2.0, 5.0]), np.array([3.0, 0.0])
                        ).tolist() == [0.0, 0.0]          # zero at lattice points
    x = np.array([3.14, 0.5, -7.25])
    assert perlin.noise(x, 42 + x, 7 - x).tolist() == [
        float(perlin.noise(a, 42 + a, 7 - a)) for a in x]


def _blob_scene(tmp_path, centers):
    keys = "".join(f"Center{i} = {c};\n" for i, c in enumerate(centers))
    return ref.parse_scene(write_scene(
        tmp_path, "1.3", "Perspective.Type = conic;\nNumberOfMaterials = 1;\nNumberOfBlobs = 1;\n",
        f"Material0 {{ }}\nBlob0 {{\n{keys}Size = 80;\n}}\n"))


def test_blob_lone_source_surface_is_radius_R(tmp_path):
    # two sources far away (f = 0 beyond 10 R^2): the surface is f(x) = 1, x = 1, exactly at R;
    # this is the case where the zone bound is exactly 1
    # (clean: the exact zone method in float64; strict sums the polynomial in float32 as the
    # original, whose C ~ |c - o|^2 / R^2 ~ 40 rounds by ~4e-6, i.e. ~2e-4 in t at this slope)
    world = World(_blob_scene(tmp_path, ["0, 0, 500", "5000, 0, 0", "0, 5000, 0"]))
    o, d = np.array([[0.0], [0.0], [0.0]]), np.array([[0.0], [0.0], [1.0]])
    t, obj = world.intersect(o, d, np.array([2000.0]), ref.CLEAN)
    assert obj[0] == 0 and t[0] == pytest.approx(420.0, abs=1e-9)
    t32, obj32 = world.intersect(o, d, np.array([2000.0]), ref.STRICT)
    assert obj32[0] == 0 and t32[0] == pytest.approx(420.0, abs=1e-3)
    n, zero = world.normal(o + t * d, obj)
    assert np.allclose(n[:, 0], [0, 0, -1], atol=1e-5) and not zero[0]  # far sources tilt it


def test_blob_coincident_sources_surface(tmp_path):
    # (clean: exact arithmetic; see the lone-source test for strict's float32 sums)
    # three sources at one point: 3 f(x) = 1 in zone 2 (f = -0.12 x + 0.7): x = (0.7 - 1/3)/0.12
    world = World(_blob_scene(tmp_path, ["0, 0, 500"] * 3))
    x = (0.7 - 1 / 3) / 0.12
    o = np.array([[0.0, 30.0], [0.0, 0.0], [0.0, 0.0]])
    d = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 1.0]])
    t, obj = world.intersect(o, d, np.full(2, 2000.0), ref.CLEAN)
    assert t[0] == pytest.approx(500 - 80 * math.sqrt(x), abs=1e-9)
    assert t[1] == pytest.approx(500 - math.sqrt(80 ** 2 * x - 30 ** 2), abs=1e-9)
    # a ray starting inside finds the exit, a shadow ray shorter than that finds nothing
    inside = np.array([[0.0], [0.0], [480.0]])
    assert world.intersect(inside, d[:, :1], np.array([2000.0]), ref.CLEAN)[0][0] == pytest.approx(
        20 + 80 * math.sqrt(x), abs=1e-9)
    assert not world.occluded(inside, d[:, :1], np.array([100.0]), ref.CLEAN)[0]
    assert world.occluded(inside, d[:, :1], np.array([200.0]), ref.CLEAN)[0]


def test_cubemap_faces_and_texel_fetch(tmp_path):
    keys = write_cubemap(tmp_path)
    scene = ref.parse_scene(write_scene(tmp_path, "1.3", "Perspective.Type = conic;\n" + keys, ""))
    env = World(scene).environment
    dirs = np.array([[0, 1, 0], [0, -1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1],
                     [1, 1, 0], [0, 1, 1], [1, 0, 1]], dtype=float).T
    got = env.lookup(dirs) * 255
    expected = [(200, 10, 10), (10, 200, 10), (10, 10, 200), (200, 200, 10), (10, 200, 200),
                (200, 10, 200), (10, 10, 200), (200, 10, 10), (10, 10, 200)]  # ties: x, y, z
    assert np.allclose(got.T, expected)
    # no half-texel offset: u = v = 0.5 on a 2x2 face is texel (1, 1); u = 0.25 mixes 0 and 1
    forward = scene.cubemap.faces["Forward"]
    forward[:] = np.arange(12).reshape(2, 2, 3) / 255
    centre = env.__class__(scene.cubemap).lookup(np.array([[0.0], [0.0], [1.0]]))
    assert np.allclose(centre[:, 0] * 255, [9, 10, 11])
    quarter = env.__class__(scene.cubemap).lookup(np.array([[-0.5], [0.0], [1.0]]))
    assert np.allclose(quarter[:, 0] * 255, [7.5, 8.5, 9.5])   # row 1, halfway cols 0 and 1


def test_cubemap_radiance_transforms(tmp_path):
    keys = uniform_cubemap(tmp_path, (128, 64, 255))
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Perspective.Type = conic;\nCubemap.sRGB = true;\nCubemap.Exposed = true;\n"
        "Cubemap.Exposure = 2;\n" + keys, ""))
    got = World(scene).environment.lookup(np.array([[0.3], [0.2], [0.9]]))[:, 0]
    c = np.array([128, 64, 255]) / 255
    assert np.allclose(got, -np.log(1.001 - c ** 2.2) / 2, rtol=1e-12)


def test_page4_auto_exposure_uniform_sky(tmp_path):
    keys = uniform_cubemap(tmp_path, (100, 150, 200))
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Image.Width = 32;\nImage.Height = 24;\nPerspective.Type = conic;\n"
        "Tonemap.Midpoint = 0.6;\nPerspective.Dispersion = 3;\n" + keys, ""))
    result = ref.render(scene)
    c = np.array([100, 150, 200]) / 255
    lum = 0.2126 * c[0] + 0.715160 * c[1] + 0.072169 * c[2]
    e = -math.log(1 - 0.6) / lum
    assert result.exposure == pytest.approx(e, rel=1e-12)
    tone = tonemap.curve(e * c, scene.tonemap)
    expected = [int(255 * srgb(v)) for v in tone]
    assert (result.rgb8_tga[10:] == expected).all()      # every pixel above the strip


def test_page4_orthographic_shows_the_texel_straight_ahead(tmp_path):
    keys = write_cubemap(tmp_path)
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Image.Width = 16;\nImage.Height = 16;\nNumberOfMaterials = 1;\n"
        "NumberOfSpheres = 1;\n" + keys, "Material0 { Diffuse = 1; }\n"
        "Sphere0 { Center = 8, 8, 100; Size = 5; }\n"))           # not hit: rays start at -10000
    assert any("orthographic" in w for w in scene.warnings)
    result = ref.render(scene, exposure=1.0)
    forward = np.array([10, 200, 200]) / 255
    assert np.allclose(result.linear[:12], forward)              # rows y >= 10 of the image


def _shadow_scene(tmp_path):
    # light to the right of sphere A; blocker B beyond the light, outside the orthographic view
    return ref.parse_scene(write_scene(
        tmp_path, "1.1", "Image.Width = 64;\nImage.Height = 48;\nNumberOfMaterials = 1;\n"
        "NumberOfSpheres = 2;\nNumberOfLights = 1;\n",
        "Material0 { Diffuse = 1; }\nSphere0 { Center = 32, 24, 0; Size = 10; }\n"
        "Sphere1 { Center = 100, 24, -20; Size = 8; }\nLight0 { Position = 60, 24, -10; Intensity = 1; }\n"))


def test_strict_shadow_test_uses_squared_distance(tmp_path):
    scene = _shadow_scene(tmp_path)
    strict, clean = ref.render(scene, "strict"), ref.render(scene, "clean")
    # predict the sub-samples whose shadow ray hits B beyond the light but within |L|^2
    bites = np.zeros(strict.linear.shape[:2], dtype=bool)
    lit = np.zeros_like(bites)
    c_a, c_b, light = np.array([32.0, 24, 0]), np.array([100.0, 24, -20]), np.array([60.0, 24, -10])
    for row in range(bites.shape[0]):
        for col in range(bites.shape[1]):
            fx, fy = col / 2, (bites.shape[0] - 1 - row) / 2
            h = 100 - (fx - 32) ** 2 - (fy - 24) ** 2
            if h < 0:
                continue
            p = np.array([fx, fy, -math.sqrt(h)])
            dist = light - p
            if dist @ (p - c_a) <= 0:
                continue
            lit[row, col] = True
            ld = dist / np.linalg.norm(dist)
            oc = c_b - p
            disc = (ld @ oc) ** 2 - oc @ oc + 64
            if disc >= 0:
                t = ld @ oc - math.sqrt(disc)
                bites[row, col] = np.linalg.norm(dist) < t < dist @ dist
    assert bites.sum() > 20
    differ = (strict.linear != clean.linear).any(axis=2)
    assert np.array_equal(differ, bites)
    assert (strict.linear[bites] == 0).all() and (clean.linear[bites] > 0).all()
    assert (clean.linear[lit & ~bites] > 0).all()


def test_coef_squared_on_textured_materials_only_after_a_bounce(tmp_path):
    # a nearly flat half-mirror (metal, Reflection 0.5) in front; behind the eye a turbulence
    # sphere seen in it
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Image.Width = 64;\nImage.Height = 48;\nPerspective.Type = conic;\n"
        "Perspective.FOV = 60;\nNumberOfMaterials = 2;\nNumberOfSpheres = 2;\nNumberOfLights = 1;\n",
        "Material0 { Reflection = 0.5; }\n"
        "Material1 { Type = turbulence; Diffuse = 0.8; Diffuse2 = 0.2, 0.3, 0.4; }\n"
        "Sphere0 { Center = 32, 24, 1200; Size = 1000; Material.Id = 0; }\n"
        "Sphere1 { Center = 32, 24, -80; Size = 60; Material.Id = 1; }\n"
        "Light0 { Position = 32, 150, 0; Intensity = 1; }\n"))
    strict = ref.render(scene, "strict", seed=5, exposure=1.0)
    fixed = ref.render(scene, ref.Quirks(coef_squared=False), seed=5, exposure=1.0)
    differ = (strict.linear != fixed.linear).any(axis=2)
    assert differ.sum() > 100
    # the same draws pick the same events: only reflected hits on the textured sphere change,
    # by exactly the factor 1/coef = 2 of the Lambert term
    assert np.allclose(fixed.linear[differ], 2 * strict.linear[differ], rtol=1e-6)


def _sphere_world(tmp_path, material: str):
    keys = write_cubemap(tmp_path)
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Perspective.Type = conic;\nNumberOfMaterials = 1;\nNumberOfSpheres = 1;\n"
        + keys, f"Material0 {{ {material} }}\nSphere0 {{ Center = 0, 0, 0; Size = 50; }}\n"))
    return World(scene)


def _trace(world, quirks, draws):
    o = np.zeros((3, 1))
    d = np.array([[0.6], [0.0], [0.8]])
    return transport.roulette(world, o, d, np.asarray(draws, float).reshape(1, -1), quirks)[:, 0], d


def test_cubemap_added_at_the_segment_limit_only_in_strict(tmp_path):
    world = _sphere_world(tmp_path, "Reflection = 1;")         # a closed mirror around the eye
    draws = np.full(rng.DRAWS, 0.5)
    strict, d = _trace(world, ref.STRICT, draws)
    assert np.allclose(strict, world.environment.lookup(d)[:, 0])   # 10 reflections: d again
    assert (_trace(world, ref.CLEAN, draws)[0] == 0).all()
    assert (_trace(world, ref.Quirks(cubemap_at_limit=False), draws)[0] == 0).all()


def test_inside_retrace_consumes_segments_only_in_strict(tmp_path):
    # inside a sphere the path index is 1 on both sides: R = 0, Tr = 0.5, so u <= 0.5 refracts
    # straight out (coef 0.5) and u > 0.5 is a diffuse event inside
    world = _sphere_world(tmp_path, "Density = 1.5; Refraction = 0.5;")
    sky = world.environment.lookup(np.array([[0.6], [0.0], [0.8]]))[:, 0]
    never = np.full(rng.DRAWS, 0.9)
    assert np.allclose(_trace(world, ref.STRICT, never)[0], sky)        # stuck, cube map at limit
    assert (_trace(world, ref.Quirks(cubemap_at_limit=False), never)[0] == 0).all()
    assert np.allclose(_trace(world, ref.CLEAN, never)[0], 0.5 * sky)   # redrawn: refracts
    late = np.full(rng.DRAWS, 0.9)
    late[2 + 9] = 0.2             # the last segment's draw refracts: strict gets there too
    assert np.allclose(_trace(world, ref.STRICT, late)[0], 0.5 * sky)
    assert np.allclose(_trace(world, ref.CLEAN, late)[0], 0.5 * sky)


def test_path_index_is_carried_only_in_strict(tmp_path):
    # the eye at the centre of a glass sphere: every hit is "inside" at normal incidence.
    # strict: the path index is still the camera's 1 = n2, so R = 0 and the ray refracts
    # straight out; clean: n1 = Density 2, R = 1/9, Rf = 0.5/9, and the first draw reflects
    world = _sphere_world(tmp_path, "Density = 2; Reflection = 0.5; Refraction = 1;")
    d = np.array([[0.6], [0.0], [0.8]])
    sky, behind = world.environment.lookup(d)[:, 0], world.environment.lookup(-d)[:, 0]
    draws = np.full(rng.DRAWS, 0.9)
    draws[2] = 0.01
    assert np.allclose(_trace(world, ref.STRICT, draws)[0], sky)
    # reflected back through the centre, then refracted out (weights 0.5 x 1)
    assert np.allclose(_trace(world, ref.Quirks(path_index=False), draws)[0], 0.5 * behind)
    assert np.allclose(_trace(world, ref.CLEAN, draws)[0], 0.5 * behind)


def test_clean_inside_draw_picks_reflect_and_refract_in_proportion():
    rf, tr = np.full(1000, 0.3), np.full(1000, 0.5)
    u = (np.arange(1000) + 0.5) / 1000
    event = transport._decide(u * np.minimum(rf + tr, 1.0), rf, tr)
    assert (event != transport.DIFFUSE).all()
    assert abs((event == transport.REFLECT).mean() - 0.3 / 0.8) <= 1e-3


def test_subrect_stride_and_workers_do_not_change_pixels(tutorial_dir, monkeypatch):
    scene = ref.parse_scene(tutorial_dir / "page4" / "scene.txt")
    full = ref.render(scene, seed=7, rect=(150, 200, 166, 216), workers=1)
    part = ref.render(scene, seed=7, rect=(152, 204, 166, 216), stride=2, workers=1)
    assert full.exposure == part.exposure
    assert np.array_equal(part.rgb8_tga, full.rgb8_tga[4::2, 2::2])
    monkeypatch.setattr(driver._Job, "tiles", lambda self: [      # one tile per row
        (r, r + 1, 0, 1) for r in range(self.ys.size)])
    pooled = ref.render(scene, seed=7, rect=(150, 200, 166, 216), workers=2)
    assert np.array_equal(pooled.linear, full.linear)
    other = ref.render(scene, seed=8, rect=(150, 200, 166, 216), workers=1)
    assert not np.array_equal(other.linear, full.linear)


def test_complexity_gives_mean_and_variance(tutorial_dir):
    scene = ref.parse_scene(tutorial_dir / "page4" / "scene.txt")
    one = ref.render(scene, "clean", seed=3, rect=(150, 200, 158, 204), exposure=2.0)
    assert np.isnan(one.variance).all()
    many = ref.render(scene, "clean", seed=3, rect=(150, 200, 158, 204), complexity=8, exposure=2.0)
    assert many.complexity == 8 and np.isfinite(many.variance).all()
    assert (many.variance >= 0).all() and (many.variance > 0).any()
    # repeat 0 of the Complexity-8 render is the Complexity-1 render: both use stream (y, 0)
    assert not np.array_equal(many.linear, one.linear)


def test_clean_and_strict_expected_values_through_a_glass_sphere(tmp_path):
    # Density 1 (R = 0 at every angle), Refraction 0.5, Reflection 0: at the front hit half the
    # paths shade (Lambert + Blinn), half refract straight through (coef 0.5); at the back hit,
    # from inside, clean always refracts out (coef 0.25) to the sky, strict re-draws in place
    # and ends at the segment limit with the sky at coef 0.5 if 9 draws in a row fail
    keys = uniform_cubemap(tmp_path, (60, 120, 240))
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Image.Width = 64;\nImage.Height = 48;\nPerspective.Type = conic;\n"
        "Perspective.FOV = 90;\nNumberOfMaterials = 1;\nNumberOfSpheres = 1;\nNumberOfLights = 1;\n"
        + keys, "Material0 { Diffuse = 0.6, 0.4, 0.2; Specular = 0.5; Power = 20; Density = 1;"
        " Refraction = 0.5; }\nSphere0 { Center = 32, 24, 100; Size = 30; }\n"
        "Light0 { Position = 32, 80, 0; Intensity = 2; }\n"))
    sky = np.array([60, 120, 240]) / 255
    direct = _lone_sphere_colour(np.array([32.0, 24, 70]), np.array([32.0, 24, 100]), 30.0,
                                 np.array([32.0, 80, 0]), np.full(3, 2.0),
                                 np.array([0.6, 0.4, 0.2]), np.full(3, 0.5), 20.0,
                                 np.array([0.0, 0.0, 1.0]))
    through = {"clean": 0.25 * sky, "strict": (0.25 * (1 - 2.0 ** -9) + 0.5 * 2.0 ** -9) * sky}
    n = 4096
    for mode, behind in through.items():
        result = ref.render(scene, mode, seed=11, complexity=n, exposure=1.0, rect=(32, 24, 33, 25))
        mean, var = result.linear[1, 0], result.variance[1, 0]     # sub-sample (32, 24): on axis
        expected = 0.5 * direct + 0.5 * behind
        assert np.all(np.abs(mean - expected) < 4 * np.sqrt(var)), mode
        # two outcomes with probability 1/2 each: variance of the mean (direct - behind)^2 / 4n
        assert var == pytest.approx((direct - behind) ** 2 / (4 * n), rel=0.05)


def test_row_streams_are_one_sequence_per_row():
    whole = rng.row_draws(3, 17, 0, 5, 8)
    assert whole.shape == (5, 8, 2, 2, rng.DRAWS)
    assert np.array_equal(np.concatenate([rng.row_draws(3, 17, c, c + 1, 8) for c in range(5)]),
                          whole)
    assert np.array_equal(rng.row_draws(3, 17, 2, 4, 8), whole[2:4])
    assert not np.array_equal(rng.row_draws(3, 18, 0, 5, 8), whole)
    assert not np.array_equal(rng.row_draws(4, 17, 0, 5, 8), whole)


def test_tone_curve_is_defined_for_huge_and_infinite_radiance():
    """c^Power overflows for huge c: the curve's limit 1 there, not inf / inf = NaN (a black
    pixel); every other value is unchanged (found by the tone_curve stability sweep)."""
    tm = ref.scene.Tonemap(0.6, 3.0, 0.1)
    c = np.array([0.0, 0.5, 1.0, 10.0, 1e30, 1e103, 1e200, 1.7e308, np.inf])
    out = tonemap.curve(c, tm)
    assert np.isfinite(out).all() and out[0] == 0 and (out[4:] == 1.0).all()
    n = -math.log(1 - 0.6)
    s = -(1 + 0.1 / n ** 2)
    assert out[1] == 1.0 - math.exp(s * 0.5 ** 3 / (0.1 + 0.5 ** 2))   # bit for bit
    assert tonemap.curve(np.array([1e31]), ref.scene.Tonemap(0.6, 10.0, 0.1))[0] == 1.0
    assert np.isnan(tonemap.curve(np.array([np.nan]), tm)[0])


def test_non_finite_radiance_and_black_probes_are_reported(tmp_path):
    """A NaN radiance becomes byte 0 and black probes give E = -1 (facts.md F6.3), which tone-maps
    whatever they missed from negative values: the render says so in its warnings."""
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Image.Width = 24;\nImage.Height = 24;\nPerspective.Type = conic;\n"
        "NumberOfMaterials = 1;\nNumberOfSpheres = 1;\nNumberOfLights = 1;\n",
        "Material0 { Diffuse = 0.5; }\nSphere0 { Center = 12, 12, 60; Size = 40; }\n"
        "Light0 { Position = 12, 12, -100; Intensity = 1; }\n"))
    assert scene.warnings == []
    # the parser refuses a NaN (codermind_ref.checks); a scene changed after parsing is not
    scene.lights[0].intensity = (float("nan"),) * 3
    with np.errstate(all="ignore"):
        result = ref.render(scene, exposure=1.0)
    assert np.isnan(result.linear[:20]).all() and (result.rgb8[:-10] == 0).all()
    assert len(result.warnings) == 1 and "non-finite radiance" in result.warnings[0]
    # the sphere between the 16 x 16 probes (every 2 pixels here) with no probe on it
    scene = ref.parse_scene(write_scene(
        tmp_path, "1.3", "Image.Width = 32;\nImage.Height = 32;\nPerspective.Type = conic;\n"
        "NumberOfMaterials = 1;\nNumberOfSpheres = 1;\nNumberOfLights = 1;\n",
        "Material0 { Diffuse = 0.5; }\nSphere0 { Center = 17, 17, 30; Size = 0.5; }\n"
        "Light0 { Position = 17, 17, -100; Intensity = 1; }\n", name="probes.txt"))
    result = ref.render(scene)
    assert result.exposure == -1.0
    assert len(result.warnings) == 1 and "E = -1" in result.warnings[0]
    assert "probes.txt:1: auto exposure" in result.warnings[0]



def test_workers_started_from_a_forkserver_give_the_forked_image():
    """The command line starts the port's workers from a forkserver (it has imported Mitsuba,
    whose threads hold locks a fork would copy locked); the image is the same."""
    scene = ref.parse_scene(ROOT / "scenes" / "page4.txt")
    rect = (0, 200, 640, 264)
    forked = ref.render(scene, rect=rect, workers=2, complexity=1)
    served = ref.render(scene, rect=rect, workers=2, complexity=1, start_method="forkserver")
    assert np.array_equal(forked.linear, served.linear)


@pytest.mark.parametrize("page", ["page2", "page4"])
def test_tone_curve_in_bands_of_rows_gives_the_same_bits(page, monkeypatch):
    """The finish applies the tone curve in bands of rows to bound its temporaries; the bands
    must not change a bit (evidence: the same render with one band and with bands of 3 rows)."""
    scene = ref.parse_scene(ROOT / "scenes" / f"{page}.txt")
    rect = (200, 150, 240, 181)
    whole = ref.render(scene, "strict", 3, 2, rect=rect, workers=1)
    monkeypatch.setattr(driver, "_BAND_SAMPLES", 4 * 40 * 3)
    banded = ref.render(scene, "strict", 3, 2, rect=rect, workers=1)
    for name in ("rgb8", "tonemapped", "encoded", "linear", "variance"):
        assert np.array_equal(getattr(whole, name), getattr(banded, name), equal_nan=True), name
