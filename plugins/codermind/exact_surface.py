"""The contract between a shape that knows its exact surface and the integrators that use
it (``tutorialpath``).

A shape may stand in for a surface that no triangle mesh reproduces exactly, such as the
``blob``'s zone field. Such a shape implements :class:`ExactSurface`, and an
integrator finds it with ``isinstance(shape, ExactSurface)`` (a runtime-checkable protocol:
no base class is needed, which matters because a Python shape subclasses ``mi.Mesh`` and
nanobind allows it no second base). Built-in shapes do not implement it and are intersected
as usual.

The shape is in one of two modes, given by :attr:`ExactSurface.tessellated`:

* ``True``: the shape is a mesh that Embree intersects, inscribed in the exact surface. The
  integrator may move a mesh hit onto the surface (:meth:`~ExactSurface.exact_hit`), pass
  through a hit that is the surface the ray leaves (:meth:`~ExactSurface.left_surface`),
  and find where a ray that leaves the surface inwards comes out
  (:meth:`~ExactSurface.exit_hit`).
* ``False``: the shape has no mesh that any ray hits. The integrator intersects the exact
  surface itself (:meth:`~ExactSurface.analytic_hit`) for every ray and shadow ray and
  shades the hit with :meth:`~ExactSurface.interaction`.

Units: every ``t`` is a distance along the ray in world units (rays are unit length, so the
same as world distance), and so are :attr:`~ExactSurface.SELF_HIT` and ``limit``. Arrays are
the current variant's Dr.Jit types, one lane per ray; a lane outside ``active`` is returned
unchanged (or with ``t`` = inf). None of the methods carries derivatives: the moves onto
the exact surface are detached.

Rays that leave a point on the exact surface start at that point without Mitsuba's spawn
offset; a crossing within :attr:`~ExactSurface.SELF_HIT` of a ray's origin is the surface
the ray leaves, not a new hit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    import mitsuba as mi


@runtime_checkable
class ExactSurface(Protocol):
    """A shape that knows its exact surface (see the module's docstring for the two modes,
    the units and what holds of every method)."""

    #: True: a mesh inscribed in the exact surface, intersected by Embree (use
    #: ``exact_hit``, ``left_surface``, ``exit_hit``); False: no mesh (use ``analytic_hit``
    #: and ``interaction``).
    tessellated: bool

    #: The self-intersection distance (world units): a crossing this close to a ray's
    #: origin is the surface the ray leaves.
    SELF_HIT: float

    def exact_hit(self, ray: mi.Ray3f, si: mi.SurfaceInteraction3f,
                  active: mi.Bool) -> mi.SurfaceInteraction3f:
        """``si``, a hit of ``ray`` on this shape's mesh, moved onto the exact surface where
        the surface crosses the ray near the mesh's ``t``: ``t``, ``p``, ``n``, the shading
        frame and ``wi`` (in that frame). ``t`` may come out <= 0 (the crossing lies behind
        the ray's origin). Lanes without such a crossing near the mesh hit (grazing rays
        that hit the mesh but not the surface) keep ``si`` unchanged, bit for bit: callers
        detect them by ``t`` equal to the mesh's."""
        ...

    def left_surface(self, ray: mi.Ray3f, mesh_si: mi.SurfaceInteraction3f,
                     exact_si: mi.SurfaceInteraction3f) -> mi.Bool:
        """Lanes where the hit (``mesh_si`` on the mesh, ``exact_si`` what ``exact_hit``
        made of it) is the surface that ``ray`` leaves (its origin lies on the exact
        surface): the caller passes through it along the ray."""
        ...

    def exit_hit(self, ray: mi.Ray3f, si: mi.SurfaceInteraction3f, limit: mi.Float,
                 active: mi.Bool) -> tuple[mi.SurfaceInteraction3f, mi.Bool]:
        """For rays whose origin lies inside the exact surface, or on it heading into it:
        where the ray comes out, if that lies beyond ``SELF_HIT`` and before ``limit``
        (``si`` is the ray's next hit in the scene, or its miss, and ``limit`` the ``t``
        up to which the caller trusts it). Returns ``si`` replaced there (a hit on this
        shape, with its shading frame) and the lanes replaced."""
        ...

    def analytic_hit(self, ray: mi.Ray3f, tmin: float, tmax: mi.Float,
                     active: mi.Bool = True, strict: bool = False) -> mi.Float:
        """The ``t`` of the ray's first crossing of the exact surface in (``tmin``,
        ``tmax``), or inf. ``strict``: the tutorial programs' own intersection, quirks
        included (for ``tutorialpath``'s ``quirks`` = ``strict``)."""
        ...

    def interaction(self, ray: mi.Ray3f, t: mi.Float,
                    active: mi.Bool = True) -> mi.SurfaceInteraction3f:
        """The surface interaction of ``ray`` at ``analytic_hit``'s ``t`` (a hit on this
        shape: ``t``, ``p``, ``n``, the shading frame, ``wi``; ``t`` = inf outside
        ``active``)."""
        ...
