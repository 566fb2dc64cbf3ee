"""Tiled rendering (codermind.passes.accumulate on a film above its tile budget): the tiles
cover the film once, a forced-tile render equals a whole render statistically (plain
perspective scene, also within a crop window set in the XML, and a small page-4-like
tutorial scene through the tutorial pipeline), the seams do not show, the crop window is
restored, and an interrupt returns whole passes. Evidence: our own two sides agreeing (tiled
against untiled renders of the same scene, with the variance of each from its 16 passes),
except where a test says otherwise. Films of 48 x 32 pixels, tile budget 200 pixels: tiles
of 14 x 14 with remainders of 6 and 4 (the film is not a multiple of the tile)."""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
import pytest

from support.zstat import t_test

#: Perspective camera, Gaussian reconstruction filter (Mitsuba's default: a 2-pixel border),
#: a point light near the top-left (a smooth gradient across every seam, the same sign along
#: it), a sphere (hard edges and a shadow) and a constant environment (noise).
SCENE = """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0, 0, -4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"/>
        <film type="hdrfilm">
            <integer name="width" value="48"/><integer name="height" value="32"/>
            {crop}
        </film>
    </sensor>
    <emitter type="point"><point name="position" x="2.2" y="1.6" z="-0.5"/><rgb name="intensity" value="6"/></emitter>
    <shape type="sphere"><float name="radius" value="0.6"/><bsdf type="diffuse"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate y="1" angle="180"/><scale value="4"/><translate z="1"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.6, 0.4"/></bsdf>
    </shape>
</scene>
"""
CROP = ('<integer name="crop_offset_x" value="5"/><integer name="crop_offset_y" value="3"/>'
        '<integer name="crop_width" value="37"/><integer name="crop_height" value="23"/>')
BUDGET = 200            # tiles of 14 x 14 (isqrt 200), remainders 6 and 4
PASSES = 16


def load(mi, crop: bool = False):
    return mi.load_string(SCENE.format(crop=CROP if crop else ""))


def crop_window(scene):
    film = scene.sensors()[0].film()
    return [int(v) for v in film.crop_offset()], [int(v) for v in film.crop_size()]


def render(scene, seed: int, spp: int = 4, **options):
    """(mean, variance of the mean, passes) of PASSES passes of ``spp`` samples."""
    from codermind.passes import accumulate
    mean, var, done, times = accumulate([scene], 0, [spp] * PASSES, seed, variance=True,
                                        **options)
    assert done == spp * PASSES and len(times) == PASSES
    return mean.astype(np.float64), var.astype(np.float64), PASSES


def test_tiles_cover_the_crop_window_once_within_the_budget():
    """Closed form: every pixel of the window in exactly one tile, none larger than the
    budget, the remainders where the film is not a multiple of the tile."""
    from codermind.passes import film_tiles
    for offset, size, budget in [((0, 0), (48, 32), 200), ((5, 3), (37, 23), 200),
                                 ((0, 0), (7, 1000), 50), ((2, 1), (1000, 3), 10),
                                 ((0, 0), (3000, 3000), 1 << 22)]:
        tiles = film_tiles(offset, size, budget)
        count = np.zeros(size[::-1], dtype=int)
        for x, y, w, h in tiles:
            assert 0 < w * h <= budget
            count[y - offset[1]:y - offset[1] + h, x - offset[0]:x - offset[0] + w] += 1
        assert (count == 1).all(), (offset, size, budget)
    assert film_tiles((5, 3), (37, 23), 37 * 23) == [(5, 3, 37, 23)]
    widths = {w for _, _, w, _ in film_tiles((0, 0), (48, 32), BUDGET)}
    heights = {h for _, _, _, h in film_tiles((0, 0), (48, 32), BUDGET)}
    assert widths == {14, 6} and heights == {14, 4}
    assert len(film_tiles((0, 0), (3000, 3000), 1 << 22)) == 4
    with pytest.raises(ValueError):
        film_tiles((0, 0), (4, 4), 0)


