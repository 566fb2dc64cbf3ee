"""The tutorial's image pipeline on the Mitsuba side (codermind.tutorial.image): facts.md F2,
F3 and F6 formulas, byte rules, the strip, the 2x2 mean after tone mapping, the comment
block; and agreement with the port's independent tonemap module."""

from __future__ import annotations

import math

import numpy as np
import pytest

from codermind.tutorial.image import (ToneBlockError, ToneSettings, average_blocks,
                                      calibration_strip, exposure_from_luminance, format_block,
                                      luminance, parse_block, probe_film_positions,
                                      probe_positions, srgb_encode, tga_bytes, to_bytes,
                                      tone_curve, tutorial_image)

P4 = ToneSettings(page=4, width=8, height=14, midpoint=0.7, power=3.0, black=0.1)


@pytest.mark.parametrize("midpoint, power, black", [(0.7, 3, 0.1), (0.6, 2, 0.5), (0.2, 5.5, 2.0),
                                                    (0.95, 3, 1e-3)])
def test_curve_maps_n_to_midpoint(midpoint, power, black):
    s = ToneSettings(page=4, width=1, height=1, midpoint=midpoint, power=power, black=black)
    n = -math.log(1 - midpoint)
    assert tone_curve(np.array(n), s) == pytest.approx(midpoint, rel=1e-12)


def test_curve_formula_and_black_zero_branch():
    c = np.array([0.0, 0.1, 0.5, 1.0, 3.0])
    n = -math.log(1 - 0.7)
    slope = -(1 + 0.1 / n ** 2)
    expected = 1 - np.exp(slope * c ** 3 / (0.1 + c ** 2))
    assert np.allclose(tone_curve(c, P4), expected, rtol=1e-14, atol=0)
    flat = ToneSettings(page=4, width=1, height=1, midpoint=0.7, power=3, black=0.0)
    assert np.allclose(tone_curve(c, flat), 1 - np.exp(-c), rtol=1e-14, atol=0)
    page2 = ToneSettings(page=2, width=1, height=1)
    assert np.allclose(tone_curve(c, page2), 1 - np.exp(-c), rtol=1e-14, atol=0)


def test_srgb_encode_both_branches():
    assert srgb_encode(np.array(0.002)) == pytest.approx(12.92 * 0.002)
    assert srgb_encode(np.array(0.5)) == pytest.approx(1.055 * 0.5 ** (1 / 2.4) - 0.055)
    assert srgb_encode(np.array(1.0)) == pytest.approx(1.0)
    assert srgb_encode(np.array(0.0031308)) == pytest.approx(12.92 * 0.0031308)


def test_bytes_truncate_clamp_and_wrap():
    v = np.array([0.0, 0.999 / 255, 1 / 255, 254.99 / 255, 1.0, 2.0, np.inf,
                  -0.5 / 255, -1.5 / 255, -2.0 / 255, np.nan, -1e12])
    assert to_bytes(v).tolist() == [0, 0, 1, 254, 255, 255, 255, 0, 255, 254, 0, 0]
    assert to_bytes(v).dtype == np.uint8


def test_calibration_strip_bytes():
    strip = calibration_strip(40)
    assert strip.shape == (10, 40)
    assert (strip[:, 10:20] == 186).all() and (strip[:, 30:40] == 186).all()
    assert (strip[0::2, 0:10] == 0).all() and (strip[1::2, 0:10] == 255).all()
    assert (strip[1::2, 20:30] == 255).all() and (strip[0::2, 20:30] == 0).all()


def test_strip_sits_at_the_bottom_of_the_display_image():
    s = ToneSettings(page=2, width=24, height=14)
    image = tutorial_image(np.full((28, 48, 3), 0.5), s)
    rgb8 = image.rgb8
    # tutorial row y is display row H - 1 - y: y = 0 (even: 0) is the last row
    assert (rgb8[-1, :10] == 0).all() and (rgb8[-2, :10] == 255).all()
    assert (rgb8[4:, 10:20] == 186).all() and (rgb8[:4, 10:20] != 186).all()
    expected = to_bytes(srgb_encode(1 - np.exp(-0.5)))
    assert (rgb8[:4] == expected).all()
    assert (image.rgb8_tga[0, :10] == 0).all()   # TGA order: row y = 0 first


def test_mean_is_taken_after_the_tone_curve():
    film = np.zeros((28, 16, 3))
    film[0::2, 0::2] = 4.0       # one sub-sample of each 2x2 block is bright
    image = tutorial_image(film, P4, exposure=1.0)
    per = tone_curve(np.array([4.0, 0.0]), P4)
    after = 0.25 * per[0] + 0.75 * per[1]
    before = tone_curve(np.array(1.0), P4)
    assert np.allclose(image.tonemapped, after)
    assert not np.isclose(after, before)
    assert (image.rgb8[:4] == to_bytes(srgb_encode(after))).all()


def test_exposure_scales_radiance_before_the_curve():
    film = np.full((28, 16, 3), 0.25)
    image = tutorial_image(film, P4, exposure=2.0)
    assert np.allclose(image.tonemapped, tone_curve(np.array(0.5), P4))
    assert image.exposure == 2.0


