"""The port's image files: TGA as the original writes it, PNG, and float32 EXR."""

from __future__ import annotations

import numpy as np
import Imath
import OpenEXR
import pytest

from codermind_ref import exr, png, tga


def _read_exr(path):
    f = OpenEXR.InputFile(str(path))
    header = f.header()
    box = header["dataWindow"]
    shape = (box.max.y - box.min.y + 1, box.max.x - box.min.x + 1)
    channels = {name: np.frombuffer(f.channel(name, Imath.PixelType(Imath.PixelType.FLOAT)),
                                    np.float32).reshape(shape) for name in header["channels"]}
    return channels, header


@pytest.mark.parametrize("compression", [exr.NO_COMPRESSION, exr.ZIP_COMPRESSION])
def test_exr_round_trip_through_openexr(tmp_path, compression):
    rng = np.random.default_rng(0)
    image = np.concatenate([np.linspace(0, 4, 37 * 53 * 2).reshape(37, 53, 2),
                            rng.normal(size=(37, 53, 1))], axis=2).astype(np.float32)
    image[0, 0, 2] = np.nan
    exr.write(tmp_path / "a.exr", image, compression=compression)
    channels, header = _read_exr(tmp_path / "a.exr")
    back = np.stack([channels[c] for c in "RGB"], axis=2)
    assert back.dtype == np.float32 and back.shape == (37, 53, 3)
    assert np.array_equal(back, image, equal_nan=True)
    assert header["compression"].v == compression


def test_zip_exr_compresses_smooth_images(tmp_path):
    image = np.broadcast_to(np.linspace(0, 1, 64, dtype=np.float32)[None, :, None], (64, 64, 3))
    exr.write(tmp_path / "s.exr", image)
    assert (tmp_path / "s.exr").stat().st_size < image.nbytes / 4
    channels, _ = _read_exr(tmp_path / "s.exr")
    assert np.array_equal(channels["G"], image[:, :, 1])


def test_png_round_trip(tmp_path):
    image = np.random.default_rng(1).integers(0, 256, (20, 30, 3), dtype=np.uint8)
    png.write(tmp_path / "a.png", image)
    assert np.array_equal(png.decode((tmp_path / "a.png").read_bytes()), image)


def test_tga_output_layout_and_face_reading(tmp_path):
    rows = np.zeros((2, 3, 3), np.uint8)
    rows[0, 0] = (1, 2, 3)           # tutorial row y = 0, x = 0: the first stored pixel
    rows[1, 2] = (7, 8, 9)
    data = tga.encode(rows)
    assert data[:18] == bytes([0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 2, 0, 24, 0])
    assert data[18:21] == bytes([3, 2, 1]) and data[-3:] == bytes([9, 8, 7])   # B, G, R
    tga.write(tmp_path / "a.tga", rows)
    pixels, warnings = tga.read_face(tmp_path / "a.tga")
    assert warnings == [] and np.array_equal(pixels * 255, rows)


def test_tga_face_with_signed_char_size_is_refused(tmp_path):
    header = bytes([0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 128, 2, 1, 0, 24, 0])   # 640 x 1
    (tmp_path / "f.tga").write_bytes(header + bytes(640 * 3))
    with pytest.raises(tga.TgaError, match="signed char"):
        tga.read_face(tmp_path / "f.tga")
