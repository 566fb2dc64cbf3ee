"""Cube-map environment lookup of facts.md F12 (page 4).

Face by dominant axis (ties: x, then y, then z), the per-face (u, v) table, |u|, |v|,
bilinear fetch without a half-texel offset (i0 = int(S u), weight S u - i0, indices clamped),
then on the interpolated colour: pow 2.2 (Cubemap.sRGB), -ln(1.001 - c) (Cubemap.Exposed),
and division by Cubemap.Exposure. Texture row v = 0 is the first stored TGA row.
"""

from __future__ import annotations

import numpy as np

from .scene import FACES, Cubemap


# spec table 2.11 with a, b, c = d.x, d.y, d.z and the dominant component as denominator:
# x faces: u = 1 - (c/a + 1)/2, v = (b/a + 1)/2 (-x: 1 - that); y faces: u = (a/b + 1)/2
# (-y: 1 - that), v = 1 - (c/b + 1)/2 (-y: without 1 -); z faces: u = (a/c + 1)/2,
# v = (b/c + 1)/2 (-z: 1 - that)
_FACE_OF_AXIS = np.array([1, 0, 2])            # axis x -> faces 2, 3; y -> 0, 1; z -> 4, 5
_U_OF_AXIS = np.array([2, 0, 0])
_V_OF_AXIS = np.array([1, 2, 1])
_FLIP_U = np.array([False, True, True, True, False, False])
_FLIP_V = np.array([True, False, False, True, False, True])


class Environment:
    """The cube map of a scene, ready for vectorized lookups (black if no faces)."""

    def __init__(self, cubemap: Cubemap):
        self.cm = cubemap
        if cubemap.faces is None:
            self.texels = None
            return
        stack = np.stack([cubemap.faces[f] for f in FACES])   # (6, rows, cols, 3)
        self.rows, self.cols = stack.shape[1:3]
        self.texels = stack.reshape(-1, 3).T.copy()           # (3, 6 * rows * cols)

    def lookup(self, d: np.ndarray) -> np.ndarray:
        """Radiance (3, N) seen along directions d (3, N)."""
        n = d.shape[1]
        if self.texels is None or n == 0:
            return np.zeros((3, n))
        ax, ay, az = np.abs(d)
        use_x = (ax >= ay) & (ax >= az)
        axis = np.where(use_x, 0, np.where(ay >= az, 1, 2))
        flat, ray = d.reshape(-1), np.arange(n)
        den = flat[axis * n + ray]
        face = 2 * _FACE_OF_AXIS[axis] + (den < 0)      # FACES order: +y -y +x -x +z -z
        with np.errstate(divide="ignore", invalid="ignore"):
            qu = (flat[_U_OF_AXIS[axis] * n + ray] / den + 1.0) * 0.5
            qv = (flat[_V_OF_AXIS[axis] * n + ray] / den + 1.0) * 0.5
        u = np.where(_FLIP_U[face], 1.0 - qu, qu)
        v = np.where(_FLIP_V[face], 1.0 - qv, qv)
        colour = self._fetch(face, np.abs(u), np.abs(v))
        colour[:, den == 0] = 0.0       # only d = 0 has no face: black
        return self._radiance(colour)

    def _fetch(self, face, u, v) -> np.ndarray:
        cols, rows = self.cols, self.rows
        su, sv = cols * u, rows * v
        su = np.where(np.isfinite(su), su, 0.0)
        sv = np.where(np.isfinite(sv), sv, 0.0)
        i0, j0 = su.astype(np.int64), sv.astype(np.int64)
        fu, fv = su - i0, sv - j0
        i1, j1 = np.clip(i0 + 1, 0, cols - 1), np.clip(j0 + 1, 0, rows - 1)
        i0, j0 = np.clip(i0, 0, cols - 1), np.clip(j0, 0, rows - 1)
        base = face * (rows * cols)
        t = self.texels
        t00, t10 = t[:, base + j0 * cols + i0], t[:, base + j0 * cols + i1]
        t01, t11 = t[:, base + j1 * cols + i0], t[:, base + j1 * cols + i1]
        return (1.0 - fv) * ((1.0 - fu) * t00 + fu * t10) + fv * ((1.0 - fu) * t01 + fu * t11)

    def _radiance(self, c: np.ndarray) -> np.ndarray:
        if self.cm.srgb:
            c = c ** 2.2
        if self.cm.exposed:
            with np.errstate(divide="ignore", invalid="ignore"):
                c = -np.log(1.001 - c)
        return c / self.cm.exposure
