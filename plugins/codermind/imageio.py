"""Atomic image output: a file is either absent, the old version, or complete.

Each image is written to a hidden temporary file in the destination folder,
flushed to disk, then renamed over the destination (``os.replace`` is atomic on
POSIX). A failure removes the temporary file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator, Sequence

import mitsuba as mi
import numpy as np


@contextlib.contextmanager
def atomic_path(dest: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path next to ``dest``; on success rename it to ``dest``."""
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    # The pid in the name: a later run can tell a killed run's leftover from a live one's
    # (codermind_cli.outputs.recover_leftovers).
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.codermind-{os.getpid()}-",
                               suffix=suffix + ".tmp", dir=dest.parent)
    os.close(fd)
    tmp = Path(tmp)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the usual mode
    try:
        yield tmp
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, dest)
    finally:
        tmp.unlink(missing_ok=True)


def _bitmap(image: np.ndarray, channel_names: Sequence[str] | None) -> mi.Bitmap:
    image = np.ascontiguousarray(image, dtype=np.float32)
    if image.ndim == 2:
        image = image[:, :, None]
    channels = image.shape[2]
    if channel_names is None or len(channel_names) != channels:
        channel_names = {1: ["Y"], 3: ["R", "G", "B"], 4: ["R", "G", "B", "A"]}.get(
            channels, [f"ch{i}" for i in range(channels)])
    fmt = {("Y",): mi.Bitmap.PixelFormat.Y, ("R", "G", "B"): mi.Bitmap.PixelFormat.RGB,
           ("R", "G", "B", "A"): mi.Bitmap.PixelFormat.RGBA}.get(tuple(channel_names),
                                                                 mi.Bitmap.PixelFormat.MultiChannel)
    return mi.Bitmap(image, fmt, list(channel_names))


def write_exr(path: str | os.PathLike, image: np.ndarray,
              channel_names: Sequence[str] | None = None) -> None:
    """Write a float32 linear EXR atomically (lossless PIZ compression)."""
    bmp = _bitmap(image, channel_names)
    with atomic_path(path) as tmp:
        bmp.write(str(tmp), mi.Bitmap.FileFormat.OpenEXR)


#: Pixels converted to sRGB bytes at once by :func:`write_png_srgb`.
PNG_CHUNK = 1 << 20


def write_png_srgb(path: str | os.PathLike, rgb: np.ndarray) -> None:
    """Write linear RGB as an 8-bit sRGB PNG atomically (clamped, rounded); one channel
    (a ``mono`` variant's luminance) is written grey. Converted in bands of rows of about
    ``PNG_CHUNK`` pixels, so that besides ``rgb`` only the bytes are image-sized. Mitsuba's
    8-bit conversion dithers with a pattern that starts again in each band: a byte may
    differ by one level from a whole-image conversion (never more), the same on every run."""
    rgb = np.asarray(rgb, dtype=np.float32)
    if rgb.ndim == 2:
        rgb = rgb.reshape(rgb.shape[0], rgb.shape[1], 1)
    h, w = rgb.shape[:2]
    out = np.empty((h, w, 3), dtype=np.uint8)
    rows = max(1, PNG_CHUNK // max(w, 1))
    for y in range(0, h, rows):
        band = rgb[y:y + rows]
        if band.shape[2] == 1:
            band = np.repeat(band, 3, axis=2)
        band = np.nan_to_num(band[:, :, :3], nan=0.0, posinf=1.0)
        bmp = mi.Bitmap(np.ascontiguousarray(band), mi.Bitmap.PixelFormat.RGB)
        bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True)
        out[y:y + rows] = np.array(bmp, copy=False)
    write_png_bytes(path, out)


def write_png_bytes(path: str | os.PathLike, pixels: np.ndarray) -> None:
    """Write an 8-bit RGB (H, W, 3) array as PNG atomically, as given."""
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    bmp = mi.Bitmap(pixels, mi.Bitmap.PixelFormat.RGB)
    with atomic_path(path) as tmp:
        bmp.write(str(tmp), mi.Bitmap.FileFormat.PNG)


def read_exr(path: str | os.PathLike) -> np.ndarray:
    """Read an EXR as a float32 (H, W, C) array."""
    return np.array(mi.Bitmap(str(path)), copy=True, dtype=np.float32)
