"""The tutorial's version of Ken Perlin's 2002 "improved noise" in double precision,
vectorized (facts.md F9), and the tutorial's turbulence sum.

The arithmetic follows the code operation by operation (fade 6t^5-15t^4+10t^3, lerp
a + t(b - a), grad from the low 4 bits of the hash), so scalar results are bit-identical to it:
``noise(3.14, 42, 7) == 0.13691995878400012``. The table is Perlin's (223 at index 156, where the
tutorial's printed table has a typo 23). The gradient is the tutorial's, which differs from
Perlin's reference for hashes 13 and 14 (tutorial -x + y and y - z, reference -y + z and y - x);
``gradient="reference"`` gives Perlin's, for comparisons only: the original uses the tutorial's.
"""

from __future__ import annotations

import numpy as np

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
    138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195, 78, 66, 215, 61, 156, 180,
)
_P = np.array(PERMUTATION * 2, dtype=np.int32)

# grad(h, x, y, z) = (+-u) + (+-v) written as gx*x + gy*y + gz*z with one of gx, gy, gz = 0;
# bit 0 negates u, bit 1 negates v. Adding the exact zero term does not change the rounded sum.
# tutorial: u = x if (h < 8 or h in (12, 13)) else y; v = y if (h < 4 or h in (12, 13)) else z
# reference: u = x if h < 8 else y; v = y if h < 4 else (x if h in (12, 14) else z)
def _gradient_table(tutorial: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    g = np.zeros((3, 16))
    for h in range(16):
        if tutorial:
            u = 0 if (h < 8 or h in (12, 13)) else 1
            v = 1 if (h < 4 or h in (12, 13)) else 2
        else:
            u = 0 if h < 8 else 1
            v = 1 if h < 4 else (0 if h in (12, 14) else 2)
        g[u, h] += -1.0 if h & 1 else 1.0
        g[v, h] += -1.0 if h & 2 else 1.0
    # indexed directly by a permutation value (0..255): the low 4 bits select the gradient
    return tuple(np.ascontiguousarray(np.tile(g[i], 16)) for i in range(3))


GRADIENTS = {"tutorial": _gradient_table(True), "reference": _gradient_table(False)}


def _fade(t: np.ndarray) -> np.ndarray:
    return t * t * t * (t * (t * 6 - 15) + 10)


def noise(x, y, z, gradient: str = "tutorial") -> np.ndarray:
    """Improved noise at arrays (or scalars) x, y, z; same shape as their broadcast.
    gradient: "tutorial" (the original's) or "reference" (Perlin's 2002 code)."""
    gx, gy, gz = GRADIENTS[gradient]
    x, y, z = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (x, y, z)))
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    X = fx.astype(np.int32) & 255
    Y = fy.astype(np.int32) & 255
    Z = fz.astype(np.int32) & 255
    x, y, z = x - fx, y - fy, z - fz
    x1, y1, z1 = x - 1, y - 1, z - 1
    u, v, w = _fade(x), _fade(y), _fade(z)
    P = _P
    A = P[X] + Y
    B = P[X + 1] + Y
    AA, AB, BA, BB = P[A] + Z, P[A + 1] + Z, P[B] + Z, P[B + 1] + Z

    def grad(corner, a, b, c):
        h = P[corner]
        return gx[h] * a + gy[h] * b + gz[h] * c

    # lerp(t, lo, hi) = lo + t * (hi - lo), as Perlin nests them (x innermost)
    e00 = grad(AA, x, y, z)
    e00 += u * (grad(BA, x1, y, z) - e00)
    e10 = grad(AB, x, y1, z)
    e10 += u * (grad(BB, x1, y1, z) - e10)
    e00 += v * (e10 - e00)
    e01 = grad(AA + 1, x, y, z1)
    e01 += u * (grad(BA + 1, x1, y, z1) - e01)
    e11 = grad(AB + 1, x, y1, z1)
    e11 += u * (grad(BB + 1, x1, y1, z1) - e11)
    e01 += v * (e11 - e01)
    return e00 + w * (e01 - e00)


def turbulence(px, py, pz) -> np.ndarray:
    """T = sum_{k=1..9} (1/k) |noise(0.05 k p)| (facts.md F7.2), p in world units."""
    total = np.zeros(np.broadcast(px, py, pz).shape)
    for k in range(1, 10):
        f = k * 0.05
        total += (1.0 / k) * np.abs(noise(f * px, f * py, f * pz))
    return total
