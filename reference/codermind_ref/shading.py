"""Direct lighting at a hit (facts.md F7): point lights without falloff, shadows, Lambert and
Blinn. Nothing is added for a light with L.n <= 0 or a blocked shadow ray."""

from __future__ import annotations

import numpy as np

from .materials import GOURAUD
from .quirks import Quirks
from .vec import dot
from .world import World


def direct(world: World, p: np.ndarray, n: np.ndarray, d: np.ndarray, coef: np.ndarray,
           mat: np.ndarray, colour: np.ndarray, quirks: Quirks) -> np.ndarray:
    """Light (3, N) added at points p with normals n (facing the viewer), view directions d,
    path weights coef, material ids mat and surface colours colour."""
    page = world.page
    mt = world.materials
    out = np.zeros_like(p)
    squared = page >= 2 and quirks.shadow_squared
    lambert_coef = coef
    if page >= 4 and quirks.coef_squared:
        lambert_coef = np.where(mt.kind[mat] != GOURAUD, coef * coef, coef)
    if page >= 2:
        view = dot(d, n)
        spec, power = mt.specular[:, mat], mt.power[mat]
    for position, intensity in zip(world.light_position, world.light_intensity):
        dist = position - p
        lit = np.flatnonzero(dot(n, dist) > 0.0)
        if lit.size == 0:
            continue
        dl = dist[:, lit]
        length2 = dot(dl, dl)
        length = np.sqrt(length2)
        ok = length > 0.0
        lit, dl, length2, length = lit[ok], dl[:, ok], length2[ok], length[ok]
        ldir = (1.0 / length) * dl
        blocked = world.occluded(p[:, lit], ldir, length2 if squared else length, quirks)
        lit, ldir = lit[~blocked], ldir[:, ~blocked]
        if lit.size == 0:
            continue
        nl = n[:, lit]
        projection = dot(ldir, nl)
        lambert = projection * lambert_coef[lit]
        out[:, lit] += lambert * intensity * colour[:, lit]
        if page >= 2:
            half = ldir - d[:, lit]
            h2 = dot(half, half)
            with np.errstate(divide="ignore", invalid="ignore"):
                blinn = (1.0 / np.sqrt(h2)) * np.maximum(projection - view[lit], 0.0)
                blinn = coef[lit] * blinn ** power[lit]
            blinn = np.where(h2 != 0.0, blinn, 0.0)
            out[:, lit] += blinn * spec[:, lit] * intensity
    return out
