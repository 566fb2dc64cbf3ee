"""Small tutorial-format scenes and cube-map faces for the port's tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

FACES = ("Up", "Down", "Right", "Left", "Forward", "Backward")


def write_face(path: Path, texels) -> None:
    """An uncompressed 24-bit TGA whose stored rows are ``texels`` (rows, cols, 3) RGB bytes."""
    texels = np.asarray(texels, dtype=np.uint8)
    h, w, _ = texels.shape
    header = bytes([0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, w & 255, w >> 8, h & 255, h >> 8, 24, 0])
    path.write_bytes(header + texels[:, :, ::-1].tobytes())


def write_cubemap(folder: Path, colours: dict[str, tuple[int, int, int]] | None = None,
                  size: int = 2) -> str:
    """Six uniform faces (default: a distinct colour per face); returns the Scene keys."""
    colours = colours or {"Up": (200, 10, 10), "Down": (10, 200, 10), "Right": (10, 10, 200),
                          "Left": (200, 200, 10), "Forward": (10, 200, 200),
                          "Backward": (200, 10, 200)}
    keys = ""
    for face in FACES:
        write_face(folder / f"{face.lower()}.tga", np.full((size, size, 3), colours[face]))
        keys += f"Cubemap.{face} = {face.lower()}.tga;\n"
    return keys


def uniform_cubemap(folder: Path, rgb: tuple[int, int, int]) -> str:
    """Six faces of one colour; returns the Scene keys."""
    return write_cubemap(folder, {face: rgb for face in FACES})


def write_scene(folder: Path, version: str, scene: str, objects: str, name: str = "scene.txt") -> Path:
    major, minor = version.split(".")
    path = folder / name
    path.write_text(f"Scene {{\nVersion.Major = {major};\nVersion.Minor = {minor};\n{scene}}}\n"
                    + objects)
    return path
