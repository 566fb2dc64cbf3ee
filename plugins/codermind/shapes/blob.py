from __future__ import annotations  # Delayed parsing of type annotations

import math
import re
import time

import drjit as dr
import mitsuba as mi
import numpy as np

from ..exposed import exposed, scalar
from ..masks import logical_not as _not
from ..blobmesh import BlobMeshError, build_blob_mesh, estimate_cost
from ..blobmesh.cost import ACCURACY
from ..blobmesh.field import INTERCEPT, NORMAL_SKIP, SLOPE

from ..params import check_float, loose_number

# Blob._zone's closed form of the zone tables beyond the outermost zone
assert all(abs(SLOPE[k] + k * (k + 1) / 100) < 1e-12 and abs(INTERCEPT[k] - (2 * k + 1) / 10)
           < 1e-12 for k in range(2, 10)), "zone tables are no longer the chords of 1/x"

_CENTER = re.compile(r"center(\d+)$")

#: ``max_triangles``' default: about 1 GB of the mesher's memory and up to a minute (see
#: codermind.blobmesh.cost)
MAX_TRIANGLES = 2_000_000

# the strict walk's bound increments of zones 0..8: the float32 differences of the zone bounds
# 0.2, 0.3, ..., 1.0 (spec 2.10: they sum to exactly 1 in a lone core)
_BOUND_INC32 = [float(v) for v in np.diff(np.array([0.0] + [0.1 * k for k in range(2, 11)],
                                                   dtype=np.float32))]


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
    the scene, notified after the shape, rebuilds its acceleration structure)."""

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
        self._set_buffers(v, f, n)

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

    # -- hits on the exact surface (called by the tutorialpath integrator) ----------------
    #: Newton steps from the mesh's hit; the error falls quadratically within a zone piece,
    #: so 2 take a max_error start to float32 rounding (tests/test_blob_plugin.py)
    REFINE_STEPS = 2
    #: the tutorial's blob epsilon (spec 2.3, world units): a crossing this close to a ray's
    #: origin is the surface the ray leaves (tutorialpath's exact_hits)
    SELF_HIT = 0.01
    #: F - 1 beyond which a ray's origin is inside the surface (``exit_hit``)
    INSIDE_F = 1e-5

    def _along(self, ray: mi.Ray3f, origin: mi.Point3f):
        """Object-space offsets of ``origin`` from the centres, ``ray.d`` in object space
        (an affine map keeps t) and the world normal map."""
        linear = self.matrix[:3, :3]
        inv = np.linalg.inv(linear)
        shift = self.matrix[:3, 3]
        mat = lambda m: mi.ScalarMatrix3f([[float(x) for x in row] for row in m])  # noqa: E731
        to_obj, normal_to_world = mat(inv), mat(inv.T)
        po = to_obj @ (mi.Vector3f(dr.detach(origin)) - mi.ScalarVector3f(*map(float, shift)))
        do = to_obj @ mi.Vector3f(dr.detach(ray.d))
        rel = [po - mi.ScalarVector3f(*map(float, c)) for c in self.centers]
        return rel, do, normal_to_world

    def _residual(self, rel: list, do: mi.Vector3f, s: mi.Float
                  ) -> tuple[mi.Float, mi.Float, mi.Float]:
        """(F - 1, dF/ds, d2F/ds2 within the zones) at ``rel + s do``."""
        inv_r2 = 1.0 / (self.radius * self.radius)
        value, slope, curve = mi.Float(-1.0), mi.Float(0.0), mi.Float(0.0)
        for r in rel:
            q = r + s * do
            f, df = self._zone(dr.squared_norm(q) * inv_r2)
            value += f
            slope += df * (2.0 * inv_r2) * dr.dot(q, do)
            curve += df * (2.0 * inv_r2) * dr.squared_norm(do)
        return value, slope, curve

    def _newton(self, rel: list, do: mi.Vector3f, s: mi.Float
                ) -> tuple[mi.Float, mi.Float, mi.Float, mi.Float]:
        """``REFINE_STEPS`` Newton steps on F - 1 along ``rel + s do`` from ``s``, and one
        more only measured: (s, F - 1, dF/ds, that last step) at the result."""
        for _ in range(self.REFINE_STEPS + 1):
            g, slope, _ = self._residual(rel, do, s)
            step = dr.select(slope != 0, g / dr.select(slope != 0, slope, 1.0), 0.0)
            s = s - step
        return s + step, g, slope, step

    def _frame_at(self, rel: list, do: mi.Vector3f, s: mi.Float, normal_to_world
                  ) -> tuple[mi.Frame3f, mi.Bool]:
        """The ``normals`` option's shading frame at ``rel + s do`` (not ``flat``)."""
        inv_r2 = 1.0 / (self.radius * self.radius)
        n = mi.Vector3f(0.0)
        for r in rel:
            q = r + s * do
            d2 = dr.squared_norm(q)
            if self.normals == "exact":         # sum R^2/|q|^4 q (spec 2.10; NORMAL_SKIP)
                w = dr.select(d2 * inv_r2 > NORMAL_SKIP, self.radius ** 2 / dr.square(d2), 0.0)
            else:                               # -grad F: outward
                w = -self._zone(d2 * inv_r2)[1] * (2.0 * inv_r2)
            n += w * q
        n = normal_to_world @ n
        return mi.Frame3f(dr.normalize(n)), dr.squared_norm(n) > 0

    def exact_hit(self, ray: mi.Ray3f, si: mi.SurfaceInteraction3f,
                  active: mi.Bool) -> mi.SurfaceInteraction3f:
        """``si`` (a hit of ``ray`` on this mesh) moved onto the exact surface, where the
        field along the ray crosses 1 near the mesh's t: Newton's method on
        F(o + t d) - 1 from the mesh's t, in object space (an affine map keeps t).

        Changed where the iteration converges, within ``2 max_error / |cos|`` of the
        mesh's t, on the side the mesh was hit from (the field rises along the ray where
        it enters): ``t`` (which may come out <= 0: the crossing lies behind the ray's
        origin), ``p``, the geometric normal ``n`` and the shading frame (the ``normals``
        option's normal at the new point, also for ``n``; ``flat`` keeps the facet's),
        with ``wi`` in that frame. Elsewhere (grazing rays that hit the mesh but not the
        surface, a mesh without vertices) ``si`` is returned unchanged. The move is
        detached: ``p`` keeps the mesh's derivatives (vertex positions), if any."""
        if len(self.centers) == 0:
            return si
        rel, do, normal_to_world = self._along(ray, si.p)
        entering = dr.dot(dr.detach(si.n), dr.detach(ray.d)) < 0

        s, _, slope, step = self._newton(rel, do, mi.Float(0.0))   # its slope: the side
        cos = dr.abs(dr.dot(dr.detach(si.n), dr.detach(ray.d)))
        bound = 2.0 * self.max_error / dr.maximum(cos, 0.05)
        ok = active & dr.isfinite(s) & (dr.abs(s) <= bound) & \
            (dr.abs(step) <= 1e-3 * self.max_error + 1e-6 * dr.abs(si.t)) & \
            ((slope > 0) == entering) & (slope != 0)
        s = dr.select(ok, s, 0.0)

        frame = si.sh_frame
        if self.normals != "flat":
            frame, nonzero = self._frame_at(rel, do, s, normal_to_world)
            ok &= nonzero
            frame = mi.Frame3f(dr.select(ok, frame.n, si.sh_frame.n))

        out = mi.SurfaceInteraction3f(si)
        out.t = dr.select(ok, si.t + s, si.t)
        out.p = dr.select(ok, si.p + dr.detach(mi.Vector3f(ray.d)) * s, si.p)
        if self.normals != "flat":
            out.sh_frame = mi.Frame3f(dr.select(ok, frame.s, si.sh_frame.s),
                                      dr.select(ok, frame.t, si.sh_frame.t),
                                      dr.select(ok, frame.n, si.sh_frame.n))
            out.wi = dr.select(ok, out.sh_frame.to_local(si.sh_frame.to_world(si.wi)), si.wi)
            out.n = dr.select(ok, frame.n, si.n)
        return out

    def exit_hit(self, ray: mi.Ray3f, si: mi.SurfaceInteraction3f, limit: mi.Float,
                 active: mi.Bool) -> tuple[mi.SurfaceInteraction3f, mi.Bool]:
        """For rays that start inside the exact surface, or on it heading INTO it (the
        field rises along the ray at its origin): the surface where the ray comes out,
        if that lies beyond ``SELF_HIT`` and before ``limit`` (the ray's next trusted hit
        in the scene; ``si`` is that hit or the miss).

        It is the hit the mesh cannot give where the ray runs between the inscribed mesh
        and the surface (a grazing reflection that a bumped normal turns slightly inwards;
        chords shorter than about sqrt(8 R max_error)) and leaves the surface without
        entering the mesh: the mesh lets it escape, the tutorial's roots see it come out.
        The crossing is found where the field along the ray is a parabola within its
        zones (the guess: the exit root of the parabola through the origin's F, F' and
        F''), then polished by Newton's method.
        Returns ``si`` replaced by that hit (on this shape, with the ``normals`` option's
        frame at the new point; ``flat``: the field's normal) and the lanes replaced."""
        if len(self.centers) == 0:
            return si, mi.Bool(False)
        rel, do, normal_to_world = self._along(ray, ray.o)
        g0, slope0, curve0 = self._residual(rel, do, mi.Float(0.0))
        # inside, or on the surface heading in. An exact point's F - 1 is only known to
        # its float32 position (~3e-5 units at the tutorial's ~500: ~1e-6 of F), so a
        # point counts as inside only beyond that; else a grazing ray heading OUT of an
        # exact point would find a spurious exit a fraction of a unit on
        inward = active & (curve0 < 0) & ((g0 > self.INSIDE_F) |
                                          ((slope0 > 0) & (g0 > -self.INSIDE_F)))
        disc = dr.square(slope0) - 2.0 * curve0 * dr.maximum(g0, 0.0)
        s = dr.select(inward, (slope0 + dr.safe_sqrt(disc)) / dr.select(curve0 < 0, -curve0,
                                                                         1.0), 0.0)
        s, g, slope, step = self._newton(rel, do, s)
        # grazing chords have slopes of ~1e-4 per unit: float32's rounding of F (~1e-7)
        # then moves t by ~1e-3, so converged means a step within tolerance or F - 1 at
        # that rounding
        ok = inward & dr.isfinite(s) & (slope < 0) & (s > self.SELF_HIT) & (s < limit) & \
            ((dr.abs(step) <= 1e-3 * self.max_error + 1e-6 * s) | (dr.abs(g) <= 4e-7))
        frame, nonzero = self._frame_at(rel, do, s, normal_to_world)
        ok &= nonzero
        out = mi.SurfaceInteraction3f(si)
        out.t = dr.select(ok, s, si.t)
        out.p = dr.select(ok, dr.fma(dr.detach(mi.Vector3f(ray.d)), s, ray.o), si.p)
        out.n = dr.select(ok, frame.n, si.n)
        out.sh_frame = mi.Frame3f(dr.select(ok, frame.s, si.sh_frame.s),
                                  dr.select(ok, frame.t, si.sh_frame.t),
                                  dr.select(ok, frame.n, si.sh_frame.n))
        out.wi = dr.select(ok, frame.to_local(-ray.d), si.wi)
        out.dp_du = dr.select(ok, frame.s, si.dp_du)
        out.dp_dv = dr.select(ok, frame.t, si.dp_dv)
        out.uv = dr.select(ok, mi.Point2f(0.0), si.uv)
        out.prim_index = dr.select(ok, 0, si.prim_index)
        if dr.is_jit_v(mi.Float):
            out.shape = dr.select(ok, mi.ShapePtr(self), si.shape)
        elif ok:
            out.shape = self
        return out, ok

    def left_surface(self, ray: mi.Ray3f, mesh_si: mi.SurfaceInteraction3f,
                     exact_si: mi.SurfaceInteraction3f) -> mi.Bool:
        """Lanes whose hit (``mesh_si`` on the mesh, ``exact_si`` from ``exact_hit``) is the
        surface the ray leaves, for rays that leave exact points without an offset: the
        exact crossing within ``SELF_HIT`` of the origin, or, where ``exact_hit`` found no
        crossing, the mesh hit within ``SELF_HIT`` plus the mesh's own reach
        (2 max_error / |cos|) of it."""
        cos = dr.abs(dr.dot(dr.detach(mesh_si.n), dr.detach(ray.d)))
        reach = self.SELF_HIT + 2.0 * self.max_error / dr.maximum(cos, 0.05)
        unmoved = exact_si.t == mesh_si.t
        return (exact_si.t <= self.SELF_HIT) | (unmoved & (mesh_si.t <= reach))

    # -- the analytic intersection (tessellate = false) ------------------------------------
    def _bound_level(self) -> float:
        """A level L with F < 1 wherever every x_i >= L: f(10/j) = 0.1 j (j >= 2), so
        N sources outside x = 10/j give F <= 0.1 j N < 1 for j < 10/N (L = 10: F = 0)."""
        j = max(1, math.ceil(10.0 / len(self.centers)) - 1)
        return 10.0 / j

    @staticmethod
    def _zone_lines(x: mi.Float) -> tuple[mi.Float, mi.Float]:
        """The zone field's line f = di + ds x at ``x``: (ds, di), (0, 0) beyond x = 10.
        The depth k = #{j in 1..9: x <= 10/j} = min(9, floor(10/x)) picks the cumulative
        tables' line (blobmesh.field); from k = 2 on they are the chords of 1/x (checked at
        import), so a few operations instead of one select per zone."""
        return Blob._lines_of(dr.clip(dr.floor(10.0 / dr.maximum(x, 1e-30)), 0.0, 9.0))

    @staticmethod
    def _field_of(x: mi.Float) -> mi.Float:
        """One source's zone field f(x)."""
        ds, di = Blob._zone_lines(x)
        return dr.fma(ds, x, di)

    @staticmethod
    def _first_root(qa: mi.Float, qb: mi.Float, qg: mi.Float, lo: mi.Float, span: mi.Float
                    ) -> mi.Float:
        """The smallest root s of qa s^2 + qb s + qg in [lo, span] (stable form), or inf."""
        disc = qb * qb - 4.0 * qa * qg
        sq = dr.safe_sqrt(disc)
        q = -0.5 * (qb + dr.select(qb >= 0, sq, -sq))
        r1 = dr.select(qa != 0, q / dr.select(qa != 0, qa, 1.0), dr.inf)
        r2 = dr.select(q != 0, qg / dr.select(q != 0, q, 1.0), dr.inf)
        small, large = dr.minimum(r1, r2), dr.maximum(r1, r2)
        return dr.select((disc >= 0) & (small >= lo) & (small <= span), small,
                         dr.select((disc >= 0) & (large >= lo) & (large <= span), large, dr.inf))

    def _quadratic(self, tcs: list, x0s: list, a: mi.Float, t0: mi.Float, t1: mi.Float
                   ) -> tuple[mi.Float, mi.Float, mi.Float]:
        """F - 1 = A s^2 + B s + G in s = t - t0 on [t0, t1], no zone sphere crossed inside:
        each source's line taken at the midpoint."""
        tm = 0.5 * (t0 + t1)
        return self._quadratic_of(tcs, x0s, a, t0, [self._zone_lines(x0 + a * dr.square(tm - tc))
                                                    for tc, x0 in zip(tcs, x0s)])

    @staticmethod
    def _quadratic_of(tcs: list, x0s: list, a: mi.Float, t0: mi.Float, lines: list
                      ) -> tuple[mi.Float, mi.Float, mi.Float]:
        """F - 1 = A s^2 + B s + G in s = t - t0 with each source on its line (ds, di)."""
        qa, qb, qg = mi.Float(0.0), mi.Float(0.0), mi.Float(-1.0)
        for tc, x0, (ds, di) in zip(tcs, x0s, lines):
            u0 = t0 - tc
            qa += ds * a
            qb += ds * (2.0 * a * u0)
            qg += ds * (x0 + a * u0 * u0) + di
        return qa, qb, qg

    def _approach(self, ray: mi.Ray3f):
        """Per source: the t of closest approach and x there; a = |d|^2/R^2 (object space)."""
        rel, do, _ = self._along(ray, ray.o)
        a = dr.squared_norm(do) / (self.radius * self.radius)
        inv_d2 = 1.0 / dr.squared_norm(do)
        tcs, x0s = [], []
        for r in rel:
            tc = -dr.dot(r, do) * inv_d2
            tcs.append(tc)
            x0s.append(dr.squared_norm(r + tc * do) / (self.radius * self.radius))
        return tcs, x0s, a

    def analytic_hit(self, ray: mi.Ray3f, tmin: float, tmax: mi.Float,
                     active: mi.Bool = True, strict: bool = False) -> mi.Float:
        """The ray's first crossing of the zone field's surface F = 1 in (tmin, tmax), or
        inf. Along the ray each source's x_i = |o + t d - c_i|^2/R^2 is a parabola in t, so
        between two consecutive zone-sphere crossings (of any source) F is a quadratic:
        the loop walks those intervals from where the ray enters the region the surface
        can reach and solves one quadratic per interval (stable roots).
        ``strict``: the original's walk (spec 2.10), with its float32 running bound."""
        if strict:
            return self._strict_hit(ray, tmin, tmax, active)
        return self._clean_hit(ray, tmin, tmax, active)

    #: F units by which the clean walk widens the stretch of a ray where F >= 1 is possible
    #: (the float32 rounding of each source's f is ~1e-7)
    REACH_SLACK = 1e-4

    #: spec 2.10's zone radii r^2/R^2 "as written in the code" (zones 0..8)
    WRITTEN_RATIO = (10.0, 5.0, 3.33333, 2.5, 2.0, 1.66667, 1.42857, 1.25, 1.1111)

    @dr.syntax
    def _strict_hit(self, ray: mi.Ray3f, tmin: float, tmax: mi.Float,
                    active: mi.Bool = True) -> mi.Float:
        """The original's intersection (spec 2.10): every zone sphere's entry and exit,
        walked in t order from the first (also behind the origin) with the bound increments
        as a float32 running sum; an interval is solved only where that sum is >= 1, so a
        lone source's core can be skipped where the sum comes out at 0.99999994 (the
        original's holes). The increments are ``_BOUND_INC32``."""
        tcs, x0s, a = self._approach(ray)
        inc = _BOUND_INC32
        events = []                      # (t, crossed, signed bound increment), walked in t order
        total = mi.Float(0.0)            # quick reject: the entry increments, source by source
        for tc, x0 in zip(tcs, x0s):
            for k, level in enumerate(self.WRITTEN_RATIO):
                crossed = x0 < level
                total += dr.select(crossed, inc[k], 0.0)
                h = dr.safe_sqrt((level - x0) / a)
                events.append((tc - h, crossed, inc[k]))
                events.append((tc + h, crossed, -inc[k]))
        hit_t = mi.Float(dr.inf)
        t0 = mi.Float(-dr.inf)
        i0 = mi.Int32(-1)
        bound = mi.Float(0.0)
        walking = mi.Bool(active) & (total >= 1.0)
        while walking:
            # the next event in (t, index) order
            t1 = mi.Float(dr.inf)
            i1 = mi.Int32(-1)
            step = mi.Float(0.0)
            for e, (te, crossed, de) in enumerate(events):
                later = crossed & ((te > t0) | ((te == t0) & (e > i0)))
                better = later & (te < t1)
                t1 = dr.select(better, te, t1)
                i1 = dr.select(better, e, i1)
                step = dr.select(better, de, step)
            solve = (bound >= 1.0) & (t1 > t0) & (t1 > tmin) & (t0 < tmax) & dr.isfinite(t1)
            if solve:
                qa, qb, qg = self._quadratic(tcs, x0s, a, t0, t1)
                s = self._first_root(qa, qb, qg, dr.maximum(tmin - t0, 0.0), t1 - t0)
                t = t0 + s
                hit_t = dr.select(dr.isfinite(s) & (t > tmin) & (t < t1) & (t <= tmax), t,
                                  hit_t)
            bound += step
            t0 = t1
            i0 = i1
            walking &= _not(dr.isfinite(hit_t)) & dr.isfinite(t1) & (t0 < tmax)
        return hit_t

    @staticmethod
    def _lines_of(k: mi.Float) -> tuple[mi.Float, mi.Float]:
        """The zone field's line (ds, di) of zone ``k`` (0: beyond x = 10)."""
        ds = dr.select(k == 1.0, float(SLOPE[1]), -0.01 * k * (k + 1.0))
        di = dr.select(k == 1.0, float(INTERCEPT[1]), 0.1 * (2.0 * k + 1.0))
        return dr.select(k == 0.0, 0.0, ds), dr.select(k == 0.0, 0.0, di)

    @staticmethod
    def _crossing(tc: mi.Float, x0: mi.Float, inv_a: mi.Float, k: mi.Float, out: mi.Bool
                  ) -> mi.Float:
        """A source's next zone-sphere crossing from zone ``k``: on the way in (``out``
        false) where it enters zone k + 1, on the way out where it leaves zone k (inf
        from zone 0)."""
        level = 10.0 / dr.maximum(dr.select(out, k, k + 1.0), 1.0)
        h = dr.safe_sqrt((level - x0) * inv_a)
        return dr.select(out, dr.select(k >= 1.0, tc + h, dr.inf), tc - h)

    def _clean_hit(self, ray: mi.Ray3f, tmin: float, tmax: mi.Float,
                   active: mi.Bool = True) -> mi.Float:
        tcs, x0s, a = self._approach(ray)
        inv_a = 1.0 / a
        bound = self._bound_level()
        t_enter, t_exit = mi.Float(dr.inf), mi.Float(-dr.inf)
        for tc, x0 in zip(tcs, x0s):
            h = dr.safe_sqrt((bound - x0) * inv_a)
            near = x0 < bound
            t_enter = dr.select(near, dr.minimum(t_enter, tc - h), t_enter)
            t_exit = dr.select(near, dr.maximum(t_exit, tc + h), t_exit)
        # where F >= 1 is possible at all: each source contributes at most f(x0), at its
        # closest approach, so with M = sum f(x0_i), F(t) >= 1 needs M >= 1 and every source
        # within M - 1 of its most, f(x_i(t)) >= f(x0_i) - (M - 1): an interval of t per
        # source whose limit is not vacuous. The walk runs on their intersection (on page 4
        # it takes half the walk's steps, and most rays that miss take none)
        f0s = [self._field_of(x0) for x0 in x0s]
        excess = f0s[0] - 1.0
        for f0 in f0s[1:]:
            excess += f0
        for tc, x0, f0 in zip(tcs, x0s, f0s):
            v = f0 - excess - self.REACH_SLACK
            ds, di = self._lines_of(dr.clip(dr.ceil(10.0 * v) - 1.0, 1.0, 9.0))
            h = dr.safe_sqrt(((v - di) / ds - x0) * inv_a)     # f(x) = v: f's inverse
            near = v > 0.0
            t_enter = dr.select(near, dr.maximum(t_enter, tc - h), t_enter)
            t_exit = dr.select(near, dr.minimum(t_exit, tc + h), t_exit)
        t0 = dr.maximum(t_enter, tmin)
        hi = dr.select(excess >= -self.REACH_SLACK, dr.minimum(t_exit, tmax), -dr.inf)
        # per source: the deepest zone the ray reaches (fixed along it), the zone just past
        # t0 (probed just beyond it), whether the ray is past that deepest zone's entry (on
        # the way out), and the next crossing; the walk then moves one source at a time
        probe = t0 + 1e-3
        deeps, ks, outs, tns = [], [], [], []
        for tc, x0 in zip(tcs, x0s):
            deep = dr.minimum(dr.floor(10.0 / dr.maximum(x0, 1e-30)), 9.0)
            u = probe - tc
            k = dr.minimum(dr.floor(10.0 / dr.maximum(x0 + a * u * u, 1e-30)), deep)
            out = (u >= 0) | (k >= deep)
            deeps.append(deep)
            ks.append(k)
            outs.append(out)
            tns.append(self._crossing(tc, x0, inv_a, k, out))
        n = len(tcs)

        def body(t0, hit_t, walking, ks, outs, tns):
            t1 = mi.Float(hi)
            for tn in tns:
                t1 = dr.minimum(t1, tn)
            # F - 1 on the interval from each source's current zone
            qa, qb, qg = self._quadratic_of(tcs, x0s, a, t0, [self._lines_of(k) for k in ks])
            s = self._first_root(qa, qb, qg, 0.0, t1 - t0)
            found = dr.isfinite(s)
            hit_t = dr.select(walking & found, t0 + s, hit_t)
            # the source whose crossing ends the interval moves to its next zone
            j = mi.UInt32(n)
            for i in reversed(range(n)):
                j = dr.select(tns[i] == t1, i, j)
            tc_j, x0_j, k_j, out_j, deep_j = tcs[0], x0s[0], ks[0], outs[0], deeps[0]
            for i in range(1, n):
                on = j == i
                tc_j = dr.select(on, tcs[i], tc_j)
                x0_j = dr.select(on, x0s[i], x0_j)
                k_j = dr.select(on, ks[i], k_j)
                out_j = dr.select(on, outs[i], out_j)
                deep_j = dr.select(on, deeps[i], deep_j)
            k_j = dr.select(out_j, k_j - 1.0, k_j + 1.0)
            out_j = out_j | (k_j >= deep_j)
            tn_j = self._crossing(tc_j, x0_j, inv_a, k_j, out_j)
            ks, outs, tns = list(ks), list(outs), list(tns)
            for i in range(n):
                on = walking & (j == i)
                ks[i] = dr.select(on, k_j, ks[i])
                outs[i] = dr.select(on, out_j, outs[i])
                tns[i] = dr.select(on, tn_j, tns[i])
            t0 = dr.select(walking, t1, t0)
            walking = walking & _not(found) & (t0 < hi)
            return t0, hit_t, walking, ks, outs, tns

        walking = mi.Bool(active) & (t0 < hi)
        state = (t0, mi.Float(dr.inf), walking, ks, outs, tns)
        state = dr.while_loop(state, lambda t0, hit_t, walking, *_: walking, body,
                              labels=("t0", "hit_t", "walking", "ks", "outs", "tns"),
                              label="Blob._clean_hit")
        return state[1]

    def interaction(self, ray: mi.Ray3f, t: mi.Float, active: mi.Bool = True
                    ) -> mi.SurfaceInteraction3f:
        """The surface interaction of ``ray`` at ``analytic_hit``'s ``t``: the ``normals``
        option's frame there (``flat``: the field's normal), ``n`` its normal, uv 0."""
        rel, do, normal_to_world = self._along(ray, ray.o)
        t = dr.select(active, t, 0.0)
        frame, _ = self._frame_at(rel, do, t, normal_to_world)
        if dr.is_jit_v(mi.Float):
            si = dr.zeros(mi.SurfaceInteraction3f, dr.width(t))
            si.shape = dr.select(active, mi.ShapePtr(self), dr.zeros(mi.ShapePtr))
        else:
            si = mi.SurfaceInteraction3f()
            si.shape = self
        si.t = dr.select(active, t, dr.inf)
        si.p = dr.fma(mi.Vector3f(dr.detach(ray.d)), t, ray.o)
        si.n = frame.n
        si.sh_frame = frame
        si.wi = frame.to_local(-ray.d)
        si.dp_du, si.dp_dv = frame.s, frame.t
        si.uv = mi.Point2f(0.0)
        si.time, si.wavelengths = ray.time, ray.wavelengths
        return si

    def _zone(self, x: mi.Float) -> tuple[mi.Float, mi.Float]:
        """f(x) and f'(x) of one source (the ``field`` option)."""
        if self.field == "exact":
            inv = 1.0 / dr.maximum(x, 1e-30)
            return inv, -dr.square(inv)
        ds, di = self._zone_lines(x)
        return di + ds * x, ds

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
