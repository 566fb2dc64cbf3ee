"""The tutorial's Perlin noise (its version of Ken Perlin's improved noise, 2002) in Dr.Jit,
float32, vectorized; shared by the ``perlin``, ``turbulence`` and ``marble`` textures and the
``noisebump`` BSDF.

Two gradient functions (facts.md F9), chosen per plugin by its ``gradient`` parameter:

- ``"tutorial"`` (the default): the tutorial's own ``grad``, u = x if h < 8 or h is 12 or 13
  else y; v = y if h < 4 or h is 12 or 13 else z;
- ``"reference"``: Perlin's 2002 reference, u = x if h < 8 else y; v = y if h < 4, x if h is
  12 or 14, else z.

They differ only for h = 13 (tutorial -x + y, reference -y + z) and h = 14 (y - z against
y - x). Both use Perlin's permutation table (the tutorial's printed copy has 23 where
Perlin's has 223; its program uses Perlin's), and the value equals the double-precision
``noise(x, y, z)`` evaluated in float32. Instead of the reference's 14 table look-ups per
call, two pre-combined tables need 5:

- ``_PAIRS[X * 256 + Y]`` packs the four second-level hashes ``p[p[X]+Y]``,
  ``p[p[X]+Y+1]``, ``p[p[X+1]+Y]``, ``p[p[X+1]+Y+1]`` (the reference's AA, AB, BA, BB
  before adding Z) into one 32-bit word (256 KiB table);
- ``_GRADS[gradient][h]`` holds the gradient of both z-corners, ``p[h] & 15`` and
  ``p[h+1] & 15``, for h = AA+Z etc., already expanded to signs: see :func:`_grad`.

This module is loaded before the plugins and reloaded on every variant switch (its
tables are arrays of the current variant).
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np

from ..params import FLOAT32_MAX

#: Ken Perlin's permutation (https://mrl.nyu.edu/~perlin/noise/), 223 at index 156.
PERMUTATION = (
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30,
    69, 142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94,
    252, 219, 203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171,
    168, 68, 175, 74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60,
    211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1,
    216, 80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86,
    164, 100, 109, 198, 173, 186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118,
    126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170,
    213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39,
    253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97, 228, 251, 34,
    242, 193, 238, 210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49,
    192, 214, 31, 181, 199, 106, 157, 184, 84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254,
    138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195, 78, 66, 215, 61, 156, 180)


#: The ``gradient`` choices; the first is the default.
GRADIENTS = ("tutorial", "reference")
DEFAULT_GRADIENT = GRADIENTS[0]


def _gradient_code(h: int, gradient: str) -> int:
    """``grad(h, x, y, z) = +-u +- v`` of the chosen gradient as 6 bits: for x, y, z a 2-bit
    field holding the coefficient + 1 (0, 1 or 2)."""
    if gradient == "tutorial":
        u = 0 if h < 8 or h in (12, 13) else 1                  # axis of u: x or y
        v = 1 if h < 4 or h in (12, 13) else 2                  # axis of v: y or z
    else:
        u = 0 if h < 8 else 1
        v = 1 if h < 4 else (0 if h in (12, 14) else 2)         # axis of v: y, x or z
    coef = [0, 0, 0]
    coef[u] += -1 if h & 1 else 1
    coef[v] += -1 if h & 2 else 1
    return sum((c + 1) << (2 * axis) for axis, c in enumerate(coef))


def _build_tables() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    p = np.array(PERMUTATION * 2, dtype=np.uint32)              # p[i] for i < 512
    x, y = np.meshgrid(np.arange(256), np.arange(256), indexing="ij")
    a, b = p[x] + y, p[x + 1] + y                               # reference's A and B
    pairs = p[a] | (p[a + 1] << 8) | (p[b] << 16) | (p[b + 1] << 24)
    h = np.arange(511)
    grads = {}
    for gradient in GRADIENTS:
        codes = np.array([_gradient_code(k, gradient) for k in range(16)], dtype=np.uint32)
        g = codes[p[h] & 15] | (codes[p[h + 1] & 15] << 6)     # z-corner 0 and 1
        grads[gradient] = np.append(g, 0).astype(np.uint32)
    return pairs.ravel().astype(np.uint32), grads


_PAIRS_NP, _GRADS_NP = _build_tables()
_SCALAR = dr.is_array_v(mi.Float) is False
if _SCALAR:
    _PAIRS = _PAIRS_NP.tolist()
    _GRADS = {g: t.tolist() for g, t in _GRADS_NP.items()}
else:
    _PAIRS = mi.UInt32(_PAIRS_NP)
    _GRADS = {g: mi.UInt32(t) for g, t in _GRADS_NP.items()}


def read_gradient(props: mi.Properties, plugin: str) -> str:
    """The plugin's string parameter ``gradient`` (default ``"tutorial"``), checked."""
    value = props.get("gradient", DEFAULT_GRADIENT)
    if value not in GRADIENTS:
        raise ValueError(f"{plugin}: 'gradient' must be 'tutorial' or 'reference', got "
                         f"{value!r}")
    return value


