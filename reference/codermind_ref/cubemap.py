"""Cube-map environment lookup of spec 2.11 (page 4).

Face by dominant axis (ties: x, then y, then z), the per-face (u, v) table, |u|, |v|,
bilinear fetch without a half-texel offset (i0 = int(S u), weight S u - i0, indices clamped),
then on the interpolated colour: pow 2.2 (Cubemap.sRGB), -ln(1.001 - c) (Cubemap.Exposed),
and division by Cubemap.Exposure. Texture row v = 0 is the first stored TGA row.
"""

from __future__ import annotations

import numpy as np

from .scene import FACES, Cubemap


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
        a, b, c = d
        ax, ay, az = np.abs(a), np.abs(b), np.abs(c)
        use_x = (ax >= ay) & (ax >= az)
        use_y = ~use_x & (ay >= ax) & (ay >= az)
        use_z = ~use_x & ~use_y
        with np.errstate(divide="ignore", invalid="ignore"):
            # u and v of spec table 2.11, then the face index in FACES order (+y -y +x -x +z -z)
            qx_c, qx_b = (c / a + 1.0) * 0.5, (b / a + 1.0) * 0.5
            qy_a, qy_c = (a / b + 1.0) * 0.5, (c / b + 1.0) * 0.5
            qz_a, qz_b = (a / c + 1.0) * 0.5, (b / c + 1.0) * 0.5
        pos_x, pos_y, pos_z = a > 0, b > 0, c > 0
        u = np.where(use_x, 1.0 - qx_c,
                     np.where(use_y, np.where(pos_y, qy_a, 1.0 - qy_a), qz_a))
        v = np.where(use_x, np.where(pos_x, qx_b, 1.0 - qx_b),
                     np.where(use_y, np.where(pos_y, 1.0 - qy_c, qy_c),
                              np.where(pos_z, qz_b, 1.0 - qz_b)))
        face = np.where(use_x, np.where(pos_x, 2, 3),
                        np.where(use_y, np.where(pos_y, 0, 1), np.where(pos_z, 4, 5)))
        # a zero component on the dominant axis (only d = 0) finds no face: black
        black = np.where(use_x, a == 0, np.where(use_y, b == 0, c == 0))
        colour = self._fetch(face, np.abs(u), np.abs(v))
        colour[:, black] = 0.0
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