def test_subsample_layout():
    # sub-sample (x + a/2, y + b/2) is film pixel (2x + a, 2H - 1 - 2y - b); the tutorial
    # pixel (x, y) is display pixel (H - 1 - y, x)
    s = ToneSettings(page=2, width=8, height=16)
    x, y, a, b = 5, 12, 1, 0
    film = np.zeros((32, 16, 3))
    film[2 * 16 - 1 - 2 * y - b, 2 * x + a] = 8.0
    rgb8 = tutorial_image(film, s).rgb8
    lit = np.argwhere(rgb8.max(-1) > 0)
    lit = lit[lit[:, 0] < 16 - 10]      # above the strip
    assert lit.tolist() == [[16 - 1 - y, x]]
    # the order of the 2x2 mean: (a, b) = (0,0), (0,1), (1,0), (1,1) -> rows 2r+1, 2r, ...
    blocks = average_blocks(np.arange(16.0).reshape(4, 4, 1))
    assert blocks[0, 0, 0] == pytest.approx((4 + 0 + 5 + 1) / 4)


def test_page1_bytes_without_tone_mapping():
    s = ToneSettings(page=1, width=3, height=2)
    film = np.array([[[0.5, 1.5, -0.001], [0.2, 0.2, 0.2], [1, 1, 1]],
                     [[0, 0, 0], [0.999, 0.001, 0.01], [0.3, 0.3, 0.3]]])
    rgb8 = tutorial_image(film, s).rgb8
    assert rgb8[0, 0].tolist() == [127, 255, 0]
    assert rgb8[1, 1].tolist() == [254, 0, 2]
    with pytest.raises(ValueError):
        tutorial_image(film, s, exposure=1.0)


def test_film_size_is_checked():
    with pytest.raises(ValueError, match="needs 16x28"):
        tutorial_image(np.zeros((6, 8, 3)), P4, exposure=1.0)


def test_auto_exposure_formula():
    lum = np.array([0.5, 1.5, 1.0, 0.0])
    e = exposure_from_luminance(lum, 0.7)
    assert e * math.sqrt(np.mean(lum ** 2)) == pytest.approx(-math.log(0.3))
    assert exposure_from_luminance(np.zeros(4), 0.7) == -1.0
    assert luminance(np.array([1.0, 2.0, 3.0])) == pytest.approx(
        0.2126 + 2 * 0.715160 + 3 * 0.072169)


def test_probe_grid():
    xy = probe_positions(640, 480)
    assert xy.shape == (256, 2)
    assert xy[:, 0].max() == 600 and xy[:, 1].max() == 600 and xy.min() == 0
    assert len(np.unique(xy[:, 0])) == 16
    film = probe_film_positions(640, 480)
    assert film[:, 0].max() == pytest.approx(600 / 640)
    assert film[:, 1].min() == pytest.approx(1 - 600 / 480)   # past the image top


def test_tga_layout():
    rgb8 = np.zeros((2, 3, 3), np.uint8)
    rgb8[0, 0] = (10, 20, 30)      # display top-left = tutorial row y = 1
    data = tga_bytes(rgb8)
    assert data[:18] == bytes([0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 2, 0, 24, 0])
    pixels = np.frombuffer(data[18:], np.uint8).reshape(2, 3, 3)
    assert pixels[1, 0].tolist() == [30, 20, 10]    # second stored row, BGR


def test_block_round_trip_and_errors():
    s = ToneSettings(page=4, width=640, height=480, midpoint=0.7, power=3.0, black=0.1,
                     lights="sample")
    text = f"<scene>\n{format_block(s)}\n</scene>"
    assert parse_block(text) == s
    assert parse_block("<scene/>") is None
    with pytest.raises(ToneBlockError, match="line 1: 'color=1'"):
        parse_block("<!-- codermind-tutorial: page=1 width=2 height=2 color=1 -->")
    with pytest.raises(ToneBlockError, match="'height=' is missing"):
        parse_block("<!-- codermind-tutorial: page=1 width=2 -->")
    with pytest.raises(ToneBlockError, match="midpoint must be in"):
        parse_block("<!-- codermind-tutorial: page=4 width=2 height=2 midpoint=1.5 -->")
    with pytest.raises(ToneBlockError, match="line 2: a second"):
        parse_block("<!-- codermind-tutorial: page=1 width=2 height=2 -->\n"
                    "<!-- codermind-tutorial: page=1 width=2 height=2 -->")


def test_agrees_with_the_port():
    """Two implementations written from facts.md independently give the same numbers."""
    from codermind_ref import tonemap as port
    from codermind_ref.scene import Tonemap
    rng = np.random.default_rng(5)
    c = rng.exponential(1.0, 10000)
    assert np.allclose(tone_curve(c, P4), port.curve(c, Tonemap(0.7, 3.0, 0.1)),
                       rtol=1e-13, atol=1e-15)
    v = np.concatenate([rng.uniform(-0.02, 1.2, 10000), [np.nan, -np.inf, np.inf]])
    assert (to_bytes(v) == port.to_bytes(v)).all()
    u = rng.uniform(0, 1, 10000)
    assert np.allclose(srgb_encode(u), port.srgb(u), rtol=1e-14, atol=1e-16)
    assert (calibration_strip(640) == port.strip(np.arange(10), np.arange(640))).all()
    lum = rng.uniform(0, 2, 256)
    assert exposure_from_luminance(lum, 0.7) == pytest.approx(port.exposure_from_probes(lum, 0.7))
