"""Uncompressed 24-bit TGA: the cube-map face loader of facts.md F12 and the output writer of 2.1.

Reading follows the original loader: only header byte 2 (image type, must be 2) and bytes
12-15 (width, height) are used and pixels are taken in stored order (row 0 = first stored row,
the bottom row of a bottom-left-origin file) as B, G, R bytes / 255. Where a file would make
that loader misread it (an image-ID field, not 24 bits per pixel, a size whose low byte is >=
128, which the original reads through a signed char) :class:`TgaError` is raised instead of
silently producing garbage; a top-left origin flag gives a warning (the loader ignores it).
"""

from __future__ import annotations

import os

import numpy as np

from .files import write_atomic


class TgaError(ValueError):
    """A face the tutorial's loader cannot read correctly; the message says why."""


#: Largest face read, in pixels (16384 x 16384: 6.4 GiB of float64 per face once decoded).
#: A TGA header can claim up to 65535 x 65535 (12.9 GB); the size is checked against this
#: and against the file's size before any pixel is read.
MAX_FACE_PIXELS = 16384 * 16384


def _check_size(path, header: bytes, size: int) -> None:
    width, height = header[12] | header[13] << 8, header[14] | header[15] << 8
    if width * height > MAX_FACE_PIXELS:
        raise TgaError(f"'{path}' claims {width}x{height} pixels, more than the "
                       f"{MAX_FACE_PIXELS} a face may have (16384 x 16384)")
    if header[2] == 2 and header[16] == 24 and size < 18 + width * height * 3:
        raise TgaError(f"'{path}' is truncated ({max(size - 18, 0)} of {width * height * 3} "
                       "pixel bytes)")


def read_face(path: str | os.PathLike) -> tuple[np.ndarray, list[str]]:
    """Load a face as the original does: float64 array (rows, cols, 3) in stored row order,
    RGB, values byte / 255; returns (pixels, warnings)."""
    try:
        with open(path, "rb") as f:
            data = f.read(18)
            size = os.fstat(f.fileno()).st_size
            if len(data) == 18:
                _check_size(path, data, size)
                data += f.read((data[12] | data[13] << 8) * (data[14] | data[15] << 8) * 3)
    except OSError as e:
        raise TgaError(f"cannot read '{path}': {e.strerror or e}") from None
    if len(data) < 18:
        raise TgaError(f"'{path}' is too short to be a TGA file")
    if data[2] != 2:
        raise TgaError(f"'{path}' has TGA image type {data[2]}; only type 2 (uncompressed "
                       "true colour) is supported")
    width, height = data[12] | data[13] << 8, data[14] | data[15] << 8
    if data[0] != 0:
        raise TgaError(f"'{path}' has an image-ID field, which the original loader does not skip")
    if data[16] != 24:
        raise TgaError(f"'{path}' has {data[16]} bits per pixel; the loader reads 24-bit B,G,R")
    if width & 0x80 or height & 0x80:
        raise TgaError(f"'{path}' is {width}x{height}: the original loader reads sizes through "
                       "a signed char and misreads a size whose low byte is >= 128")
    if width == 0 or height == 0:
        raise TgaError(f"'{path}' has an empty image ({width}x{height})")
    count = width * height * 3
    if len(data) < 18 + count:
        raise TgaError(f"'{path}' is truncated ({len(data) - 18} of {count} pixel bytes)")
    bgr = np.frombuffer(data, np.uint8, count, 18).reshape(height, width, 3)
    warnings = []
    if data[17] & 0x20:
        warnings.append(f"'{path}' has a top-left origin; read in stored order as the original "
                        "does, so it appears upside down")
    return bgr[:, :, ::-1] / 255.0, warnings


def encode(rgb_rows: np.ndarray) -> bytes:
    """TGA bytes of an (H, W, 3) uint8 RGB array whose row 0 is the BOTTOM row (tutorial y=0),
    with the original's header: type 2, 24 bits, descriptor 0 (bottom-left origin)."""
    h, w, _ = rgb_rows.shape
    header = bytes([0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                    w & 255, w >> 8, h & 255, h >> 8, 24, 0])
    return header + np.ascontiguousarray(rgb_rows[:, :, ::-1], np.uint8).tobytes()


def write(path: str | os.PathLike, rgb_rows: np.ndarray) -> None:
    """Write :func:`encode` of ``rgb_rows`` atomically."""
    write_atomic(path, encode(rgb_rows))
