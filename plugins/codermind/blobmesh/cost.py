"""What a blob mesh will cost, estimated before it is built (numpy only, a few tens of ms).

The mesher refines until every triangle is within ``max_error`` of the surface. A triangle
of circumradius r on a surface of largest principal curvature kappa deviates from it by
about r^2 kappa / 2, so the triangles it ends with have areas proportional to
``max_error / kappa`` and their number is about

    N = K * integral(kappa dA) / max_error,

at least the first marching-cubes pass's ``K0 * area / h0^2`` (h0 its cell size, which is at
most R/6). The integrals are taken over the surface by rays from each centre (every centre
lies inside it): a ray's first exit point q, where its source's term is the largest of the
field (each point of the surface is counted from one source), contributes
``t^2 / |n . w| dw`` (the area the ray's solid angle cuts out at distance t).

K, K0 and the cost per triangle were measured by ``benchmarks/calibrate_blob_cost.py``
(spheres, pairs, the page-4 blob and 12 random blobs of 2-6 sources, max_error R/5000 to
R/100, both fields; ``tests/plugins/test_blob_mesh.py`` checks the factor on random blobs): the
mesher's triangle count was 0.86-1.13 times the estimate for every mesh above 12 000
triangles; below, coarse zone-field blobs of several sources had up to 1.8 times it (the
cut along the field's creases adds triangles that the first pass's term does not count),
hence ``ACCURACY``. The mesher's peak memory (numpy, by tracemalloc) was a median 450 bytes
per triangle (up to 550 for meshes above 12 000 triangles), and the page-4 blob at
1e-7 reached 3.4 GB of resident memory for 6.3 M triangles; its time, a median 32 (``tutorial``)
and 7 (``exact``) microseconds per triangle on a 2-core machine.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .field import BlobField

#: triangles per unit of integral(kappa dA) / max_error, per field (measured; module doc)
K = {"tutorial": 0.9, "exact": 0.7}
#: triangles per unit of area / h0^2 of the first marching-cubes pass (measured: a sphere
#: at cell size R/6 has about 1330 triangles, 2.9 times its area over the cell's square)
K0 = 2.9
#: the real count lies within this factor of the estimate, either way (measured: 0.86-1.13
#: above 12 000 triangles, up to 1.8 below; module doc)
ACCURACY = 2.0
#: the mesher's peak memory per triangle, bytes (measured; module doc)
BYTES_PER_TRIANGLE = 500
#: the mesher's time per triangle, seconds, per field (measured on 2 cores; module doc)
SECONDS_PER_TRIANGLE = {"tutorial": 3e-5, "exact": 8e-6}

RAYS = 8192            # rays in all, shared among the sources
RAYS_MIN = 64          # per source
STEPS = 16             # samples along a ray before bisection
MIN_COS = 0.1          # |n . w| floor: a grazing exit's area counts at most 10 times


class Cost(NamedTuple):
    triangles: float        # estimated triangle count
    bytes: float            # the mesher's estimated peak memory
    seconds: float          # the mesher's estimated time (2 cores)

    def describe(self) -> str:
        """``about 3.2e+10 triangles, 16 TB of memory and 270 h of meshing``."""
        size = next((f"{self.bytes / u:.3g} {n}" for u, n in
                     ((1e12, "TB"), (1e9, "GB"), (1e6, "MB"))
                     if self.bytes >= u), f"{self.bytes / 1e3:.3g} kB")
        time = next((f"{self.seconds / u:.3g} {n}" for u, n in
                     ((3600.0, "h"), (60.0, "min")) if self.seconds >= u),
                    f"{self.seconds:.3g} s")
        return f"about {self.triangles:.3g} triangles, {size} of memory and {time} of meshing"


def _directions(m: int) -> np.ndarray:
    """m directions spread evenly over the sphere (a Fibonacci lattice)."""
    k = np.arange(m) + 0.5
    z = 1.0 - 2.0 * k / m
    phi = math.pi * (1.0 + math.sqrt(5.0)) * k
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def _d2f(field: BlobField, x: np.ndarray) -> np.ndarray:
    """f''(x) of one source (0 inside the zone field's linear pieces)."""
    if field.kind == "exact":
        return 2.0 / np.maximum(x, 1e-30) ** 3
    return np.zeros_like(x)


def _largest_curvature(field: BlobField, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The largest |principal curvature| of the level set of F at points q, and the unit
    normal there: the Hessian of F on the tangent plane over |grad F|."""
    s = 2.0 * field.inv_r2
    g = np.zeros_like(q)
    hess = np.zeros((len(q), 3, 3))
    for k, c in enumerate(field.centers):
        x, u = field.sqdist(q, k), q - c
        d1, d2 = field.df(x), _d2f(field, x)
        g += (s * d1)[:, None] * u                # grad f(x) = f'(x) 2 (p - c) / R^2
        hess += (d2 * s * s)[:, None, None] * u[:, :, None] * u[:, None, :]
        hess += (s * d1)[:, None, None] * np.eye(3)
    norm = np.maximum(np.linalg.norm(g, axis=1), 1e-300)
    n = -g / norm[:, None]
    a = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    t1 = a / np.linalg.norm(a, axis=1, keepdims=True)
    t2 = np.cross(n, t1)
    h11 = np.einsum("ni,nij,nj->n", t1, hess, t1)
    h12 = np.einsum("ni,nij,nj->n", t1, hess, t2)
    h22 = np.einsum("ni,nij,nj->n", t2, hess, t2)
    # the larger |eigenvalue| of the 2x2 tangent block
    kappa = np.abs(0.5 * (h11 + h22)) + np.sqrt(0.25 * (h11 - h22) ** 2 + h12 * h12)
    return kappa / norm, n


def surface_integrals(centers, radius: float, kind: str, rays: int = RAYS
                      ) -> tuple[float, float]:
    """(area, integral of the largest |principal curvature| dA) of the blob's surface, by
    rays from the centres (module docstring)."""
    field = BlobField(centers, radius, kind)
    c, r = field.centers, field.radius
    n_src = len(c)
    m = max(RAYS_MIN, rays // n_src)
    w = _directions(m)
    # a source's exit lies where its term is the largest, so F = 1 there needs f_i >= 1/N:
    # x_i <= support_x; and F >= f_i > 1 inside x_i < 1
    ts = np.linspace(r, 1.01 * r * math.sqrt(field.support_x()) + 1e-3 * r, STEPS)
    origin = np.repeat(c, m, axis=0)
    d = np.tile(w, (n_src, 1))
    inside = field.value((origin[:, None, :] + ts[None, :, None] * d[:, None, :])
                         .reshape(-1, 3)).reshape(-1, STEPS) >= 1.0
    found = ~inside.all(axis=1)
    j = np.maximum(np.argmin(inside, axis=1), 1)          # first sample outside
    lo, hi = ts[j - 1], ts[j]
    for _ in range(40):                                   # bisection to ~1e-12 of the step
        mid = 0.5 * (lo + hi)
        into = field.value(origin + mid[:, None] * d) >= 1.0
        lo, hi = np.where(into, mid, lo), np.where(into, hi, mid)
    t = 0.5 * (lo + hi)
    q = origin + t[:, None] * d
    terms = np.stack([field.f(field.sqdist(q, k)) for k in range(n_src)], axis=1)
    own = found & (terms[np.arange(len(q)), np.repeat(np.arange(n_src), m)]
                   >= terms.max(axis=1))
    kappa, n = _largest_curvature(field, q)
    cos = np.maximum(np.abs(np.einsum("ij,ij->i", n, d)), MIN_COS)
    da = np.where(own, t * t / cos, 0.0) * (4.0 * math.pi / m)
    return float(da.sum()), float((da * kappa).sum())


def estimate_cost(centers, radius: float, kind: str, max_error: float) -> Cost:
    """The mesher's cost (:func:`codermind.blobmesh.build_blob_mesh`) for ``max_error``, in
    the centres' units. Raises :class:`codermind.blobmesh.BlobMeshError` (naming the
    parameter) for input the mesher would refuse."""
    from .mesh import _validate, first_cell_size
    centers, radius, max_error = _validate(centers, radius, kind, max_error, "flat", None)
    area, curvature = surface_integrals(centers, radius, kind)
    h0 = first_cell_size(BlobField(centers, radius, kind), max_error)
    triangles = max(K[kind] * curvature / max_error, K0 * area / (h0 * h0))
    return Cost(triangles, triangles * BYTES_PER_TRIANGLE,
                triangles * SECONDS_PER_TRIANGLE[kind])
