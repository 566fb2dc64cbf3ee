"""Ray queries against a scene of Mitsuba ``sphere`` shapes, traced into the integrator's
kernel instead of through Embree (for ``tutorialpath``).

Mitsuba hands each sphere to Embree as user geometry: every ray and shadow ray of a packet
goes through Embree's traversal and a call back into the sphere's own intersection, which
on page 4 costs about a quarter of the render. With only a few spheres in the scene, testing
each of them in the kernel is cheaper. The arithmetic is the sphere's own (Mitsuba 3.9.1
``src/shapes/sphere.cpp``: ``ray_intersect_preliminary_impl`` with its plane shift for hits,
``ray_test_impl`` for shadow rays, float32 in the JIT variants), and the surface interaction
is the sphere's own ``compute_surface_interaction``, so a hit is what ``scene.ray_intersect``
reports; only exact ties differ: the first sphere of the scene wins them (the tutorial's
strict test), where Embree picks one in its own order.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi


def _on_segment(ray: mi.Ray3f, o: mi.Vector3f, radius: float, shift: mi.Float | float = 0.0
                ) -> tuple[mi.Bool, mi.Float]:
    """The sphere's roots for the ray from ``o`` (its origin relative to the centre, moved
    ``shift`` along the ray) and whether one lies on the ray's segment [0, maxt]: the
    sphere's own bounds test, and its t (near, or far from inside)."""
    d = mi.Vector3f(ray.d)
    found, near, far = mi.math.solve_quadratic(dr.squared_norm(d), 2.0 * dr.dot(o, d),
                                               dr.squared_norm(o) - radius * radius)
    near, far = near + shift, far + shift
    out = ~((near <= ray.maxt) & (far >= 0.0))
    inside = (near < 0.0) & (far > ray.maxt)
    return found & ~out & ~inside, dr.select(near < 0.0, far, near)


class Spheres:
    """The scene's spheres as (shape, centre, radius), if every shape of ``scene`` is a plain
    ``sphere`` or one of ``others`` (shapes the integrator intersects itself); else None."""

    def __init__(self, shapes: list):
        self.shapes = shapes

    @staticmethod
    def of(scene: mi.Scene, others: list) -> Spheres | None:
        if not dr.is_jit_v(mi.Float):
            return None
        found = []
        for shape in scene.shapes():
            if any(shape is o for o in others):
                continue
            if shape.shape_type() != mi.ShapeType.Sphere:
                return None
            to_world = mi.traverse(shape)["to_world"]
            # as Sphere::update: the centre and |to_world (1, 0, 0)|, in float32
            center = to_world @ mi.Point3f(0.0)
            radius = dr.abs(dr.norm(to_world @ mi.Vector3f(1.0, 0.0, 0.0)))
            found.append((shape, [float(v[0]) for v in center], float(radius[0])))
        return Spheres(found)

    @staticmethod
    def _hit_t(ray: mi.Ray3f, center, radius: float) -> tuple[mi.Bool, mi.Float]:
        """``Sphere::ray_intersect_preliminary_impl``: the roots from the ray's closest
        point to the centre (its plane shift), then moved back."""
        c = mi.Point3f(*center)
        d = mi.Vector3f(ray.d)
        plane_t = dr.dot(c - ray.o, d) / dr.norm(d)
        return _on_segment(ray, dr.fma(d, plane_t, ray.o) - c, radius, plane_t)

    def intersect(self, ray: mi.Ray3f, flags: mi.RayFlags, active: mi.Bool
                  ) -> mi.SurfaceInteraction3f:
        """The closest sphere hit of ``ray`` (as ``scene.ray_intersect``)."""
        pi = dr.zeros(mi.PreliminaryIntersection3f)
        best = mi.Float(dr.inf)
        shape = dr.zeros(mi.ShapePtr)
        for s, center, radius in self.shapes:
            ok, t = self._hit_t(ray, center, radius)
            closer = active & ok & (t < best)
            best = dr.select(closer, t, best)
            shape = dr.select(closer, mi.ShapePtr(s), shape)
        pi.t = best
        pi.shape = shape
        pi.valid = active & dr.isfinite(best)
        pi.prim_index = mi.UInt32(0)
        pi.shape_index = mi.UInt32(0)
        return pi.compute_surface_interaction(ray, flags, active)

    def test(self, ray: mi.Ray3f, active: mi.Bool) -> mi.Bool:
        """Whether any sphere meets ``ray`` before its maxt (``Sphere::ray_test_impl``)."""
        hit = mi.Bool(False)
        for _, center, radius in self.shapes:
            hit |= _on_segment(ray, ray.o - mi.Point3f(*center), radius)[0]
        return active & hit
