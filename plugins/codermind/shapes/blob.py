from __future__ import annotations  # Delayed parsing of type annotations

import math
import re
import time

import mitsuba as mi
import numpy as np

from ..blobmesh import BlobMeshError, build_blob_mesh
from ..params import loose_number

_CENTER = re.compile(r"center(\d+)$")


def blob(props: mi.Properties) -> mi.Mesh:
    r"""
    .. _shape-blob:

    Metaballs (:monosp:`blob`)
    --------------------------

    .. pluginparameters::

     * - center0, center1, ...
       - |point|
       - Source centres :math:`c_i`, any number, numbered from 0 without gaps.

     * - radius
       - |float|
       - Source radius :math:`R` (> 0). A single source is a sphere of radius R.

     * - field
       - |string|
       - ``tutorial`` (default): the Codermind tutorial's piecewise-linear zone field,
         :math:`\sum_i f(|p - c_i|^2/R^2) = 1` with f through (10, 0), (5, 0.2),
         (10/3, 0.3), ..., (1, 1) and :math:`1.9 - 0.9x` for x < 1.
         ``exact``: :math:`\sum_i R^2/|p - c_i|^2 = 1`.

     * - max_error
       - |float|
       - Largest distance, in WORLD units (after ``to_world``), from the mesh to the true
         surface (Default: R/500 times the largest scale factor of ``to_world``). The
         mesh is refined until the measured error is below it; the achieved error is
         logged at Info level (Warn if it could not be reached).

     * - normals
       - |string|
       - Vertex normals: ``exact`` (default; gradient of :math:`\sum R^2/d^2`, what the
         tutorial shades with, whatever the field), ``field`` (gradient of the chosen
         field; on the zone field's creases the mean of both sides), or ``flat`` (none:
         the faceted geometric normal).

     * - to_world
       - |transform|
       - Object-to-world transform, applied to the centres and the radius (any affine
         map; a non-uniform scale turns spheres into ellipsoids). The error bound holds in
         world units: the object-space target is ``max_error`` divided by the largest
         singular value of the linear part.

     * - (others)
       -
       - As any Mitsuba mesh: a nested BSDF, emitter or sensor, ``interior`` /
         ``exterior`` media, ``face_normals``, ``flip_normals``.

    The surface is tessellated by marching cubes and every vertex is moved onto the true
    isosurface; triangles where the measured error exceeds ``max_error`` are split by
    longest-edge bisection until none does. With the ``tutorial`` field the mesh is also
    cut along the field's creases (zone boundaries), so the error falls as the square of
    the cell size. Every centre lies inside the surface (f(0) = 1.9 > 1), so the surface
    is never empty. The result is a watertight, consistently outward-oriented mesh.

    .. tabs::

        .. code-tab:: xml

            <shape type="blob">
                <point name="center0" x="160" y="290" z="320"/>
                <point name="center1" x="400" y="290" z="480"/>
                <point name="center2" x="250" y="140" z="400"/>
                <float name="radius" value="80"/>
                <float name="max_error" value="0.15"/>
                <bsdf type="dielectric"/>
            </shape>
    """
    centers = _centers(props)
    radius = loose_number(props, "blob", "radius")
    field = str(props.get("field", "tutorial"))
    normals = str(props.get("normals", "exact"))
    to_world = props.get("to_world", mi.ScalarTransform4f())
    matrix = np.array(to_world.matrix, dtype=np.float64)
    if not np.allclose(matrix[3], [0, 0, 0, 1]) or not np.isfinite(matrix).all():
        raise ValueError("blob: 'to_world' must be a finite affine transform")
    linear = matrix[:3, :3]
    sv = np.linalg.svd(linear, compute_uv=False)
    if sv[-1] <= 1e-12 * sv[0]:
        raise ValueError("blob: 'to_world' is singular")
    scale = float(sv[0])  # largest stretch: world error <= scale * object-space error
    if radius is None:
        raise ValueError("blob: 'radius' is required")
    max_error = loose_number(props, "blob", "max_error")
    if max_error is None:
        max_error = scale * radius / 500.0 if math.isfinite(radius) and radius > 0 else 1.0
    t0 = time.perf_counter()
    try:
        mesh = build_blob_mesh(centers, radius, field, max_error / scale, normals=normals,
                               log=lambda msg: mi.Log(mi.LogLevel.Debug, msg))
    except BlobMeshError as e:
        raise ValueError(f"blob: {e}") from None
    seconds = time.perf_counter() - t0

    v = mesh.vertices @ linear.T + matrix[:3, 3]
    f = mesh.faces
    if np.linalg.det(linear) < 0:  # a mirror turns the winding inside out
        f = f[:, ::-1]
    n = mesh.normals
    if len(n):
        n = n @ np.linalg.inv(linear)  # normals transform with the inverse transpose
        n /= np.linalg.norm(n, axis=1, keepdims=True)
    achieved = mesh.achieved_error * scale
    level = mi.LogLevel.Info if achieved <= max_error else mi.LogLevel.Warn
    mi.Log(level, f"{len(f)} triangles, measured error {achieved:.4g} "
                  f"({'within' if achieved <= max_error else 'ABOVE'} max_error {max_error:.4g}, "
                  f"world units), cell size {mesh.info['cell_size'] * scale:.3g}, "
                  f"{mesh.info['refine_passes']} refinement passes, {seconds:.2f} s")
    for i, j in mesh.info["lost_necks"]:
        mi.Log(mi.LogLevel.Warn, f"blob: the surface joins center{i} and center{j} by a neck "
                                 f"thinner than the mesh resolution, which the mesh lost: lower "
                                 f"max_error (cell size {mesh.info['cell_size'] * scale:.3g})")

    out = mi.Mesh(props.id() or "blob", len(v), len(f), props, has_vertex_normals=len(n) > 0)
    params = mi.traverse(out)

    def buffer(key: str, a: np.ndarray, dtype) -> None:
        # the buffer types differ between variants (mi.Float is a scalar in scalar_rgb)
        params[key] = type(params[key])(np.ascontiguousarray(a, dtype=dtype).ravel())

    buffer("vertex_positions", v, np.float32)
    buffer("faces", f, np.uint32)
    if len(n):  # set in the same update as the positions, or Mitsuba recomputes them
        buffer("vertex_normals", n, np.float32)
    params.update()
    return out


def _centers(props: mi.Properties) -> np.ndarray:
    found = {}
    for key in props.keys():
        m = _CENTER.match(key)
        if m:
            found[int(m.group(1))] = key
    if not found:
        raise ValueError("blob: no source centre given (center0, center1, ...)")
    missing = [i for i in range(max(found) + 1) if i not in found]
    if missing:
        raise ValueError(f"blob: 'center{missing[0]}' is missing (centres are numbered from 0 "
                         f"without gaps; found {', '.join(found[i] for i in sorted(found))})")
    out = []
    for i in sorted(found):
        try:
            p = props.get(found[i])
            out.append([float(p[0]), float(p[1]), float(p[2])])
        except (TypeError, IndexError):
            raise ValueError(f"blob: '{found[i]}' must be a point") from None
    return np.array(out)


mi.register_shape("blob", blob)
