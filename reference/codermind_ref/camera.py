"""Primary rays (facts.md F3 and F5) for the sub-samples of a block of pixels.

Sub-sample (a, b), a, b in {0, 1}, of pixel (x, y) sits at (x + a/2, y + b/2); page 1 has one
sample at (x, y). Orthographic rays start at (fx, fy, z0) along +z (z0 = -1000; page 4:
-10000, its auto-exposure probes -1000). The page-4 conic camera has its eye at (W/2, H/2, 0)
and un-jittered direction normalize((fx - W/2)/PD, (fy - H/2)/PD, 1), PD = (W/2)/tan(FOV/2)
in float32 (exactly W/2 for FOV 90).
Depth of field moves the origin by (D u1, D u2, 0) (an off-centre square aperture [0, D]^2)
and aims at the focus point o + ClearPoint d (a sphere of radius ClearPoint around the eye).
"""

from __future__ import annotations

import math

import numpy as np

from .scene import Scene
from .vec import normalized


def inverse_projection_distance(scene: Scene) -> np.float32:
    """1/PD = 1/(0.5 W / tanf(float(pi/180) 0.5 FOV)) in float32, as the original computes it
    (facts.md F3). Both modes use it: it is the original's camera, not a quirk (for FOV 90 it is
    the exact 1/(W/2), where float64 would give PD = 320.00000000000006)."""
    f = np.float32
    half_angle = f(f(math.pi) / f(180.0)) * f(0.5 * scene.camera.fov)
    return f(1.0) / f(f(0.5 * scene.width) / np.tan(half_angle))


def projection_distance(scene: Scene) -> float:
    return float(np.float32(1.0) / inverse_projection_distance(scene))


def rays(scene: Scene, fx: np.ndarray, fy: np.ndarray, u1: np.ndarray | None = None,
         u2: np.ndarray | None = None, *, probe: bool = False, dtype=np.float64
         ) -> tuple[np.ndarray, np.ndarray]:
    """Origins and unit directions (3, N) for film positions fx, fy (N,). u1, u2: the two
    depth-of-field draws per ray (page 4 conic, ignored when Dispersion is 0 or for probes).
    dtype applies to orthographic rays (pages 1 and 2 run in float32)."""
    n = fx.shape[0]
    if scene.page < 4 or scene.camera.type != "conic":
        z0 = -1000.0 if scene.page < 4 or probe else -10000.0
        o = np.stack((fx, fy, np.full(n, z0))).astype(dtype)
        d = np.zeros((3, n), dtype=dtype)
        d[2] = 1.0
        return o, d
    w, h = scene.width, scene.height
    # the film components in float32 like the original's: where they tie exactly with the z
    # component (|x| = |z| or |y| = |z|, e.g. the probes of column 0 and row 14 for FOV 90),
    # the cube map's face choice (facts.md F12) follows that tie in both modes, as in the original
    inv_pd = inverse_projection_distance(scene)
    f = np.float32
    film = np.stack(((fx - 0.5 * w).astype(f) * inv_pd, (fy - 0.5 * h).astype(f) * inv_pd,
                     np.ones(n, dtype=f))).astype(np.float64)
    d = normalized(film)
    o = np.empty((3, n))
    o[0], o[1], o[2] = 0.5 * w, 0.5 * h, 0.0
    disp = scene.camera.dispersion
    if probe or disp == 0 or u1 is None:
        return o, d
    focus = o + scene.camera.clear_point * d
    o = o.copy()
    o[0] += disp * u1
    o[1] += disp * u2
    return o, normalized(focus - o)
