"""A reference render as the other side of ``codermind compare --reference IMAGE``.

* An 8-bit image (``.tga``: uncompressed 24- or 32-bit, either origin; ``.png``: 8-bit grey,
  RGB or RGBA) is the displayed image, W x H, and is compared with our side's displayed
  bytes (the tutorial's pipeline, the calibration strip rows left out);
* an ``.exr`` is the linear film (``codermind render`` writes it: W x H on page 1, the
  2W x 2H sub-samples on pages 2-4) and is compared on linear values.

:func:`read` returns the image in display order (row 0 = top), or raises
:class:`~codermind_harness.sides.HarnessError` with a one-line message naming the file.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import codermind_ref.png as png

from .sides import Grid, HarnessError

KINDS = {".tga": "8-bit", ".png": "8-bit", ".exr": "linear"}


@dataclass
class Reference:
    path: Path
    kind: str                  #: "8-bit" (displayed image) or "linear" (EXR film)
    image: np.ndarray          #: uint8 (H, W, 3) or float64 (film H, film W, 3), display order

    def grid_pixels(self, grid: Grid) -> np.ndarray:
        """The displayed pixels of ``grid`` (8-bit), in the grid's display order."""
        rows = grid.height - 1 - grid.ys[::-1]
        return self.image[np.ix_(rows, grid.xs)]

    def grid_film(self, grid: Grid) -> np.ndarray:
        """The film sub-samples of ``grid`` (linear), as :meth:`Grid.take` orders them."""
        (ox, oy), (w, h) = grid.crop()
        return grid.take(self.image[oy:oy + h, ox:ox + w])


def read(path: str | os.PathLike, width: int, height: int, sub: int) -> Reference:
    """The reference image, checked against the scene's size (``sub``: sub-samples per axis
    of its film, 1 on page 1, else 2)."""
    path = Path(path)
    kind = KINDS.get(path.suffix.lower())
    if kind is None:
        raise HarnessError(f"{path}: --reference must be a .tga, .png or .exr file")
    try:
        data = path.read_bytes()
    except OSError as e:
        raise HarnessError(f"{path}: cannot read: {e.strerror or e}") from None
    try:
        if path.suffix.lower() == ".tga":
            image = _tga(data)
        elif path.suffix.lower() == ".png":
            image = _rgb(png.decode(data))
        else:
            image = _exr(path)
    except (ValueError, RuntimeError, KeyError, IndexError) as e:
        raise HarnessError(f"{path}: cannot decode: {' '.join(str(e).split()) or type(e).__name__}"
                           ) from None
    want = (height, width) if kind == "8-bit" else (sub * height, sub * width)
    if image.shape[:2] != want:
        what = "displayed image" if kind == "8-bit" else "linear film (codermind render's EXR)"
        raise HarnessError(f"{path}: {image.shape[1]}x{image.shape[0]}, but the scene's "
                           f"{what} is {want[1]}x{want[0]}")
    if kind == "linear" and not np.isfinite(image).all():
        raise HarnessError(f"{path}: {int((~np.isfinite(image)).sum())} NaN or infinite values")
    return Reference(path, kind, image)


def _rgb(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[2] in (1, 2):                 # grey (with alpha)
        a = np.repeat(a[..., :1], 3, axis=2)
    return np.ascontiguousarray(a[..., :3])


def _tga(data: bytes) -> np.ndarray:
    if len(data) < 18:
        raise ValueError("too short for a TGA header")
    if data[2] != 2:
        raise ValueError(f"TGA image type {data[2]}: only uncompressed true colour (2) is read")
    bits = data[16]
    if bits not in (24, 32):
        raise ValueError(f"{bits} bits per pixel: only 24 and 32 are read")
    w, h = data[12] | data[13] << 8, data[14] | data[15] << 8
    start = 18 + data[0] + (data[5] | data[6] << 8) * (data[7] // 8 if data[1] else 0)
    count = w * h * (bits // 8)
    if w == 0 or h == 0 or len(data) < start + count:
        raise ValueError(f"truncated or empty ({w}x{h})")
    px = np.frombuffer(data, np.uint8, count, start).reshape(h, w, bits // 8)[..., 2::-1]
    if not data[17] & 0x20:                  # bottom-left origin: rows from the bottom up
        px = px[::-1]
    if data[17] & 0x10:                      # right-to-left
        px = px[:, ::-1]
    return np.ascontiguousarray(px)


def _exr(path: Path) -> np.ndarray:
    from codermind.imageio import read_exr
    a = read_exr(path)
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[2] < 3:
        a = np.repeat(a[..., :1], 3, axis=2)
    return a[..., :3].astype(np.float64)