def _gather(table, index):
    if _SCALAR:
        return table[index]
    return dr.gather(mi.UInt32, table, index)


def _fade(t: mi.Float) -> mi.Float:
    return t * t * t * dr.fma(t, dr.fma(t, 6.0, -15.0), 10.0)


def _lerp(t: mi.Float, a: mi.Float, b: mi.Float) -> mi.Float:
    return dr.fma(t, b - a, a)


def _coef(code, shift: int) -> mi.Float:
    return mi.Float((code >> shift) & 3) - 1.0


def _grad(code, x: mi.Float, y: mi.Float, z: mi.Float) -> mi.Float:
    """Dot product of the 6-bit gradient ``code`` with (x, y, z)."""
    return dr.fma(_coef(code, 0), x, dr.fma(_coef(code, 2), y, _coef(code, 4) * z))


#: Coordinates are clamped to +-2^24: beyond 2^23 every float32 is an integer, where the noise
#: is exactly 0 either way, and an infinite coordinate (a position times a frequency beyond
#: the float32 range) would otherwise give inf - inf = NaN.
_CLAMP = float(2 ** 24)


def _cell(x: mi.Float):
    """Lattice index (mod 256), offsets to the two lattice planes, and the fade weight."""
    x = dr.clip(x, -_CLAMP, _CLAMP)
    f = dr.floor(x)
    t = x - f
    return mi.UInt32(mi.Int32(f) & 255), t, t - 1.0, _fade(t)


def _combine(cx, cy, cz, gradient: str) -> mi.Float:
    """The noise from the three axes' cells (see :func:`_cell`)."""
    ix, x, x1, u = cx
    iy, y, y1, v = cy
    iz, z, z1, w = cz
    grads = _GRADS[gradient]
    q = _gather(_PAIRS, (ix << 8) | iy)
    g_aa = _gather(grads, (q & 255) + iz)
    g_ab = _gather(grads, ((q >> 8) & 255) + iz)
    g_ba = _gather(grads, ((q >> 16) & 255) + iz)
    g_bb = _gather(grads, (q >> 24) + iz)
    lo = _lerp(v, _lerp(u, _grad(g_aa, x, y, z), _grad(g_ba, x1, y, z)),
               _lerp(u, _grad(g_ab, x, y1, z), _grad(g_bb, x1, y1, z)))
    hi = _lerp(v, _lerp(u, _grad(g_aa >> 6, x, y, z1), _grad(g_ba >> 6, x1, y, z1)),
               _lerp(u, _grad(g_ab >> 6, x, y1, z1), _grad(g_bb >> 6, x1, y1, z1)))
    return _lerp(w, lo, hi)


def noise(x: mi.Float, y: mi.Float, z: mi.Float, gradient: str = DEFAULT_GRADIENT) -> mi.Float:
    """The noise at (x, y, z) with the chosen gradient, in about [-1, 1]."""
    return _combine(_cell(x), _cell(y), _cell(z), gradient)


def rotated_noise(x: mi.Float, y: mi.Float, z: mi.Float,
                  gradient: str = DEFAULT_GRADIENT) -> mi.Vector3f:
    """(noise(x, y, z), noise(y, z, x), noise(z, x, y)), the tutorial's bump vector; the
    three share their lattice cells and fade weights."""
    cx, cy, cz = _cell(x), _cell(y), _cell(z)
    return mi.Vector3f(_combine(cx, cy, cz, gradient), _combine(cy, cz, cx, gradient),
                       _combine(cz, cx, cy, gradient))


def noise3(p: mi.Point3f, gradient: str = DEFAULT_GRADIENT) -> mi.Float:
    return noise(p.x, p.y, p.z, gradient)


def turbulence(p: mi.Point3f, frequency: float | mi.Float, octaves: int,
               gradient: str = DEFAULT_GRADIENT) -> mi.Float:
    """The tutorial's T = sum_{k=1..octaves} |noise(frequency * k * p)| / k; ``frequency``
    a Python float or a ``mi.Float`` (differentiable: the derivative flows through the
    fractional part of each lattice coordinate)."""
    t = mi.Float(0.0)
    for k in range(1, octaves + 1):
        # 0 * inf would be NaN: the product is clamped to the float32 range
        f = dr.minimum(frequency * k, FLOAT32_MAX) if dr.is_array_v(frequency) else \
            min(frequency * k, FLOAT32_MAX)
        t += dr.abs(noise(p.x * f, p.y * f, p.z * f, gradient)) * (1.0 / k)
    return t


#: Spatial average of |noise| per gradient (4M random points over the noise's period, float64
#: reference of the tests; +-1e-4).
MEAN_ABS_NOISE = {"tutorial": 0.2180, "reference": 0.2204}