def test_each_pass_and_tile_has_its_own_seed():
    """An untiled film keeps the pass seeds; a tiled one gets a distinct seed per (pass,
    tile), none equal to a pass seed."""
    from codermind.passes import pass_seed, tile_seed
    assert [tile_seed(3, i, 0, 1) for i in range(5)] == [pass_seed(3, i) for i in range(5)]
    seeds = [tile_seed(3, i, j, 12) for i in range(50) for j in range(12)]
    assert len(set(seeds)) == len(seeds)
    assert not set(seeds) & {pass_seed(3, i) for i in range(50)}


@pytest.mark.parametrize("crop", [False, True], ids=["whole film", "crop window"])
def test_forced_tiles_equal_a_whole_render(llvm, crop):
    """Two-sample t-test per pixel and channel (each side's variance from its 16 passes,
    Sidak-corrected alpha = 1e-3 over all of them) and a z-test per channel of the
    difference of the image sums over pixels that share no sample (alpha = 1e-3, Sidak over
    the channels): 12 (crop window: 9) tiles of the film against the untiled
    film; and the tests have teeth: 5 % brighter fails the second. A crop window
    set in the XML is tiled within itself and kept."""
    scene = load(llvm, crop)
    before = crop_window(scene)
    whole = render(scene, seed=1)
    tiled = render(scene, seed=2, tile_budget=BUDGET)
    assert crop_window(scene) == before
    assert tiled[0].shape == whole[0].shape == (before[1][1], before[1][0], 3)
    result = t_test(whole, tiled)
    assert result.passed, result
    assert np.abs(mean_z(whole, tiled)).max() < critical(3)
    brighter = (tiled[0] * 1.05, tiled[1] * 1.05 ** 2, tiled[2])
    assert np.abs(mean_z(whole, brighter)).min() > critical(3)


#: Pixels this far apart along a row or column share no sample: the Gaussian filter's
#: border is 2 pixels, so a sample reaches at most 2 pixels either side of its own. The
#: variance of a sum over such pixels is the sum of their variances.
APART = 5


def critical(tests: int, alpha: float = 1e-3) -> float:
    """Two-sided normal critical value, Sidak-corrected over ``tests``."""
    return NormalDist().inv_cdf(1 - (1 - (1 - alpha) ** (1 / tests)) / 2)


def mean_z(a, b, step: int = APART) -> np.ndarray:
    """Per channel, z of the difference of the two images' sums over the pixels ``step``
    apart in both directions (the per-pixel test has little power against a small bias
    everywhere; this one has)."""
    d = (b[0] - a[0])[::step, ::step]
    v = (a[1] + b[1])[::step, ::step]
    return d.sum(axis=(0, 1)) / np.sqrt(v.sum(axis=(0, 1)))


def seam_z(whole, tiled) -> np.ndarray:
    """z of the summed difference (tiled - whole) along each of the two pixel lines on either
    side of every seam of the 48 x 32 film's tiles (vertical seams at x = 14, 28, 42,
    horizontal ones at y = 14, 28), over the pixels APART apart, per channel: shape
    (lines, 3)."""
    d, v = tiled[0] - whole[0], tiled[1] + whole[1]
    lines = [(slice(None, None, APART), x) for s in (14, 28, 42) for x in (s - 1, s)]
    lines += [(y, slice(None, None, APART)) for s in (14, 28) for y in (s - 1, s)]
    return np.array([d[line].sum(axis=0) / np.sqrt(v[line].sum(axis=0)) for line in lines])


def test_tile_seams_do_not_show(llvm):
    """Along each pixel line beside a seam, the mean difference between a tiled and an
    untiled render is noise: |z| below the normal's Sidak-corrected critical value (alpha
    1e-3 over the 10 lines x 3 channels). A point light gives a smooth gradient of one sign
    across each seam, so a pixel that lost its neighbours' filter share across the seam is
    biased the same way all along it: rendered without the filter's margin (Mitsuba drops
    what a crop window's samples splat outside it) the same statistic fails."""
    scene = load(llvm)
    whole = render(scene, seed=1, spp=32)
    tiled = render(scene, seed=2, spp=32, tile_budget=BUDGET)
    bare = render(scene, seed=3, spp=32, tile_budget=BUDGET, margin=0)
    z = seam_z(whole, tiled)
    assert np.abs(z).max() < critical(z.size), (np.abs(z).max(), critical(z.size))
    assert np.abs(seam_z(whole, bare)).max() > critical(z.size)


