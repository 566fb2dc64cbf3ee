"""Primary rays (spec 2.2 and 2.4) for the sub-samples of a block of pixels.

Sub-sample (a, b), a, b in {0, 1}, of pixel (x, y) sits at (x + a/2, y + b/2); page 1 has one
sample at (x, y). Orthographic rays start at (fx, fy, z0) along +z (z0 = -1000; page 4:
-10000, its auto-exposure probes -1000). The page-4 conic camera has its eye at (W/2, H/2, 0)
and un-jittered direction normalize((fx - W/2)/PD, (fy - H/2)/PD, 1), PD = (W/2)/tan(FOV/2).
Depth of field moves the origin by (D u1, D u2, 0) (an off-centre square aperture [0, D]^2)
and aims at the focus point o + ClearPoint d (a sphere of radius ClearPoint around the eye).
"""

from __future__ import annotations

import math

import numpy as np

from .scene import Scene
from .vec import normalized


def projection_distance(scene: Scene) -> float:
    return (scene.width / 2.0) / math.tan(math.radians(scene.camera.fov) / 2.0)


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
    pd = projection_distance(scene)
    d = normalized(np.stack(((fx - 0.5 * w) / pd, (fy - 0.5 * h) / pd, np.ones(n))))
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
