"""Make ``envmap.exr``, the environment of ``glass.xml``: a latitude-longitude sky (blue
above, warm near the horizon, a dark ground) with a small bright sun, 64 x 32 texels,
linear float32. Deterministic.

Run: ``.venv/bin/python scenes/user/make_envmap.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def envmap(width: int = 64, height: int = 32) -> np.ndarray:
    """(height, width, 3) radiance; row 0 is the zenith, as Mitsuba's ``envmap`` reads it."""
    theta = (np.arange(height) + 0.5) / height * np.pi             # from the zenith
    phi = (np.arange(width) + 0.5) / width * 2.0 * np.pi
    elevation = 0.5 * np.pi - theta[:, None] + 0.0 * phi[None, :]
    up = np.clip(np.sin(elevation), 0.0, 1.0)[..., None]
    sky = up * np.array([0.25, 0.45, 0.9]) + (1.0 - up) * np.array([0.9, 0.75, 0.55])
    ground = np.array([0.12, 0.1, 0.08])
    image = np.where((elevation > 0)[..., None], sky, ground)
    # the sun: 40 degrees up, 2 texels across
    sun_theta, sun_phi = np.radians(50.0), np.radians(120.0)
    d_theta = theta[:, None] - sun_theta
    d_phi = np.angle(np.exp(1j * (phi[None, :] - sun_phi)))
    image = image + (np.hypot(d_theta, d_phi * np.sin(sun_theta)) < 0.1)[..., None] * 60.0
    return image.astype(np.float32)


if __name__ == "__main__":
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    out = Path(__file__).with_name("envmap.exr")
    mi.Bitmap(envmap()).write(str(out))
    print(f"wrote {out}")