def test_crop_window_is_restored_after_an_error(llvm):
    """An exception during a tiled render (here from should_stop, polled before each pass,
    raised after the first pass left the last tile's crop set) leaves the film's window as
    it was: the whole film, and a crop window set in the XML."""
    from codermind.passes import accumulate
    for crop in (False, True):
        scene = load(llvm, crop)
        before = crop_window(scene)
        calls = []

        def stop():
            calls.append(1)
            if len(calls) > 1:
                raise KeyboardInterrupt
            return False

        with pytest.raises(KeyboardInterrupt):
            accumulate([scene], 0, [1, 1], 0, should_stop=stop, tile_budget=BUDGET)
        assert crop_window(scene) == before


def test_interrupt_after_k_passes_returns_k_whole_passes(llvm):
    """should_stop answering True before pass 3 of 5: the first 2 passes, every tile of
    each, are returned; they equal (to float rounding: film accumulation order) a tiled
    render of those 2 passes with the same seed, and differ from a 1-pass one."""
    from codermind.passes import accumulate
    scene = load(llvm)
    calls = []

    def stop():
        calls.append(1)
        return len(calls) > 2

    mean, _, done, times = accumulate([scene], 0, [2, 3, 2, 2, 2], 7, should_stop=stop,
                                      tile_budget=BUDGET)
    assert done == 5 and len(times) == 2
    two, _, _, _ = accumulate([scene], 0, [2, 3], 7, tile_budget=BUDGET)
    one, _, _, _ = accumulate([scene], 0, [2], 7, tile_budget=BUDGET)
    assert np.allclose(mean, two, rtol=1e-5, atol=1e-6)
    assert not np.allclose(mean, one, rtol=1e-3, atol=1e-4)


PAGE4_LIKE = """Scene
{
Version.Major = 1;
Version.Minor = 3;
Image.Width = 24;
Image.Height = 16;
Perspective.Type = conic;
Perspective.FOV = 90.0;
Perspective.ClearPoint = 14.0;
Perspective.Dispersion = 6.0;
Tonemap.Midpoint = 0.7;
Tonemap.Power = 3.0;
Tonemap.Black = 0.1;
NumberOfMaterials = 2;
NumberOfSpheres = 2;
NumberOfLights = 2;
Complexity = 16;
}
Material0 { Type = marble; Diffuse = 0.8, 0.6, 0.3; Diffuse2 = 0.1, 0.2, 0.4; Density = 1.0; Reflection = 0.3; Refraction = 0.0; Specular = 1, 1, 1; Power = 60; }
Material1 { Type = turbulence; Diffuse = 0.3, 0.7, 0.5; Diffuse2 = 0.5, 0.1, 0.1; Density = 2.0; Reflection = 0.0; Refraction = 0.5; Specular = 1, 1, 1; Power = 30; }
Sphere0 { Center = 8.0, 8.0, 12.0; Size = 6.0; Material.Id = 0; }
Sphere1 { Center = 17.0, 7.0, 16.0; Size = 5.0; Material.Id = 1; }
Light0 { Position = 0.0, 16.0, -10.0; Intensity = 1.5, 1.5, 1.5; }
Light1 { Position = 30.0, 4.0, 0.0; Intensity = 0.8, 0.6, 0.4; }
"""


