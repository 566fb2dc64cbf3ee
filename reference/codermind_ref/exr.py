"""Minimal OpenEXR writer: single-part scanline image, float32 channels, ZIP (zlib, 16 lines
per chunk, with OpenEXR's byte interleave and delta predictor) or no compression."""

from __future__ import annotations

import os
import struct
import zlib

import numpy as np

from .files import write_atomic

NO_COMPRESSION, ZIP_COMPRESSION = 0, 3
_FLOAT = 2


def _attribute(name: str, kind: str, value: bytes) -> bytes:
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def _zip(raw: bytes) -> bytes:
    b = np.frombuffer(raw, np.uint8)
    t = np.concatenate((b[0::2], b[1::2]))
    t[1:] = (t[1:].astype(np.int16) - t[:-1] + 128).astype(np.uint8)   # wraps mod 256
    packed = zlib.compress(t.tobytes(), 6)
    return packed if len(packed) < len(raw) else raw


def encode(channels: dict[str, np.ndarray], compression: int = ZIP_COMPRESSION) -> bytes:
    """EXR bytes of same-shape (H, W) arrays by channel name (row 0 = top)."""
    names = sorted(channels)                       # EXR wants the channel list sorted
    h, w = channels[names[0]].shape
    data = np.stack([np.asarray(channels[n], dtype="<f4") for n in names], axis=1)  # (H, C, W)
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", _FLOAT, 0, 1, 1)
                      for n in names) + b"\0"
    window = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<i", 2)
              + _attribute("channels", "chlist", chlist)
              + _attribute("compression", "compression", bytes([compression]))
              + _attribute("dataWindow", "box2i", window)
              + _attribute("displayWindow", "box2i", window)
              + _attribute("lineOrder", "lineOrder", b"\0")
              + _attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + _attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
              + _attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    lines = 16 if compression == ZIP_COMPRESSION else 1
    chunks = []
    for y in range(0, h, lines):
        raw = data[y:y + lines].tobytes()
        body = _zip(raw) if compression == ZIP_COMPRESSION else raw
        chunks.append(struct.pack("<ii", y, len(body)) + body)
    offset = len(header) + 8 * len(chunks)
    table = []
    for chunk in chunks:
        table.append(struct.pack("<Q", offset))
        offset += len(chunk)
    return header + b"".join(table) + b"".join(chunks)


def write(path: str | os.PathLike, image: np.ndarray, names=("R", "G", "B"),
          compression: int = ZIP_COMPRESSION) -> None:
    """Write an (H, W, C) float image (row 0 = top) with channel names, atomically."""
    image = np.asarray(image)
    write_atomic(path, encode({n: image[:, :, i] for i, n in enumerate(names)}, compression))
