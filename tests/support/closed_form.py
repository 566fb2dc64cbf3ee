"""Closed-form expectations for the tutorial material (facts.md F7, F8) in numpy float64,
and a renderer that returns each pixel's radiance with its hit position (1 spp, box
filter, position AOV), shared by the tutorial-material and bump tests."""

from __future__ import annotations

import numpy as np

LIGHT = np.array([3.0, 3.0, 1.0])
INTENSITY = np.array([1.0, 0.8, 0.6])
DIFFUSE = np.array([0.6, 0.5, 0.4])
SPECULAR, POWER = 0.8, 60.0
CENTER, RADIUS = np.array([0.0, 0.0, 5.0]), 1.0


def rgb(v):
    return {"type": "rgb", "value": [float(x) for x in np.broadcast_to(v, 3)]}


def material(page=2, diffuse=DIFFUSE, specular=SPECULAR, power=POWER, **extra):
    return {"type": "tutorial", "page": page, "diffuse": rgb(diffuse),
            "specular": rgb(specular), "power": power, **extra}


def render_with_positions(mi, objects, max_depth, size=48, fov=30.0, light=LIGHT):
    """Render with path at 1 spp (box filter) and return (radiance, hit position) per pixel."""
    T = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "aov", "aovs": "pp:position",
                       "inner": {"type": "path", "max_depth": max_depth, "rr_depth": 100}},
        "sensor": {"type": "perspective", "fov": fov,
                   "to_world": T().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": size, "height": size,
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": 1}},
        "light": {"type": "tutorialpoint", "position": list(light), "intensity": rgb(INTENSITY)},
        **objects,
    })
    img = mi.render(scene, seed=7).numpy().astype(np.float64)
    return img[..., :3].reshape(-1, 3), img[..., 3:6].reshape(-1, 3)


def normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def lighting(p, n, view, diffuse=DIFFUSE, specular=SPECULAR, power=POWER, light=LIGHT):
    """The tutorial's shading of points p (normal n, unit direction to the viewer) by the
    light: I (Diffuse (L.n) + Specular max(n.H, 0)^Power), 0 where L.n <= 0."""
    to_light = normalize(light - p)
    cos_l = np.sum(to_light * n, axis=-1)
    h = normalize(to_light + view)
    blinn = np.maximum(np.sum(n * h, axis=-1), 0) ** power
    value = INTENSITY * (np.asarray(diffuse) * cos_l[:, None] + specular * blinn[:, None])
    return np.where((cos_l > 0)[:, None], value, 0.0)


def fresnel(cos_i, n1, n2):
    """facts.md F8 step 1: reflectance and cos_t (independent transcription)."""
    sin_t2 = (n1 / n2) ** 2 * (1 - cos_i ** 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_t = np.sqrt(np.maximum(1 - sin_t2, 0))
        rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)
        rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t)
    r = np.where(cos_i >= 0.999, ((n1 - n2) / (n1 + n2)) ** 2,
                 np.where(sin_t2 > 0.9999, 1.0, (rs ** 2 + rp ** 2) / 2))
    cos_t = np.where(cos_i >= 0.999, 1.0, np.where(sin_t2 > 0.9999, 0.0, cos_t))
    return r, cos_t


def sphere_hit_mask(pos, center, radius, tol=1e-3):
    return np.abs(np.linalg.norm(pos - center, axis=-1) - radius) < tol