def test_tutorial_pipeline_tiles_equal_a_whole_render(llvm, tmp_path, monkeypatch):
    """A page-4-like scene (conic sensor with lens blur, marble and turbulence, refraction,
    two lights summed over two light scenes: the built-in path integrator) converted and
    rendered through the tutorial pipeline with the variance: 48 x 32 sub-samples in tiles
    of 24 x 24 and 24 x 8 (fewer tiles than above: each tile's crop is a constant of the
    kernels, compiled once per tile) against the untiled film, the two tests above; the
    film stays whole."""
    from codermind import passes
    from codermind.tutorial import render as tr
    from codermind.tutorial.convert import convert_scene
    from codermind_ref import parse_scene
    source = tmp_path / "p4.txt"
    source.write_text(PAGE4_LIKE)
    xml = tmp_path / "p4.xml"
    xml.write_text(convert_scene(parse_scene(source), xml, integrator="path").xml)
    scene, settings = tr.load(xml)
    assert len(tr.light_scenes(scene)) == 2
    whole = tr.render(scene, settings, seed=1, exposure=2.0, variance=True)
    monkeypatch.setattr(passes, "TILE_BUDGET", 600)
    assert len(passes.film_tiles((0, 0), (48, 32))) == 4
    tiled = tr.render(scene, settings, seed=2, exposure=2.0, variance=True)
    film = scene.sensors()[0].film()
    assert [int(v) for v in film.crop_size()] == [48, 32] and list(film.crop_offset()) == [0, 0]
    assert tiled.linear.shape == whole.linear.shape == (32, 48, 3)
    assert tiled.image.rgb8.shape == (16, 24, 3)
    assert len(tiled.pass_times) == len(whole.pass_times) == PASSES
    a = (whole.linear.astype(np.float64), whole.variance.astype(np.float64), PASSES)
    b = (tiled.linear.astype(np.float64), tiled.variance.astype(np.float64), PASSES)
    assert (a[1] > 0).mean() > 0.4            # the lens and the materials make noise
    result = t_test(a, b)
    assert result.passed, result
    # the conic sensor's box filter puts each sample in one pixel: all pixels are apart
    assert np.abs(mean_z(a, b, step=1)).max() < critical(3)
    assert np.abs(mean_z(a, (b[0] * 1.05, b[1] * 1.05 ** 2, PASSES), step=1)).min() > critical(3)


def test_png_bands_differ_from_a_whole_conversion_by_at_most_one_level(llvm, tmp_path,
                                                                       monkeypatch):
    """Mitsuba built-in as the reference: write_png_srgb converts in bands of rows; Mitsuba's
    8-bit conversion dithers per band, so a byte may differ by one level from converting
    the whole image at once (NaN, infinities and negatives included), never more."""
    mi = llvm
    from codermind import imageio
    rng = np.random.default_rng(1)
    rgb = (rng.random((41, 29, 3)) * 1.5 - 0.2).astype(np.float32)
    rgb[3, 4] = [np.nan, np.inf, -np.inf]
    monkeypatch.setattr(imageio, "PNG_CHUNK", 29 * 8 + 5)      # bands of 8 rows
    imageio.write_png_srgb(tmp_path / "bands.png", rgb)
    bands = np.array(mi.Bitmap(str(tmp_path / "bands.png")), dtype=int)
    whole = mi.Bitmap(np.nan_to_num(rgb, nan=0.0, posinf=1.0), mi.Bitmap.PixelFormat.RGB)
    whole = np.array(whole.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8,
                                   srgb_gamma=True), dtype=int)
    assert bands.shape == whole.shape == (41, 29, 3)
    assert np.abs(bands - whole).max() <= 1
    assert (bands[:8] == whole[:8]).all()            # the first band is the whole's
    assert math.isclose(np.mean(bands), np.mean(whole), abs_tol=0.1)


def test_tutorial_tone_mapping_in_bands_equals_the_whole_film(monkeypatch):
    """Our own two sides: the page-4 pipeline tone-maps the film in bands of rows (here of
    6 rows: 3 blocks, and a remainder) and gives exactly the bytes and the block means of
    the per-sub-sample formula applied to the whole film at once."""
    from codermind.tutorial import image as ti
    settings = ti.parse_block("<!-- codermind-tutorial: page=4 width=20 height=11 lights=sum "
                              "midpoint=0.7 power=3 black=0.1 probes=probes -->")
    rng = np.random.default_rng(4)
    linear = (rng.random((22, 40, 3)) * 3).astype(np.float32)
    monkeypatch.setattr(ti, "TONE_BAND", 40 * 6)
    banded = ti.tutorial_image(linear, settings, 1.3)
    whole = ti.average_blocks(ti.tone_curve(1.3 * linear.astype(np.float64), settings))
    assert banded.tonemapped.shape == (11, 20, 3)
    assert np.array_equal(banded.tonemapped, whole)
    monkeypatch.setattr(ti, "TONE_BAND", linear.size)          # one band
    assert np.array_equal(banded.rgb8, ti.tutorial_image(linear, settings, 1.3).rgb8)
