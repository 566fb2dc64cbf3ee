"""The tutorial's image pipeline on the Mitsuba side (facts.md F2, F3, F6).

A converted tutorial scene renders the tutorial's sub-samples as film pixels: page 1 one
sample per pixel on a W x H film, pages 2 and 4 the 2x2 sub-sample grid on a 2W x 2H film
(sub-sample (x + a/2, y + b/2), y up, is film pixel (2x + a, 2H - 1 - 2y - b); film row 0 is
the top of the displayed image). From that linear film this module makes the tutorial's
8-bit image:

* page 1: byte = min(255 c, 255), truncated;
* page 2: per sub-sample 1 - exp(-E c) (E = 1, the tutorial's fixed exposure), mean of the
  four, sRGB encode, bytes, calibration strip;
* page 4: per sub-sample E c with the auto exposure E, the tone curve (Midpoint, Power,
  Black), mean of the four, sRGB, bytes, calibration strip.

Bytes: ``min(255 v, 255)`` converted as an x86 float-to-integer cast does (truncation toward
zero to a 32-bit integer, 0x80000000 for NaN and out-of-range values) and the low 8 bits
kept: there is no lower clamp, so a negative value wraps (-0.5/255 gives 0, -1.5/255 gives
255). The 2x2 mean is taken in the tutorial's order (x offset outer, y offset inner), in
float64.

The auto exposure is E = -ln(1 - Midpoint) / sqrt(mean L^2) over the luminances L of the
16 x 16 probe rays (:func:`probe_positions`; E = -1 when that mean is 0, as the original);
:mod:`codermind.tutorial.render` traces the probes through Mitsuba.

This module is written from facts.md independently of the port's ``tonemap`` (the two are
compared by the tests); it uses numpy only.

The settings travel in the converted XML as one comment block that Mitsuba ignores and
``codermind render`` reads (:func:`parse_block`)::

    <!-- codermind-tutorial: page=4 width=640 height=480 midpoint=0.7 power=3 black=0.1
         probes=probes -->

Keys: ``page`` (1, 2 or 4), ``width``, ``height`` (the tutorial image), ``lights`` (``sum``,
default: one render per light, added, as the tutorial sums its lights at every hit;
``sample``: Mitsuba's one light per hit; see :mod:`codermind.tutorial.render`), page 4 also
``midpoint``, ``power``, ``black`` (the ``Tonemap.*`` values) and ``probes`` (the id of the
sensor whose ``sample_ray`` gives the auto-exposure probe rays). Values contain no spaces.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, fields

import numpy as np

#: Luminance weights of the tutorial's auto exposure (facts.md F6.3).
LUMINANCE = np.array([0.2126, 0.715160, 0.072169])
#: Probe grid size per axis.
PROBES = 16
#: Rows y = 0 .. STRIP_ROWS - 1 hold the calibration pattern on pages 2 and 4.
STRIP_ROWS = 10

BLOCK_TAG = "codermind-tutorial:"
_BLOCK = re.compile(r"<!--\s*" + re.escape(BLOCK_TAG) + r"(?P<body>.*?)-->", re.S)


class ToneBlockError(ValueError):
    """A malformed ``codermind-tutorial`` comment block."""


@dataclass(frozen=True)
class ToneSettings:
    """What the pipeline needs to know about a converted scene."""
    page: int
    width: int
    height: int
    midpoint: float = 0.6
    power: float = 3.0
    black: float = 0.1
    probes: str = "probes"
    lights: str = "sum"

    def __post_init__(self):
        if self.lights not in ("sum", "sample"):
            raise ToneBlockError(f"lights must be 'sum' or 'sample', got '{self.lights}'")
        if self.page not in (1, 2, 4):
            raise ToneBlockError(f"page must be 1, 2 or 4, got {self.page}")
        if self.width < 1 or self.height < 1:
            raise ToneBlockError(f"width and height must be >= 1, got {self.width}x{self.height}")
        if self.page == 4:
            if not 0 < self.midpoint < 1:
                raise ToneBlockError(f"midpoint must be in (0, 1), got {self.midpoint:g}")
            if not self.power >= 2:
                raise ToneBlockError(f"power must be >= 2, got {self.power:g}")
            if not self.black >= 0:
                raise ToneBlockError(f"black must be >= 0, got {self.black:g}")

    @property
    def film_size(self) -> tuple[int, int]:
        """(width, height) of the film holding the sub-samples."""
        k = 1 if self.page == 1 else 2
        return k * self.width, k * self.height

    @property
    def has_strip(self) -> bool:
        return self.page in (2, 4)


def format_number(value: float) -> str:
    """Shortest text that reads back as the same double (integers without '.0')."""
    value = float(value)
    if value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(value)


def format_block(s: ToneSettings) -> str:
    """The XML comment carrying ``s``."""
    keys = ["page", "width", "height", "lights"]
    if s.page == 4:
        keys += ["midpoint", "power", "black", "probes"]
    body = " ".join(f"{k}={format_number(v) if isinstance(v, float) else v}"
                    for k, v in ((k, getattr(s, k)) for k in keys))
    return f"<!-- {BLOCK_TAG} {body} -->"


def parse_block(xml_text: str) -> ToneSettings | None:
    """The settings of the one ``codermind-tutorial`` block in ``xml_text``, None without
    one. Raises ToneBlockError (with the line) for a malformed or repeated block."""
    found = list(_BLOCK.finditer(xml_text))
    if not found:
        return None
    line = xml_text.count("\n", 0, found[0].start()) + 1
    if len(found) > 1:
        second = xml_text.count("\n", 0, found[1].start()) + 1
        raise ToneBlockError(f"line {second}: a second '{BLOCK_TAG}' block (the first is on "
                             f"line {line})")
    types = {f.name: f.type for f in fields(ToneSettings)}
    values: dict = {}
    for item in found[0]["body"].split():
        key, sep, text = item.partition("=")
        if not sep or key not in types:
            raise ToneBlockError(f"line {line}: '{item}' is not one of "
                                 f"{', '.join(k + '=...' for k in types)}")
        if key in values:
            raise ToneBlockError(f"line {line}: '{key}' given twice")
        kind = types[key]
        try:
            values[key] = int(text) if kind == "int" else float(text) if kind == "float" else text
        except ValueError:
            raise ToneBlockError(f"line {line}: {key}={text} is not a{'n integer' if kind == 'int' else ' number'}") from None
    for key in ("page", "width", "height"):
        if key not in values:
            raise ToneBlockError(f"line {line}: '{key}=' is missing")
    try:
        return ToneSettings(**values)
    except ToneBlockError as e:
        raise ToneBlockError(f"line {line}: {e}") from None


# -- formulas ------------------------------------------------------------------------------

def tone_curve(c: np.ndarray, s: ToneSettings) -> np.ndarray:
    """Per-channel tone curve of exposed radiance: page 2 and Black = 0: 1 - exp(-c);
    page 4 with Black > 0: 1 - exp(S c^P / (Black + c^(P-1))), S = -(1 + Black/n^(P-1)),
    n = -ln(1 - Midpoint), so that c = n maps to Midpoint."""
    c = np.asarray(c, dtype=np.float64)
    if s.page != 4 or s.black == 0:
        return -np.expm1(-c)
    p, b = s.power, s.black
    n = -math.log1p(-s.midpoint)
    slope = -(1.0 + b / n ** (p - 1.0))
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        return 1.0 - np.exp(slope * np.power(c, p) / (b + np.power(c, p - 1.0)))


def srgb_encode(v: np.ndarray) -> np.ndarray:
    """12.92 v for v <= 0.0031308, else 1.055 v^(1/2.4) - 0.055."""
    v = np.asarray(v, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        high = 1.055 * np.power(np.where(v > 0.0031308, v, 1.0), 1.0 / 2.4) - 0.055
    return np.where(v > 0.0031308, high, 12.92 * v)


def to_bytes(v: np.ndarray) -> np.ndarray:
    """The tutorial's ``(unsigned char) min(v * 255, 255)`` on x86 (see the module doc)."""
    scaled = np.minimum(np.asarray(v, dtype=np.float64) * 255.0, 255.0)
    ok = np.isfinite(scaled) & (scaled > -2.0 ** 31 - 1.0)
    as_int = np.where(ok, np.trunc(np.where(ok, scaled, 0.0)), -2.0 ** 31).astype(np.int64)
    return np.bitwise_and(as_int, 0xFF).astype(np.uint8)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """0.2126 R + 0.715160 G + 0.072169 B over the last axis."""
    rgb = np.asarray(rgb, dtype=np.float64)
    return rgb[..., 0] * LUMINANCE[0] + rgb[..., 1] * LUMINANCE[1] + rgb[..., 2] * LUMINANCE[2]


