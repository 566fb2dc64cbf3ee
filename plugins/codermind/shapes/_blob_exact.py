"""The exact surface of a ``blob`` (:class:`BlobSurface`): its hits moved from the mesh onto
the true surface by Newton's method, the exit of rays that run between the mesh and the
surface, and the analytic intersection of the zone field (the walk is in
:mod:`codermind.shapes._blob_zones`). The ``blob`` shape delegates its
:class:`codermind.exact_surface.ExactSurface` methods here.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np

from ..blobmesh.field import NORMAL_SKIP
from . import _blob_zones as zones


class BlobSurface:
    """The zone-field (or exact-field) surface of a blob, in world space: the sources
    ``centers`` (N x 3, object space), ``radius``, ``field`` and ``normals`` (the ``blob``
    options), ``matrix`` (``to_world``, 4 x 4 affine) and ``max_error`` (the mesh's error
    bound, world units; the reach of its hits around the surface). Read only: the shape
    makes a new one when its parameters change."""

    #: Newton steps from the mesh's hit; the error falls quadratically within a zone piece,
    #: so 2 take a max_error start to float32 rounding (tests/plugins/test_blob_plugin.py)
    REFINE_STEPS = 2
    #: the tutorial's blob epsilon (facts.md F4, world units): a crossing this close to a ray's
    #: origin is the surface the ray leaves (tutorialpath's exact_hits)
    SELF_HIT = 0.01
    #: F - 1 beyond which a ray's origin is inside the surface (``exit_hit``)
    INSIDE_F = 1e-5

    def __init__(self, centers: np.ndarray, radius: float, field: str, normals: str,
                 matrix: np.ndarray, max_error: float):
        self.centers, self.radius, self.field = centers, radius, field
        self.normals, self.matrix, self.max_error = normals, matrix, max_error

    # -- hits moved from the mesh onto the exact surface (tessellate = true) ---------------
    def along(self, ray: mi.Ray3f, origin: mi.Point3f):
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

    def residual(self, rel: list, do: mi.Vector3f, s: mi.Float
                 ) -> tuple[mi.Float, mi.Float, mi.Float]:
        """(F - 1, dF/ds, d2F/ds2 within the zones) at ``rel + s do``."""
        inv_r2 = 1.0 / (self.radius * self.radius)
        value, slope, curve = mi.Float(-1.0), mi.Float(0.0), mi.Float(0.0)
        for r in rel:
            q = r + s * do
            f, df = self.zone(dr.squared_norm(q) * inv_r2)
            value += f
            slope += df * (2.0 * inv_r2) * dr.dot(q, do)
            curve += df * (2.0 * inv_r2) * dr.squared_norm(do)
        return value, slope, curve

    def newton(self, rel: list, do: mi.Vector3f, s: mi.Float
               ) -> tuple[mi.Float, mi.Float, mi.Float, mi.Float]:
        """``REFINE_STEPS`` Newton steps on F - 1 along ``rel + s do`` from ``s``, and one
        more only measured: (s, F - 1, dF/ds, that last step) at the result."""
        for _ in range(self.REFINE_STEPS + 1):
            g, slope, _ = self.residual(rel, do, s)
            step = dr.select(slope != 0, g / dr.select(slope != 0, slope, 1.0), 0.0)
            s = s - step
        return s + step, g, slope, step

    def frame_at(self, rel: list, do: mi.Vector3f, s: mi.Float, normal_to_world
                 ) -> tuple[mi.Frame3f, mi.Bool]:
        """The ``normals`` option's shading frame at ``rel + s do`` (not ``flat``)."""
        inv_r2 = 1.0 / (self.radius * self.radius)
        n = mi.Vector3f(0.0)
        for r in rel:
            q = r + s * do
            d2 = dr.squared_norm(q)
            if self.normals == "exact":         # sum R^2/|q|^4 q (facts.md F11.4; NORMAL_SKIP)
                w = dr.select(d2 * inv_r2 > NORMAL_SKIP, self.radius ** 2 / dr.square(d2), 0.0)
            else:                               # -grad F: outward
                w = -self.zone(d2 * inv_r2)[1] * (2.0 * inv_r2)
            n += w * q
        n = normal_to_world @ n
        return mi.Frame3f(dr.normalize(n)), dr.squared_norm(n) > 0

    def exact_hit(self, ray: mi.Ray3f, si: mi.SurfaceInteraction3f,
                  active: mi.Bool) -> mi.SurfaceInteraction3f:
        """``si`` (a hit of ``ray`` on the blob's mesh) moved onto the exact surface, where the
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
        rel, do, normal_to_world = self.along(ray, si.p)
        entering = dr.dot(dr.detach(si.n), dr.detach(ray.d)) < 0

        s, _, slope, step = self.newton(rel, do, mi.Float(0.0))   # its slope: the side
        cos = dr.abs(dr.dot(dr.detach(si.n), dr.detach(ray.d)))
        bound = 2.0 * self.max_error / dr.maximum(cos, 0.05)
        ok = active & dr.isfinite(s) & (dr.abs(s) <= bound) & \
            (dr.abs(step) <= 1e-3 * self.max_error + 1e-6 * dr.abs(si.t)) & \
            ((slope > 0) == entering) & (slope != 0)
        s = dr.select(ok, s, 0.0)

        frame = si.sh_frame
        if self.normals != "flat":
            frame, nonzero = self.frame_at(rel, do, s, normal_to_world)
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

    def exit_hit(self, shape: mi.Shape, ray: mi.Ray3f, si: mi.SurfaceInteraction3f,
                 limit: mi.Float, active: mi.Bool) -> tuple[mi.SurfaceInteraction3f, mi.Bool]:
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
        Returns ``si`` replaced by that hit (on ``shape``, with the ``normals`` option's
        frame at the new point; ``flat``: the field's normal) and the lanes replaced."""
        if len(self.centers) == 0:
            return si, mi.Bool(False)
        rel, do, normal_to_world = self.along(ray, ray.o)
        g0, slope0, curve0 = self.residual(rel, do, mi.Float(0.0))
        # inside, or on the surface heading in. An exact point's F - 1 is only known to
        # its float32 position (~3e-5 units at the tutorial's ~500: ~1e-6 of F), so a
        # point counts as inside only beyond that; else a grazing ray heading OUT of an
        # exact point would find a spurious exit a fraction of a unit on
        inward = active & (curve0 < 0) & ((g0 > self.INSIDE_F) |
                                          ((slope0 > 0) & (g0 > -self.INSIDE_F)))
        disc = dr.square(slope0) - 2.0 * curve0 * dr.maximum(g0, 0.0)
        s = dr.select(inward, (slope0 + dr.safe_sqrt(disc)) / dr.select(curve0 < 0, -curve0,
                                                                         1.0), 0.0)
        s, g, slope, step = self.newton(rel, do, s)
        # grazing chords have slopes of ~1e-4 per unit: float32's rounding of F (~1e-7)
        # then moves t by ~1e-3, so converged means a step within tolerance or F - 1 at
        # that rounding
        ok = inward & dr.isfinite(s) & (slope < 0) & (s > self.SELF_HIT) & (s < limit) & \
            ((dr.abs(step) <= 1e-3 * self.max_error + 1e-6 * s) | (dr.abs(g) <= 4e-7))
        frame, nonzero = self.frame_at(rel, do, s, normal_to_world)
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
            out.shape = dr.select(ok, mi.ShapePtr(shape), si.shape)
        elif ok:
            out.shape = shape
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
    def approach(self, ray: mi.Ray3f) -> tuple[list, list, mi.Float]:
        """Per source: the t of closest approach and x there; a = |d|^2/R^2 (object space)."""
        rel, do, _ = self.along(ray, ray.o)
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
        ``strict``: the original's walk (facts.md F11), with its float32 running bound."""
        if strict:
            return zones.strict_walk(*self.approach(ray), tmin, tmax, active)
        return zones.clean_walk(*self.approach(ray), zones.bound_level(len(self.centers)),
                                tmin, tmax, active)

    def interaction(self, shape: mi.Shape, ray: mi.Ray3f, t: mi.Float, active: mi.Bool = True
                    ) -> mi.SurfaceInteraction3f:
        """The surface interaction of ``ray`` at ``analytic_hit``'s ``t``: the ``normals``
        option's frame there (``flat``: the field's normal), ``n`` its normal, uv 0, on
        ``shape``."""
        rel, do, normal_to_world = self.along(ray, ray.o)
        t = dr.select(active, t, 0.0)
        frame, _ = self.frame_at(rel, do, t, normal_to_world)
        if dr.is_jit_v(mi.Float):
            si = dr.zeros(mi.SurfaceInteraction3f, dr.width(t))
            si.shape = dr.select(active, mi.ShapePtr(shape), dr.zeros(mi.ShapePtr))
        else:
            si = mi.SurfaceInteraction3f()
            si.shape = shape
        si.t = dr.select(active, t, dr.inf)
        si.p = dr.fma(mi.Vector3f(dr.detach(ray.d)), t, ray.o)
        si.n = frame.n
        si.sh_frame = frame
        si.wi = frame.to_local(-ray.d)
        si.dp_du, si.dp_dv = frame.s, frame.t
        si.uv = mi.Point2f(0.0)
        si.time, si.wavelengths = ray.time, ray.wavelengths
        return si

    def zone(self, x: mi.Float) -> tuple[mi.Float, mi.Float]:
        """f(x) and f'(x) of one source (the ``field`` option)."""
        if self.field == "exact":
            inv = 1.0 / dr.maximum(x, 1e-30)
            return inv, -dr.square(inv)
        ds, di = zones.zone_lines(x)
        return di + ds * x, ds
