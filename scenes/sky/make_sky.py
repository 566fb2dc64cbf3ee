"""Make the bundled cube-map faces: Mitsuba's `sunsky` over a plain ground, sampled on the
six faces with the face orientation and (u, v) formulas of the tutorial (facts.md F12).

Writes, next to this script:
- ``sky{up,down,right,left,forward,backward}.tga``: 24-bit TGAs encoded as the tutorial's
  page-4 faces are (``Cubemap.sRGB`` and ``Cubemap.Exposed``: radiance L is stored as
  (1.001 - exp(-L))^(1/2.2)), for the tutorial scenes;
- ``sky{...}.exr``: the same radiance, linear float32 and unclipped (the sun included), for
  path tracing with the cube map as a light source.

Run: ``.venv/bin/python scenes/sky/make_sky.py [--size 256]``. Deterministic.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

FACES = ("up", "down", "right", "left", "forward", "backward")
SCALE = 2.5                         # radiance multiplier: a well exposed sky in the TGAs
GROUND = np.array([0.075, 0.066, 0.05])  # radiance of the ground (before SCALE)


def face_directions(face: str, size: int) -> np.ndarray:
    """Unit directions (size, size, 3) of the texels of a face, [row v, column u], in the
    tutorial frame (x right, y up, z forward). Texel i sits at u = i/size: the tutorial's
    lookup reads texel i0 = int(size*u) with no half-texel offset."""
    t = np.arange(size) / size
    u, v = np.meshgrid(t, t)        # u along columns, v along rows (stored order)
    one = np.ones_like(u)
    d = {
        "right":    (one, 2 * v - 1, 1 - 2 * u),
        "left":     (-one, 2 * v - 1, 2 * u - 1),
        "up":       (2 * u - 1, one, 1 - 2 * v),
        "down":     (2 * u - 1, -one, 1 - 2 * v),
        "forward":  (2 * u - 1, 2 * v - 1, one),
        "backward": (1 - 2 * u, 2 * v - 1, -one),
    }[face]
    d = np.stack(d, axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def sky_radiance(directions: np.ndarray) -> np.ndarray:
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("scalar_rgb" if "llvm_ad_rgb" not in mi.variants() else "llvm_ad_rgb")
    sky = mi.load_dict({"type": "sunsky", "hour": 15.5, "turbidity": 3.0})
    flat = directions.reshape(-1, 3)
    # sunsky has +z up; the tutorial has +y up (x kept, so the sun stays to one side).
    mitsuba_dirs = np.stack([flat[:, 0], -flat[:, 2], flat[:, 1]], axis=0).astype(np.float32)
    si = dr.zeros(mi.SurfaceInteraction3f, flat.shape[0])
    si.wi = -mi.Vector3f(mitsuba_dirs)
    radiance = np.array(sky.eval(si), dtype=np.float64).T
    radiance[flat[:, 1] < 0.01] = GROUND  # below the horizon: a plain ground
    return (SCALE * radiance).reshape(directions.shape)


def write_tga(path: Path, rgb8: np.ndarray) -> None:
    """24-bit uncompressed TGA, bottom-left origin; row 0 of ``rgb8`` is stored first."""
    h, w, _ = rgb8.shape
    header = bytes([0, 0, 2]) + bytes(9) + w.to_bytes(2, "little") + h.to_bytes(2, "little") + bytes([24, 0])
    path.write_bytes(header + np.ascontiguousarray(rgb8[:, :, ::-1]).tobytes())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=256)
    args = parser.parse_args()
    here = Path(__file__).resolve().parent
    import mitsuba as mi
    for face in FACES:
        radiance = sky_radiance(face_directions(face, args.size))
        encoded = np.clip(1.001 - np.exp(-radiance), 0, 1) ** (1 / 2.2)
        write_tga(here / f"sky{face}.tga", np.floor(encoded * 255 + 0.5).astype(np.uint8))
        # Row 0 of `radiance` is v = 0, the bottom row as a viewer shows the TGA: flip it
        # so that the EXR shows the same picture (EXR rows are stored top first).
        mi.Bitmap(np.ascontiguousarray(radiance[::-1], dtype=np.float32)).write(
            str(here / f"sky{face}.exr"))
        print(f"sky{face}: radiance {radiance.min():.3g} .. {radiance.max():.3g}")


if __name__ == "__main__":
    main()
