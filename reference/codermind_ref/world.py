"""The scene's objects as arrays: nearest hit, shadow test, normals and material lookup.

Object ids: spheres 0..S-1, blobs S..S+B-1, -1 = none. Page 4 tests blobs first (a root <= t
counts) and then spheres (a sphere wins only if strictly closer), as the original does.
"""

from __future__ import annotations

import numpy as np

from . import blob, sphere
from .cubemap import Environment
from .materials import MaterialTable
from .quirks import STRICT, Quirks
from .scene import Scene


class World:
    """``dtype``: float32 reproduces the float arithmetic of the page 1 and 2 programs (their
    output is deterministic and byte-exact); page 4 runs in float64 (its Perlin noise is double
    in the original, and its output is stochastic).

    ``ties``: which of two spheres a ray hits at exactly the same distance. "first" (the
    original): the one listed first, a later one wins only if strictly closer. "last": the
    later one. A renderer without the file's order (Mitsuba's BVH) may take either; page 1's
    spheres 0 and 1 meet on the plane x = 320, which the camera's column 320 sees at exactly
    equal distances."""

    def __init__(self, scene: Scene, dtype=np.float64, ties: str = "first"):
        if ties not in ("first", "last"):
            raise ValueError(f"ties must be 'first' or 'last', got {ties!r}")
        self.page = scene.page
        self.ties_last = ties == "last"
        self.dtype = dtype
        self.spheres = [(np.array(s.center, dtype=dtype).reshape(3, 1), dtype(s.size))
                        for s in scene.spheres]
        self.blobs = [(np.array(b.centers, dtype=np.float64), float(b.size)) for b in scene.blobs]
        self.object_material = np.array([s.material_id for s in scene.spheres]
                                        + [b.material_id for b in scene.blobs], dtype=np.intp)
        self.materials = MaterialTable(scene, dtype)
        self.light_position = [np.array(l.position, dtype=dtype).reshape(3, 1) for l in scene.lights]
        self.light_intensity = [np.array(l.intensity, dtype=dtype).reshape(3, 1) for l in scene.lights]
        self.environment = Environment(scene.cubemap)

    def intersect(self, o: np.ndarray, d: np.ndarray, t: np.ndarray, quirks: Quirks = STRICT
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Nearest hit before t: (t, object id), id -1 where nothing is hit. quirks: whether
        blobs use the original's float32 sums (``blob_float32``)."""
        obj = np.full(t.shape, -1, dtype=np.intp)
        # spheres first, then blobs up to the sphere hit: a blob root <= t still wins, so this
        # is the original's order (blobs, then strictly closer spheres), with a shorter
        # segment to cull the blob test against
        for i, (center, radius) in enumerate(self.spheres):
            if self.ties_last:   # roots up to the next float above t: a root equal to t too
                t_new = sphere.hit(o, d, np.nextafter(t, np.inf), center, radius)
                hit = t_new <= t
                t_new = np.where(hit, t_new, t)
            else:
                t_new = sphere.hit(o, d, t, center, radius)
                hit = t_new < t
            obj = np.where(hit, i, obj)
            t = t_new
        first = len(self.spheres)
        for i, (centers, radius) in enumerate(self.blobs):
            t, hit = blob.hit(o, d, t, centers, radius, quirks.blob_float32)
            obj = np.where(hit, first + i, obj)
        return t, obj

    def occluded(self, o: np.ndarray, d: np.ndarray, tmax: np.ndarray, quirks: Quirks = STRICT
                 ) -> np.ndarray:
        """Shadow test: any object hit at a distance in (epsilon, tmax)."""
        blocked = np.zeros(tmax.shape, dtype=bool)
        for center, radius in self.spheres:
            blocked |= sphere.hit(o, d, tmax, center, radius) < tmax
        rest = np.flatnonzero(~blocked)
        for centers, radius in self.blobs:
            if rest.size == 0:
                break
            t = tmax[rest]
            hit = blob.hit(o[:, rest], d[:, rest], t, centers, radius, quirks.blob_float32)[1]
            blocked[rest[hit]] = True
            rest = rest[~hit]
        return blocked

    def normal(self, p: np.ndarray, obj: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unit normals at hit points p of objects obj, and a mask of zero-length normals."""
        n = np.empty_like(p)
        zero = np.zeros(obj.shape, dtype=bool)
        first = len(self.spheres)
        for i, (center, radius) in enumerate(self.spheres):
            sel = np.flatnonzero(obj == i)
            if sel.size:
                n[:, sel], zero[sel] = sphere.normal(p[:, sel], center)
        for i, (centers, radius) in enumerate(self.blobs):
            sel = np.flatnonzero(obj == first + i)
            if sel.size:
                n[:, sel], zero[sel] = blob.normal(p[:, sel], centers, radius)
        return n, zero
