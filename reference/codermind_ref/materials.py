"""Materials of facts.md F7 and F10 as arrays indexed by material id: surface colour (gouraud,
turbulence, marble; ``noise`` is gouraud) and the Perlin bump of the normal."""

from __future__ import annotations

import numpy as np

from . import perlin
from .scene import Scene
from .vec import dot

GOURAUD, TURBULENCE, MARBLE = 0, 1, 2
_KIND = {"gouraud": GOURAUD, "noise": GOURAUD, "turbulence": TURBULENCE, "marble": MARBLE}


class MaterialTable:
    """Per-material columns: ``diffuse``/``diffuse2``/``specular`` (3, M), ``power``,
    ``reflection``, ``refraction``, ``density``, ``bumplevel``, ``kind`` (M,)."""

    def __init__(self, scene: Scene, dtype=np.float64):
        mats = scene.materials
        col = lambda name: np.array([getattr(m, name) for m in mats], dtype=dtype).reshape(-1)
        tri = lambda name: np.array([getattr(m, name) for m in mats], dtype=dtype).reshape(-1, 3).T
        self.diffuse, self.diffuse2, self.specular = tri("diffuse"), tri("diffuse2"), tri("specular")
        self.power, self.reflection = col("power"), col("reflection")
        self.refraction, self.density, self.bumplevel = col("refraction"), col("density"), col("bumplevel")
        self.kind = np.array([_KIND[m.type] for m in mats], dtype=np.int8)

    def colour(self, mat: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Surface colour (3, N) at points p of materials ``mat``: Diffuse for gouraud; the
        unclamped mix T Diffuse + (1-T) Diffuse2 for turbulence; m Diffuse + (1-m) Diffuse2
        with m = 0.5 sin(0.05 (x + y) + T) + 0.5 for marble; T = turbulence(p)."""
        out = self.diffuse[:, mat]
        kind = self.kind[mat]
        textured = np.flatnonzero(kind != GOURAUD)
        if textured.size:
            q = p[:, textured]
            mix = perlin.turbulence(q[0], q[1], q[2])
            marble = kind[textured] == MARBLE
            mix = np.where(marble, 0.5 * np.sin(0.05 * (q[0] + q[1]) + mix) + 0.5, mix)
            m = mat[textured]
            out[:, textured] = mix * self.diffuse[:, m] + (1.0 - mix) * self.diffuse2[:, m]
        return out


def bump(n: np.ndarray, p: np.ndarray, level: np.ndarray) -> np.ndarray:
    """normalize((1 - b) n + b (noise(0.1 (x,y,z)), noise(0.1 (y,z,x)), noise(0.1 (z,x,y))))."""
    x, y, z = 0.1 * p[0], 0.1 * p[1], 0.1 * p[2]
    # the three noise calls in one batch: (x,y,z), (y,z,x), (z,x,y)
    g = perlin.noise(np.concatenate((x, y, z)), np.concatenate((y, z, x)),
                     np.concatenate((z, x, y))).reshape(3, -1)
    m = (1.0 - level) * n + level * g
    length2 = dot(m, m)
    with np.errstate(divide="ignore", invalid="ignore"):
        bumped = m * (1.0 / np.sqrt(length2))
    return np.where(length2 > 0, bumped, n)  # a zero result (not met in practice) keeps n