def exposure_from_luminance(lum: np.ndarray, midpoint: float) -> float:
    """E = -ln(1 - Midpoint) / sqrt(mean L^2), or -1 if that mean is 0."""
    m = math.sqrt(float(np.mean(np.square(np.asarray(lum, dtype=np.float64)))))
    return -math.log1p(-midpoint) / m if m > 0 else -1.0


def probe_positions(width: int, height: int) -> np.ndarray:
    """(256, 2) tutorial pixel positions (x, y), y up, of the auto-exposure probes:
    (i s, j s), i, j = 0..15, s = max(W, H)/16 (cell corners; past the top when W > H)."""
    step = max(width, height) / PROBES
    j, i = np.meshgrid(np.arange(PROBES), np.arange(PROBES), indexing="ij")
    return np.stack([(i * step).ravel(), (j * step).ravel()], axis=1).astype(np.float64)


def probe_film_positions(width: int, height: int) -> np.ndarray:
    """The probes as a sensor's ``sample2`` on a W x H film: (x / W, 1 - y / H)."""
    xy = probe_positions(width, height)
    return np.stack([xy[:, 0] / width, 1.0 - xy[:, 1] / height], axis=1)


def calibration_strip(width: int) -> np.ndarray:
    """uint8 (STRIP_ROWS, width) of tutorial rows y = 0..9 (row index = y): grey 186 where
    floor(x/10) is odd, else 255 on odd rows and 0 on even rows."""
    x = np.arange(width)[None, :]
    y = np.arange(STRIP_ROWS)[:, None]
    return np.where((x // 10) % 2 == 1, 186, np.where(y % 2 == 1, 255, 0)).astype(np.uint8)


def average_blocks(per_sample: np.ndarray) -> np.ndarray:
    """Mean of each 2x2 film block (display order in and out), in the tutorial's order:
    0.25 s(a, b) added for (a, b) = (0, 0), (0, 1), (1, 0), (1, 1), where film row 2r + 1
    is b = 0 and 2r is b = 1 (y up), column 2c + a."""
    s = np.asarray(per_sample, dtype=np.float64)
    out = np.zeros((s.shape[0] // 2, s.shape[1] // 2) + s.shape[2:])
    for a in (0, 1):
        for b in (0, 1):
            out += 0.25 * s[1 - b::2, a::2]
    return out


@dataclass
class TutorialImage:
    """The pipeline's result (display order, row 0 = top)."""
    rgb8: np.ndarray          #: uint8 (H, W, 3)
    tonemapped: np.ndarray    #: float64 (H, W, 3): the 2x2 mean of the tone-mapped sub-samples
    exposure: float | None    #: E used (page 1: None)

    @property
    def rgb8_tga(self) -> np.ndarray:
        """Rows in the TGA's stored order (tutorial row y = 0, the bottom, first)."""
        return self.rgb8[::-1]


#: Film pixels tone-mapped at once by :func:`tutorial_image` (pages 2 and 4).
TONE_BAND = 1 << 20


def tutorial_image(linear: np.ndarray, s: ToneSettings, exposure: float | None = None
                   ) -> TutorialImage:
    """The tutorial's 8-bit image from the linear film (display order; (H, W, >=3) on page
    1, (2H, 2W, >=3) on pages 2 and 4). ``exposure``: E (page 4: required; page 2: default
    1, the tutorial's fixed exposure; page 1: must be None)."""
    linear = np.asarray(linear)[..., :3]
    want = s.film_size
    if linear.shape[:2] != (want[1], want[0]):
        raise ValueError(f"the film is {linear.shape[1]}x{linear.shape[0]}, the page-{s.page} "
                         f"pipeline needs {want[0]}x{want[1]}")
    if s.page == 1:
        if exposure is not None:
            raise ValueError("page 1 has no exposure")
        tonemapped = linear.astype(np.float64)
    else:
        if exposure is None:
            if s.page == 4:
                raise ValueError("page 4 needs an exposure (auto exposure: see codermind.tutorial.render)")
            exposure = 1.0
        # per sub-sample, then per 2x2 block: computed in bands of film rows (an even
        # number, whole blocks), so that the float64 stages are band-sized, not film-sized
        tonemapped = np.empty((linear.shape[0] // 2, linear.shape[1] // 2, 3))
        rows = max(2, TONE_BAND // max(linear.shape[1], 1) // 2 * 2)
        for y in range(0, linear.shape[0], rows):
            band = float(exposure) * linear[y:y + rows].astype(np.float64)
            tonemapped[y // 2:(y + rows) // 2] = average_blocks(tone_curve(band, s))
    encoded = tonemapped if s.page == 1 else srgb_encode(tonemapped)
    rgb8 = to_bytes(encoded)
    if s.has_strip:
        rows = min(STRIP_ROWS, s.height)
        strip = calibration_strip(s.width)[:rows]
        rgb8[s.height - rows:] = strip[::-1, :, None]   # tutorial row y is display row H-1-y
    return TutorialImage(rgb8, tonemapped, None if s.page == 1 else float(exposure))


def tga_bytes(rgb8_display: np.ndarray) -> bytes:
    """An uncompressed 24-bit TGA as the tutorial writes it: image type 2, descriptor 0
    (bottom-left origin), rows from the bottom (tutorial row 0) up, B, G, R."""
    rgb8 = np.ascontiguousarray(rgb8_display, dtype=np.uint8)
    h, w = rgb8.shape[:2]
    if not (0 < w < 65536 and 0 < h < 65536):
        raise ValueError(f"TGA size out of range: {w}x{h}")
    header = bytes([0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, w & 0xFF, w >> 8, h & 0xFF, h >> 8, 24, 0])
    return header + np.ascontiguousarray(rgb8[::-1, :, ::-1]).tobytes()
