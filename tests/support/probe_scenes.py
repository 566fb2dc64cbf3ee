"""Small page-4 tutorial scenes for the auto-exposure probes (tests/harness/test_compare_probes.py):
a glass sphere, a half mirror, and random-ish scenes drawn from a seed (spheres with random
tutorial materials in front of the camera, one or two lights, a cube map of random colours)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .port_scenes import FACES, write_cubemap, write_scene

HEAD = """Image.Width = {w};
Image.Height = {h};
Perspective.Type = conic;
Perspective.FOV = 90.0;
Perspective.ClearPoint = 450.0;
Perspective.Dispersion = 0.0;
Tonemap.Midpoint = 0.7;
Tonemap.Power = 3.0;
Tonemap.Black = 0.1;
NumberOfMaterials = {materials};
NumberOfSpheres = {spheres};
NumberOfLights = {lights};
Complexity = 4;
{keys}Cubemap.Exposed = true;
Cubemap.sRGB = true;
"""

#: A glass sphere (Density 1.5, Reflection 0.8, Refraction 0.8) over a diffuse one.
GLASS = """Material0 { Type = gouraud; Diffuse = 0.0, 0.0, 0.0; Density = 1.5; Reflection = 0.8; Refraction = 0.8; Specular = 1.2, 1.2, 1.2; Power = 60; }
Material1 { Type = gouraud; Diffuse = 0.7, 0.5, 0.3; Density = 1.0; Reflection = 0.0; Refraction = 0.0; Specular = 0.5, 0.5, 0.5; Power = 20; }
Sphere0 { Center = 32.0, 24.0, 60.0; Size = 25.0; Material.Id = 0; }
Sphere1 { Center = 32.0, -40.0, 80.0; Size = 50.0; Material.Id = 1; }
Light0 { Position = 0.0, 60.0, 0.0; Intensity = 1.0, 1.0, 1.0; }
"""

#: A lit metal that reflects half the time (Density 0, Reflection 0.5) under a dark sky: the
#: original lights a hit only when its draw picks "diffuse", which E (a root mean square)
#: sees.
HALF_MIRROR = """Material0 { Type = gouraud; Diffuse = 0.8, 0.8, 0.8; Density = 0.0; Reflection = 0.5; Refraction = 0.0; Specular = 0.0, 0.0, 0.0; Power = 60; }
Material1 { Type = gouraud; Diffuse = 0.7, 0.5, 0.3; Density = 1.0; Reflection = 0.0; Refraction = 0.0; Specular = 0.5, 0.5, 0.5; Power = 20; }
Sphere0 { Center = 32.0, 24.0, 60.0; Size = 40.0; Material.Id = 0; }
Sphere1 { Center = 32.0, -40.0, 80.0; Size = 50.0; Material.Id = 1; }
Light0 { Position = 0.0, 60.0, 0.0; Intensity = 1.0, 1.0, 1.0; }
"""


def write(folder: Path, objects: str, counts: tuple[int, int, int] = (2, 2, 1),
          sky: dict | None = None, size: tuple[int, int] = (64, 48)) -> Path:
    """A scene file of ``objects`` (materials, spheres, lights ``counts``) in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    keys = write_cubemap(folder, sky)
    head = HEAD.format(w=size[0], h=size[1], materials=counts[0], spheres=counts[1],
                       lights=counts[2], keys=keys)
    return write_scene(folder, "1.3", head, objects)


def random_scene(folder: Path, seed: int) -> Path:
    """Two or three spheres with random tutorial materials (glass, metal, partial mirrors,
    diffuse) in view of a 64 x 48 camera, one or two lights, a random sky."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 4))
    text = []
    for k in range(n):
        kind = rng.choice(["glass", "metal", "diffuse"])
        diffuse = rng.uniform(0.1, 0.9, 3) if kind != "glass" else np.zeros(3)
        density = {"glass": rng.uniform(1.2, 2.2), "metal": 0.0, "diffuse": 1.0}[kind]
        refl = {"glass": rng.uniform(0.5, 1.0), "metal": rng.uniform(0.2, 0.8),
                "diffuse": 0.0}[kind]
        refr = rng.uniform(0.5, 1.0) if kind == "glass" else 0.0
        spec = rng.uniform(0.0, 1.2)
        text.append(f"Material{k} {{ Type = gouraud; Diffuse = {_v(diffuse)}; "
                    f"Density = {density:.3f}; Reflection = {refl:.3f}; "
                    f"Refraction = {refr:.3f}; Specular = {_v([spec] * 3)}; Power = 40; }}")
    for k in range(n):
        centre = [rng.uniform(8, 56), rng.uniform(4, 44), rng.uniform(40, 90)]
        text.append(f"Sphere{k} {{ Center = {_v(centre)}; Size = {rng.uniform(10, 25):.2f}; "
                    f"Material.Id = {k}; }}")
    lights = int(rng.integers(1, 3))
    for k in range(lights):
        pos = [rng.uniform(-40, 100), rng.uniform(0, 100), rng.uniform(-50, 40)]
        text.append(f"Light{k} {{ Position = {_v(pos)}; Intensity = "
                    f"{_v(rng.uniform(0.3, 1.0, 3))}; }}")
    sky = {face: tuple(int(x) for x in rng.integers(0, 256, 3)) for face in FACES}
    return write(folder, "\n".join(text) + "\n", (n, n, lights), sky)


def _v(values) -> str:
    return ", ".join(f"{float(x):.4f}" for x in values)
