from __future__ import annotations  # Delayed parsing of type annotations

import math
import re
import time

import drjit as dr
import mitsuba as mi
import numpy as np

from ..exposed import exposed, scalar
from ..blobmesh import BlobMeshError, build_blob_mesh, estimate_cost
from ..blobmesh.cost import ACCURACY
from ..blobmesh.field import NORMAL_SKIP
from ..params import check_float, loose_number
from ._blob_exact import BlobSurface

_CENTER = re.compile(r"center(\d+)$")

#: ``max_triangles``' default: about 1 GB of the mesher's memory and up to a minute (see
#: codermind.blobmesh.cost)
MAX_TRIANGLES = 2_000_000


def blob(props: mi.Properties) -> mi.Mesh:
    r"""
    .. _shape-blob:

    Metaballs (:monosp:`blob`)
    --------------------------

    .. pluginparameters::

     * - center0, center1, ...
       - |point|
       - Source centres :math:`c_i`, any number, numbered from 0 without gaps.

     * - centers
       - |string|
       - Alternative to ``center0..``: all centres as 3N numbers ``x0 y0 z0 x1 y1 z1 ...``
         (spaces or commas; in object space, before ``to_world``).

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

     * - max_triangles
       - |int|
       - The largest mesh the blob may build, in triangles (Default: 2 000 000: about 1 GB
         of the mesher's memory and up to a minute). Before meshing, the triangle count that
         ``max_error`` needs is estimated from the centres, the radius, ``to_world`` and
         ``max_error`` (from the surface's area and curvature, in a few tens of ms; measured
         within 2x of the real count, and 0.86-1.13 of it above 12 000 triangles); above
         this limit the blob is refused with a one-line error that gives the estimated
         triangles, memory and time and the ``max_error`` that would fit. Raise it to allow
         a larger mesh.

     * - normals
       - |string|
       - Vertex normals: ``exact`` (default; gradient of :math:`\sum R^2/d^2`, what the
         tutorial shades with, whatever the field), ``field`` (gradient of the chosen
         field; on the zone field's creases the mean of both sides), or ``flat`` (none:
         the faceted geometric normal).

     * - tessellate
       - |boolean|
       - ``true``: the triangle mesh described below, what every integrator sees.
         ``false`` (``field`` = ``tutorial`` only): no mesh (one degenerate triangle that no
         ray hits); the :monosp:`tutorialpath` integrator intersects the zone field itself
         (``Blob.analytic_hit``: along a ray the field is a quadratic between zone spheres,
         so the first crossing is a root of one quadratic per zone interval), exactly and
         several times faster than the mesh on page 4. Other integrators see no blob, and
         the surface carries no derivatives with respect to ``centers`` or ``radius``
         (Default: ``true``)

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

    ``mi.traverse`` exposes ``centers`` (a flat ``mi.Float`` of 3N numbers, object
    space) and ``radius``, both differentiable, and ``max_error``; changing any of them
    re-tessellates the mesh in ``parameters_changed`` (the number of centres may change
    too), after the same checks as at loading (an absurd value or a mesh above
    ``max_triangles`` is refused in one line, and the blob stays as it was). The mesh's
    own buffers (``vertex_positions``, ...) are exposed as for any mesh.

    With gradients enabled on the centres or the radius, the vertex positions and normals
    carry their derivatives: each vertex stays on the surface to first order (implicit
    function theorem; on the ``tutorial`` field's creases, the zone spheres where the
    field has a kink, also on its crease) and moves along it with the sources, and its
    normal is the ``normals`` option's formula at the moved vertex. ``prb`` then
    differentiates the shading and ``prb_projective`` also the silhouette: a one-source
    blob's derivatives with respect to its centre and radius are those of the built-in
    ``sphere`` (within 0.04 % without silhouette; the silhouette term within 0.3 % of the
    closed form). Not differentiated:

    * ``normals`` = ``flat``: the shading normal jumps at every facet edge, and the edges
      sweep over the image as the surface moves; no integrator differentiates that
      shading discontinuity. The vertices then move along the normal only, so that the
      facets turn with the surface, but what the sweep contributes is missing: a
      one-source blob moved towards the camera gives 0.043 where the sphere and finite
      differences give 0.069, and the polygonal contour slides, a few per cent of the
      silhouette term (-2.9 % to +1.2 %). On the ``tutorial`` field ``prb_projective``
      also gives single pixels of derivatives hundreds of times the rest on the crease's
      thin triangles (docs/results/gradients.md). Use ``exact`` or ``field`` normals for
      gradients.
    * ``normals`` = ``field`` on the ``tutorial`` field: the normal jumps across the
      creases, which the mesh spreads over about a triangle; where creases sweep over the
      image, their part is differentiated only approximately (along one direction of
      two centres: AD -0.038 against differences of -0.045 and -0.048, themselves 6 %
      apart; along another, 3.144 against 3.142 and 3.143).
    * shadow edges of point lights (Mitsuba differentiates no shadow edge of a delta
      light), and everything with ``tessellate`` = ``false``.

    A reverse-mode pass through ``mi.render`` consumes the graph from ``centers`` and
    ``radius`` to the mesh's buffers (Dr.Jit's ``ADFlag.ClearEdges``): update the
    parameters (``params.update()``, as an optimiser loop does every step) before the
    next differentiated render, or pass ``flags=dr.ADFlag.ClearVertices`` to
    ``dr.backward`` to keep it.

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
    tessellate = props.get("tessellate", True)
    if not isinstance(tessellate, bool):
        raise ValueError(f"blob: 'tessellate' must be a boolean, got {tessellate!r}")
    if not tessellate and field != "tutorial":
        raise ValueError("blob: 'tessellate' = false needs field = 'tutorial' (the analytic "
                         "intersection solves the zone field's quadratics)")
    max_error = loose_number(props, "blob", "max_error", scale * radius / 500.0)
    max_triangles = loose_number(props, "blob", "max_triangles", MAX_TRIANGLES)
    _check_limits(radius, max_error, max_triangles)
    # kept as the float32 values that mi.traverse hands out, so that writing them back
    # re-tessellates the same blob
    with np.errstate(over="ignore"):
        centers = centers.astype(np.float32).astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(centers).all(axis=1))
    if bad.size:
        raise ValueError(f"blob: 'center{bad[0]}' must be finite in float32, got "
                         f"{centers[bad[0]].tolist()}")
    radius, max_error = float(np.float32(radius)), float(np.float32(max_error))
    return Blob(props, centers, radius, field, normals, matrix, max_error, tessellate,
                max_triangles)


def _check_limits(radius: float, max_error: float, max_triangles: float) -> None:
    """One-line errors for radius, max_error and max_triangles out of range."""
    check_float("blob", "radius", radius, lo=0.0, open_lo=True)
    check_float("blob", "max_error", max_error, lo=0.0, open_lo=True)
    check_float("blob", "max_triangles", max_triangles, lo=1.0)


def _refuse_runaway(centers: np.ndarray, radius: float, field: str, scale: float,
                    max_error: float, max_triangles: float) -> None:
    """A one-line ValueError, before any meshing, where the mesh for ``max_error`` (world
    units) would have more than ``max_triangles`` triangles by the estimate of
    :func:`codermind.blobmesh.estimate_cost` (within ``ACCURACY`` of the real count)."""
    try:
        cost = estimate_cost(centers, radius, field, max_error / scale)
    except BlobMeshError as e:
        raise ValueError(f"blob: {e}") from None
    if cost.triangles > max_triangles:
        fits = max_error * cost.triangles / max_triangles   # the count goes as 1/max_error
        step = 10.0 ** (math.floor(math.log10(fits)) - 2)   # rounded up to 3 digits
        fits = math.ceil(fits / step) * step
        raise ValueError(
            f"blob: 'max_error' {max_error:.3g} would need {cost.describe()} (estimated, "
            f"within {ACCURACY:g}x), more than 'max_triangles' {max_triangles:.3g}: raise "
            f"max_error to {fits:.3g} or more, or raise max_triangles")


def _mesh_arrays(centers: np.ndarray, radius: float, field: str, normals: str,
                 matrix: np.ndarray, max_error: float, max_triangles: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World-space vertices, faces and vertex normals (possibly empty) of the blob."""
    linear = matrix[:3, :3]
    scale = float(np.linalg.svd(linear, compute_uv=False)[0])
    _refuse_runaway(centers, radius, field, scale, max_error, max_triangles)
    t0 = time.perf_counter()
    try:
        # an accepted mesh has at most ACCURACY times the limit: the mesher's own cap there
        # stops only a mesh the estimate got wrong
        mesh = build_blob_mesh(centers, radius, field, max_error / scale, normals=normals,
                               max_triangles=int(ACCURACY * max_triangles),
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
    return v, f, n


class Blob(mi.Mesh):
    """The blob's triangle mesh. Mitsuba 3.9.1 cannot subclass ``mi.Shape`` from Python,
    but it can subclass ``mi.Mesh``: the object keeps the blob's own parameters and
    re-tessellates itself in ``parameters_changed`` (the mesh's buffers may change size;
    the scene, notified after the shape, rebuilds its acceleration structure).

    It is an :class:`codermind.exact_surface.ExactSurface`: ``tessellated`` is the
    ``tessellate`` option, and the hits on the exact surface are its :class:`BlobSurface`'s
    (``surface``, remade with the parameters)."""

    #: the tutorial's blob epsilon (ExactSurface.SELF_HIT)
    SELF_HIT = BlobSurface.SELF_HIT

    def __init__(self, props: mi.Properties, centers: np.ndarray, radius: float, field: str,
                 normals: str, matrix: np.ndarray, max_error: float, tessellate: bool = True,
                 max_triangles: float = MAX_TRIANGLES):
        self.tessellated = tessellate
        self.max_triangles = max_triangles
        v, f, n = self._arrays(centers, radius, field, normals, matrix, max_error)
        super().__init__(props.id() or "blob", len(v), len(f), props,
                         has_vertex_normals=normals != "flat")
        self.field, self.normals, self.matrix = field, normals, matrix
        self.centers, self.radius, self.max_error = centers, radius, max_error
        self.surface = self._surface()
        self._set_buffers(v, f, n)

    def _surface(self) -> BlobSurface:
        return BlobSurface(self.centers, self.radius, self.field, self.normals, self.matrix,
                           self.max_error)

    def _arrays(self, centers, radius, field, normals, matrix, max_error):
        if self.tessellated:
            return _mesh_arrays(centers, radius, field, normals, matrix, max_error,
                                self.max_triangles)
        # no mesh: one degenerate triangle (Embree never reports it; a mesh without faces
        # cannot be intersected at all in 3.9.1)
        mi.Log(mi.LogLevel.Info, "blob: tessellate = false, only the tutorialpath "
                                 "integrator sees this blob")
        c = np.asarray(centers[0], dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
        n = np.tile([0.0, 0.0, 1.0], (3, 1)) if normals != "flat" else np.zeros((0, 3))
        return np.tile(c, (3, 1)), np.array([[0, 1, 2]]), n

    def _attached(self, v: np.ndarray, n: np.ndarray) -> tuple:
        """World vertices ``v`` and vertex normals ``n``, with their derivatives with respect
        to the centres and the radius attached when either has gradients enabled (else
        ``v`` and ``n`` themselves). The values stay those of ``v`` and ``n``.

        A vertex p lies on F(p; c, R) = 1 and stays on it to first order (implicit function
        theorem): grad_p F . dp = -(dF/dc . dc + dF/dR dR), with dF/dc_i = -g_i (g_i:
        source i's term of grad_p F) and dF/dR = sum_i f'(x_i) (-2 x_i / R). A vertex on a
        crease of the zone field (a zone sphere x_i = 10/k, where F has a kink) also keeps
        x_i = 10/k. dp is the least-norm motion meeting the constraint(s) plus a tangential
        part t projected onto their null space: with smooth normals the sources' own
        motion weighted by their shares f_i (a one-source blob moves and scales as a
        sphere), with ``flat`` normals none. In world space dp is mapped by to_world's
        linear part. The vertex normal is the ``normals`` option's formula evaluated at
        p + dp with c + dc (:meth:`_normal_of`), so that it turns with the surface under
        the vertex; a normal kept fixed is wrong by the surface's turn over the vertex's
        motion relative to it (a sphere moved by d: -d_tangential / R at a vertex moved
        along its normal)."""
        if not dr.is_diff_v(mi.Float):
            return v, n
        c_ad, r_ad = exposed(self, "centers"), exposed(self, "radius")
        if not (dr.grad_enabled(c_ad) or dr.grad_enabled(r_ad)):
            return v, n
        from ..blobmesh.field import BlobField
        linear, shift = self.matrix[:3, :3], self.matrix[:3, 3]
        p = (v - shift) @ np.linalg.inv(linear).T          # object space
        field = BlobField(self.centers, self.radius, self.field)
        dc = c_ad - dr.detach(c_ad)                        # 0, carrying dc's gradients
        dr_ = r_ad - dr.detach(r_ad)
        f32 = lambda a: mi.Float(np.ascontiguousarray(a, dtype=np.float32))  # noqa: E731
        grad = np.zeros_like(p)
        dfdr = np.zeros(len(p))
        s1 = mi.Float(0.0)                                 # -(dF/dtheta . dtheta)
        s2 = mi.Float(0.0)                                 # the crease's x_i constraint
        crease = np.full(len(p), -1)
        normal2 = np.zeros_like(p)                         # grad_p x_i of that crease
        dcs, shares = [], []
        for i, c in enumerate(field.centers):
            x = field.sqdist(p, i)
            shares.append(field.f(x))
            df = field.df(x)                               # one-sided on a crease
            g = (2.0 * field.inv_r2) * df[:, None] * (p - c)
            grad += g
            dfdr += df * (-2.0 * x / field.radius)
            dc_i = [dr.gather(mi.Float, dc, 3 * i + axis) for axis in range(3)]
            dcs.append(dc_i)
            s1 += sum(f32(g[:, axis]) * dc_i[axis] for axis in range(3))
            if field.kind == "tutorial":
                # on a zone sphere x_i = 10/k the field has a kink; the vertex stays on the
                # crease: also x_i(p + dp; c + dc, R + dR) = 10/k
                k = 10.0 / np.maximum(x, 1e-30)
                j = np.rint(k)
                at = (np.abs(k - j) <= 1e-9 * j) & (j >= 1) & (j <= 9) & (crease < 0)
                if at.any():
                    crease[at] = i
                    a2 = (2.0 * field.inv_r2) * (p - c)
                    normal2[at] = a2[at]
                    rhs = sum(f32(np.where(at, a2[:, axis], 0.0)) * dc_i[axis]
                              for axis in range(3))
                    s2 += rhs + f32(np.where(at, 2.0 * x / field.radius, 0.0)) * dr_
        s1 -= f32(dfdr) * dr_
        # u1 s1 + u2 s2: the least-norm motion meeting the constraint(s)
        g2 = np.maximum((grad * grad).sum(1), 1e-300)
        u1, u2 = grad / g2[:, None], np.zeros_like(p)
        on = crease >= 0
        if on.any():
            a, b = grad[on], normal2[on]
            m11, m12, m22 = (a * a).sum(1), (a * b).sum(1), (b * b).sum(1)
            det = m11 * m22 - m12 * m12
            ok = det > 1e-6 * m11 * m22                    # not tangent (one sphere)
            inv11, inv12, inv22 = m22 / np.where(ok, det, 1), -m12 / np.where(ok, det, 1), \
                m11 / np.where(ok, det, 1)
            w1 = a * inv11[:, None] + b * inv12[:, None]
            w2 = a * inv12[:, None] + b * inv22[:, None]
            idx = np.flatnonzero(on)[ok]
            u1[idx], u2[idx] = w1[ok], w2[ok]
        # the tangential part t, projected onto the null space of the constraints. Smooth
        # normals: the sources' own motion (moved, and scaled about their centres) weighted
        # by their shares f_i of F = 1. It changes no derivative of the smooth shading, but
        # the mesh's silhouette keeps its shape instead of sliding over the contour, which
        # moves its coverage error (a few per cent of the boundary term). Flat: none, so
        # that the facets turn with the surface (a moved sphere's by -d_tangential / R),
        # the part of the shading's change a facet can carry
        if self.normals == "flat":
            t = [mi.Float(0.0)] * 3
        else:
            w = np.array(shares) / np.maximum(np.sum(shares, axis=0), 1e-300)
            t = [sum(f32(w[i]) * dcs[i][k] for i in range(len(w))) +
                 f32(sum(w[i] * (p[:, k] - c[k]) for i, c in enumerate(field.centers))
                     / field.radius) * dr_ for k in range(3)]
        r1 = s1 - sum(f32(grad[:, k]) * t[k] for k in range(3))
        r2 = s2 - sum(f32(normal2[:, k]) * t[k] for k in range(3))
        dp = [t[k] + f32(u1[:, k]) * r1 + f32(u2[:, k]) * r2 for k in range(3)]  # object space
        moved = [f32(v[:, k]) + sum(float(linear[k, j]) * dp[j] for j in range(3))
                 for k in range(3)]
        v_ad = dr.ravel(mi.Point3f(*moved))
        if not len(n):                                     # 'flat': Mitsuba's facet normals
            return v_ad, n
        # the offsets p - c_i in float64, their motion dp - dc_i carried by AD
        rel = [mi.Vector3f(*[f32(p[:, k] - c[k]) + dp[k] - dcs[i][k] for k in range(3)])
               for i, c in enumerate(field.centers)]
        normal = self._normal_of(field, p, rel)
        normal = normal - dr.detach(normal)                # 0, carrying dn's gradients
        return v_ad, dr.ravel(mi.Vector3f(*[f32(n[:, k]) + normal[k] for k in range(3)]))

    def _normal_of(self, field, p: np.ndarray, rel: list) -> mi.Vector3f:
        """The ``normals`` option's unit world normal at the vertices ``p`` (object space)
        from their offsets ``rel`` = p - c_i from the centres (Dr.Jit arrays, derivatives
        included): ``exact`` (and ``field`` on the exact field) the direction of
        sum x_i^-2 (p - c_i), ``field`` on the zone field that of -sum f'_i (p - c_i) with
        each source's slope f'_i in p's zone (on a crease the mean of both sides, as the
        mesher's normal), which stays while the vertex stays in its zone and on its crease.
        Neither depends on R but through p (a positive common factor)."""
        g = mi.Vector3f(0.0)
        for i, q in enumerate(rel):
            x = field.sqdist(p, i)
            if self.normals == "exact" or field.kind == "exact":
                # the mesher's rule (NORMAL_SKIP: the tutorial's, relative to R)
                keep = mi.Float(np.asarray(x > NORMAL_SKIP, dtype=np.float32))
                g += keep / dr.square(dr.squared_norm(q) * field.inv_r2) * q
            else:
                slope = field.df(x, mean_at_bounds=True)
                g += mi.Float(np.ascontiguousarray(-slope, dtype=np.float32)) * q
        inv_t = np.linalg.inv(self.matrix[:3, :3]).T       # normals: the inverse transpose
        to_world = mi.ScalarMatrix3f([[float(a) for a in row] for row in inv_t])
        return dr.normalize(to_world @ g)

    # -- the exact surface (ExactSurface, called by the tutorialpath integrator) -----------
    def exact_hit(self, ray: mi.Ray3f, si: mi.SurfaceInteraction3f,
                  active: mi.Bool) -> mi.SurfaceInteraction3f:
        """:meth:`BlobSurface.exact_hit`: Newton's method from the mesh's hit."""
        return self.surface.exact_hit(ray, si, active)

    def left_surface(self, ray: mi.Ray3f, mesh_si: mi.SurfaceInteraction3f,
                     exact_si: mi.SurfaceInteraction3f) -> mi.Bool:
        """:meth:`BlobSurface.left_surface`."""
        return self.surface.left_surface(ray, mesh_si, exact_si)

    def exit_hit(self, ray: mi.Ray3f, si: mi.SurfaceInteraction3f, limit: mi.Float,
                 active: mi.Bool) -> tuple[mi.SurfaceInteraction3f, mi.Bool]:
        """:meth:`BlobSurface.exit_hit`, a hit on this shape."""
        return self.surface.exit_hit(self, ray, si, limit, active)

    def analytic_hit(self, ray: mi.Ray3f, tmin: float, tmax: mi.Float,
                     active: mi.Bool = True, strict: bool = False) -> mi.Float:
        """:meth:`BlobSurface.analytic_hit`: the zone walk (``field`` = ``tutorial``)."""
        return self.surface.analytic_hit(ray, tmin, tmax, active, strict)

    def interaction(self, ray: mi.Ray3f, t: mi.Float, active: mi.Bool = True
                    ) -> mi.SurfaceInteraction3f:
        """:meth:`BlobSurface.interaction`, a hit on this shape."""
        return self.surface.interaction(self, ray, t, active)

    def _set_buffers(self, v, f: np.ndarray, n: np.ndarray) -> None:
        params = mi.traverse(self)

        def buffer(key: str, a, dtype) -> None:
            if dr.is_array_v(a):                            # AD-attached positions
                params[key] = a
                return
            # the buffer types differ between variants (mi.Float is a scalar in scalar_rgb)
            params[key] = type(params[key])(np.ascontiguousarray(a, dtype=dtype).ravel())

        buffer("vertex_positions", v, np.float32)
        buffer("faces", f, np.uint32)
        if len(n):  # set in the same update as the positions, or Mitsuba recomputes them
            buffer("vertex_normals", n, np.float32)
        params.update()

    def to_string(self) -> str:
        # Mitsuba's own shapes print like this; a Python shape without it makes print(scene)
        # fail (nanobind finds no trampoline)
        def indent(value) -> str:
            return str(value).replace("\n", "\n  ")

        m = self.matrix
        rows = ",\n              ".join("[" + ", ".join(f"{x:.6g}" for x in row) + "]"
                                        for row in m)
        return (f"Blob[\n  id = \"{self.id()}\",\n  centers = {len(self.centers)},\n"
                f"  radius = {self.radius:.6g},\n  field = \"{self.field}\",\n"
                f"  normals = \"{self.normals}\",\n"
                f"  tessellate = {'true' if self.tessellated else 'false'},\n"
                f"  max_error = {self.max_error:.6g},\n"
                f"  max_triangles = {self.max_triangles:.6g},\n"
                f"  to_world = [{rows}],\n"
                f"  vertex_count = {self.vertex_count()},\n"
                f"  face_count = {self.face_count()},\n"
                f"  bsdf = {indent(self.bsdf())}\n]")

    def traverse(self, callback: mi.TraversalCallback) -> None:
        super().traverse(callback)
        nd = mi.ParamFlags.NonDifferentiable
        geometry = mi.ParamFlags.Differentiable | mi.ParamFlags.Discontinuous
        if dr.is_jit_v(mi.Float):     # (a scalar variant has no array type for them)
            callback.put("centers", exposed(self, "centers", lambda: mi.Float(
                np.ascontiguousarray(self.centers, dtype=np.float32).ravel())), geometry)
        callback.put("radius", exposed(self, "radius"), geometry if dr.is_jit_v(mi.Float) else nd)
        callback.put("max_error", exposed(self, "max_error"), nd)

    def parameters_changed(self, keys: list[str]) -> None:
        own = [k for k in ("centers", "radius", "max_error") if k in keys]
        if own:
            flat = np.array(dr.detach(exposed(self, "centers")) if "centers" in keys
                            else self.centers, dtype=np.float64).ravel()
            if flat.size == 0 or flat.size % 3:
                raise ValueError(f"blob: 'centers' must hold 3 numbers per centre, got "
                                 f"{flat.size}")
            radius = scalar(exposed(self, "radius"))
            max_error = scalar(exposed(self, "max_error"))
            _check_limits(radius, max_error, self.max_triangles)
            v, f, n = self._arrays(flat.reshape(-1, 3), radius, self.field, self.normals,
                                   self.matrix, max_error)
            self.centers, self.radius, self.max_error = flat.reshape(-1, 3), radius, max_error
            self.surface = self._surface()
            if self.tessellated:
                v, n = self._attached(v, n)
            self._set_buffers(v, f, n)
        rest = [k for k in keys if k not in own]
        if rest or not keys:
            super().parameters_changed(rest)


def _centers(props: mi.Properties) -> np.ndarray:
    if "centers" in props:
        return _center_array(props)
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


def _center_array(props: mi.Properties) -> np.ndarray:
    """``centers``: 3N numbers x0 y0 z0 x1 ... (a string, separated by spaces or commas)."""
    if any(_CENTER.match(key) for key in props.keys()):
        raise ValueError("blob: give either 'centers' or 'center0', 'center1', ..., not both")
    value = props.get("centers")
    try:
        flat = np.array([float(x) for x in str(value).replace(",", " ").split()])
    except ValueError:
        raise ValueError(f"blob: 'centers' must be 3N numbers (x0 y0 z0 x1 ...), got "
                         f"{value!r}") from None
    if flat.size == 0 or flat.size % 3:
        raise ValueError(f"blob: 'centers' must hold 3 numbers per centre, got {flat.size}")
    return flat.reshape(-1, 3)


mi.register_shape("blob", blob)
