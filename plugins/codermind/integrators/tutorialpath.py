from __future__ import annotations  # Delayed parsing of type annotations

import drjit as dr
import mitsuba as mi

from ..exact_surface import ExactSurface
from ..exposed import exposed, take_float, take_int
from ..masks import logical_not as _not
from ._spheres import Spheres

QUIRKS = ("clean", "strict")
#: Mitsuba's shadow-ray epsilon (``spawn_ray_to`` shortens a shadow ray by it).
SHADOW_EPSILON = mi.math.ShadowEpsilon


def _mis_weight(pdf_a: mi.Float, pdf_b: mi.Float) -> mi.Float:
    """Power heuristic, as Mitsuba's ``path``: 0 where it is not finite (a light sample
    at grazing incidence on an area light has pdf inf, and inf / inf is NaN)."""
    a2 = dr.square(pdf_a)
    total = a2 + dr.square(pdf_b)
    w = a2 / dr.select(total > 0, total, 1.0)      # (scalar variants raise on 0 / 0)
    return dr.detach(dr.select(dr.isfinite(w), w, 0.0))


def _eval_sample(bsdf: mi.BSDF, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f,
                 wos: list[mi.Vector3f], sample1: mi.Float, sample2: mi.Point2f,
                 active: mi.Bool = True):
    """``[bsdf.eval(wo) for wo in wos]`` and ``bsdf.sample``: one call of the BSDF's fused
    ``eval_sample`` where it has one (``tutorial``, ``noisebump``: the bump, the Fresnel
    terms and the textures once per hit), else its separate methods (Mitsuba's BSDFs)."""
    fused = getattr(bsdf, "eval_sample", None)
    if fused is not None:
        return fused(ctx, si, wos, sample1, sample2, active)
    values = [bsdf.eval(ctx, si, wo, active) for wo in wos]
    bs, weight = bsdf.sample(ctx, si, sample1, sample2, active)
    return values, bs, weight


def _is(shape_ptr, shape: mi.Shape) -> mi.Bool:
    """Lanes whose hit is on ``shape`` (a Python object in scalar variants)."""
    if not dr.is_jit_v(mi.Float):
        return shape_ptr is not None and shape_ptr == shape
    return shape_ptr == mi.ShapePtr(shape)


class TutorialIntegrator(mi.SamplingIntegrator):
    r"""
    .. _integrator-tutorialpath:

    The Codermind tutorial's transport (:monosp:`tutorialpath`)
    ------------------------------------------------------------

    .. pluginparameters::

     * - max_depth
       - |int|
       - Longest path depth, as Mitsuba's ``path`` counts it (1: only what the camera rays
         see; -1: unlimited). The tutorial's 10 segments are 11 (Default: 11)

     * - exact_hits
       - |bool|
       - Move every hit on a shape that knows its exact surface (one that implements
         ``codermind.exact_surface.ExactSurface`` with a mesh: the :monosp:`blob`
         mesh) from the mesh onto that surface (``Blob.exact_hit``: a few Newton steps
         along the ray): position, normals and ``wi``; rays leave from there. A mesh hit
         whose exact crossing lies within the tutorial's blob epsilon of the ray's origin
         (0.01, facts.md F4.2: the surface the ray left; rays leave exact points without
         Mitsuba's spawn offset, as the tutorial's do) is passed through without shading
         or a segment. A ray that leaves an exact point into the surface and runs between
         the inscribed mesh and the surface (a grazing chord, e.g. a reflection a bump
         turns inwards) comes out where the surface says (``Blob.exit_hit``), not where the
         mesh lets it escape. ``false``: the mesh's hits, as :monosp:`path` sees them
         (Default: ``true``)

     * - min_distance
       - |float|
       - The tutorial's self-intersection rule instead of Mitsuba's: where > 0, rays
         (continuations and shadow rays) leave a hit point p from p + min_distance * d along
         their own direction d, with no offset along the normal, so a surface counts only
         beyond that distance along the ray, as the tutorial's roots count only beyond its
         epsilon (facts.md F4.1: 0.1 for spheres). It decides where two surfaces meet (page 1's
         spheres 0 and 1 cross on the plane x = 320, which the camera's column 320 sees):
         Mitsuba's normal offset can carry the origin across the other surface. Rays that
         leave an exact hit (``exact_hits``) keep their own rule. 0: Mitsuba's spawn offsets,
         as :monosp:`path` (Default: 0)

     * - quirks
       - |string|
       - ``clean``: the expectation of the built-in :monosp:`path` with the same
         ``max_depth`` and no Russian roulette. ``strict``: the tutorial programs' quirks
         that Mitsuba's geometry allows (below) (Default: ``clean``)

     * - draw_diffuse
       - |bool|
       - How a hit on a :monosp:`tutorial` material is lit. ``false``: at every hit, its
         lights times the probability of the roulette's "diffuse" event
         (1 - Rf - Tr), while the path goes on where the draw picks a reflection or a
         refraction: the expected value of that event, less noise. ``true``: as the
         tutorial draws it (facts.md F8.3): the lights at full weight only where the same
         draw picks "diffuse" (the path ends there), nothing elsewhere. Both have the same
         expected value; only ``true`` has the original's distribution per sample, which a
         nonlinear statistic of single rays needs: the auto-exposure probes
         (``codermind.tutorial.render.probe_radiance``; facts.md F6.3). Shapes whose BSDF
         is not a :monosp:`tutorial` one (optionally in :monosp:`noisebump`) keep
         ``false`` (Default: ``false``)

    A path tracer written for the tutorial's scenes (:monosp:`tutorial` BSDFs, optionally
    inside :monosp:`noisebump`; :monosp:`tutorialpoint` or other delta lights; the
    :monosp:`cubemap` background), faster than :monosp:`path` on them:

    - at every hit, EVERY delta light (``point``, ``spot``, ``tutorialpoint``, ...) is
      added with its own shadow ray, as the tutorial sums its lights (``path`` picks one);
      the shadow ray is traced only in lanes where the BSDF's ``eval`` towards the light
      is non-zero (none inside the tutorial's glass, none on a pure mirror);
    - the path continues with the BSDF's own ``sample`` (the tutorial material's
      roulette) and its weight; there is no Russian roulette (the tutorial has none);
    - a :monosp:`blob` with ``tessellate`` = ``false`` has no mesh (an ``ExactSurface``
      without one): every ray and shadow ray is intersected with its zone field directly
      (``Blob.analytic_hit``, the first crossing beyond the tutorial's blob epsilon 0.01),
      the hit shaded with the ``normals`` option's frame there, and rays leave it without
      an offset, as the tutorial's (on page 4 about twice as fast as its mesh with ``exact_hits``, whose
      hits it matches: docs/results/integrator.md);
    - a scene whose shapes are all Mitsuba ``sphere`` shapes (and blobs without a mesh), as
      the tutorial's are, is intersected here instead of through Embree: each sphere's own
      float32 test (Mitsuba's ``Sphere::ray_intersect_preliminary_impl`` and
      ``ray_test_impl``, repeated in the kernel) and its own
      ``compute_surface_interaction``, so hits are Mitsuba's bit for bit, at about 0.7 of
      the render time on page 4 (docs/results/integrator.md); of two spheres at exactly the
      same distance the first listed is hit, as in the tutorial (facts.md F4.1; Embree takes
      either);
    - a ray that escapes adds the environment emitter (the cube map), one that hits an
      area light adds its emission, both with ``path``'s MIS weight (1 after a delta
      event, which is every event of the tutorial material);
    - other light sources (area lights, an environment with a non-zero
      ``sampling_weight`` that is not a ``cubemap`` in ``background`` mode) are sampled
      as ``path`` samples them: one emitter sample per hit from the scene's emitter
      distribution, MIS with the BSDF's pdf; a sample that picks a delta light is
      dropped (the delta lights were all added), which keeps the estimate unbiased.
      ``strict`` refuses such emitters (the tutorial has none) with a one-line error.

    **clean**: the same expected value per pixel as :monosp:`path` (``rr_depth`` >=
    ``max_depth``, ``exact_hits`` = ``false``; with ``true``, path's value on the exact
    surface instead of its mesh) on every scene; with one delta light and nothing random the same
    value per sample.

    **strict** (facts.md F7, F8; every BSDF must be :monosp:`tutorial`, optionally in
    :monosp:`noisebump`, which expose the per-hit quantities through
    ``eval_attribute_1``): with the tutorial's segment limit
    :math:`S` = ``max_depth`` - 1,

    - shadow rays of pages 2 and 4 test occluders up to the SQUARED light distance;
    - turbulence and marble (a spatially varying ``diffuse``) get the path coefficient
      twice in their Lambert term;
    - a "diffuse" roulette draw inside an object re-draws at the same hit, each try
      consuming a segment (the number of failed tries is drawn at once, geometric with
      the diffuse probability); when the tries run out, the cube map is added along
      the current direction;
    - after the :math:`S`-th segment the cube map is added along the next direction
      without tracing it;
    - the Fresnel index :math:`n_1` is carried along the path (1 at the camera,
      :math:`n_2` after each refraction); where it disagrees with the BSDF's side test
      and equals :math:`n_2` (the blob's spots where the side test says "inside" for a
      ray coming from the air, or the reverse), :math:`R = 0` and the ray refracts
      unbent, as the tutorial computes it.

    - a :monosp:`blob` without a mesh (``tessellate`` = ``false``) is intersected as the
      original intersects it (facts.md F11): its zone spheres' crossings walked in t order
      with the bound as a float32 running sum, so where that sum comes out at 0.99999994
      in a lone source's core the ray passes through (the original's holes; a mesh has
      none).

    Not reproduced: the original's float32 sums of the zone polynomial itself (its roots
    differ from the exact ones by a median 1.3e-3 units on page 4's blob), the tutorial's
    zero-normal stop (Mitsuba's shapes have no zero
    normal), a carried index that differs from both sides' indices (two different
    glasses along one path; no tutorial scene has that), the refracted direction's length
    at near-normal incidence (the tutorial's next intersection takes a direction up to
    1 + 2e-3 long as unit and hits off the surface; Mitsuba's rays are unit).

    ``mi.traverse`` exposes ``max_depth`` and ``min_distance`` (non-differentiable); a
    kernel traced after ``params.update()`` uses the new values.

    .. tabs::

        .. code-tab:: xml

            <integrator type="tutorialpath">
                <integer name="max_depth" value="11"/>
                <boolean name="exact_hits" value="true"/>
                <string name="quirks" value="clean"/>
            </integrator>
    """

    #: Every delta light is added at every hit (``codermind render`` needs no render per light).
    sums_lights = True

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        depth = props.get("max_depth", 11)
        if isinstance(depth, bool) or not isinstance(depth, int) or depth < -1:
            raise ValueError(f"tutorialpath: 'max_depth' must be an integer >= -1, got {depth!r}")
        self.max_depth = depth
        self.exact_hits = props.get("exact_hits", True)
        if not isinstance(self.exact_hits, bool):
            raise ValueError(f"tutorialpath: 'exact_hits' must be a boolean, got "
                             f"{self.exact_hits!r}")
        self.min_distance = props.get("min_distance", 0.0)
        if isinstance(self.min_distance, bool) or not isinstance(self.min_distance, (int, float)) \
                or not self.min_distance >= 0:
            raise ValueError(f"tutorialpath: 'min_distance' must be a number >= 0, got "
                             f"{self.min_distance!r}")
        self.min_distance = float(self.min_distance)
        self.quirks = str(props.get("quirks", "clean"))
        self.draw_diffuse = props.get("draw_diffuse", False)
        if not isinstance(self.draw_diffuse, bool):
            raise ValueError(f"tutorialpath: 'draw_diffuse' must be a boolean, got "
                             f"{self.draw_diffuse!r}")
        if self.quirks not in QUIRKS:
            raise ValueError(f"tutorialpath: 'quirks' must be 'clean' or 'strict', got "
                             f"{self.quirks!r}")
        # scalar variants run the loop once per ray and have no null BSDF to call on a miss
        # (si.bsdf() is None there): a stand-in whose every call is masked off
        # (JIT variants too when the scene has no shape: si.bsdf() is then None as well)
        self.scalar = not dr.is_jit_v(mi.Float)
        self.stand_in = mi.load_dict({"type": "tutorial"})

    # -- the scene's emitters, sorted once per kernel trace ---------------------------------
    def _emitters(self, scene: mi.Scene):
        delta, sampled = [], []
        for e in scene.emitters():
            if mi.has_flag(e.flags(), mi.EmitterFlags.Delta):
                delta.append(e)
            elif e.sampling_weight() > 0 and getattr(e, "mode", None) != "background":
                sampled.append(e)
        if self.quirks == "strict":
            if sampled:
                raise ValueError(f"tutorialpath: quirks=strict has no light source "
                                 f"{sampled[0].id() or sampled[0].class_name()!r} in the "
                                 "tutorial (area or environment light): use quirks=clean")
            for shape in scene.shapes():
                bsdf = shape.bsdf()
                if bsdf is not None and not bsdf.has_attribute("tutorial_page"):
                    raise ValueError(f"tutorialpath: quirks=strict needs tutorial BSDFs, shape "
                                     f"{shape.id()!r} has {type(bsdf).__name__}")
        return delta, bool(sampled)

    def _draws(self, scene: mi.Scene) -> bool:
        """Whether the diffuse event is drawn (``draw_diffuse``): every shape's BSDF exposes
        the tutorial material's per-hit quantities."""
        if not self.draw_diffuse:
            return False
        bsdfs = [shape.bsdf() for shape in scene.shapes()]
        return all(b is None or b.has_attribute("tutorial_page") for b in bsdfs)

    def _exact_shapes(self, scene: mi.Scene) -> list[ExactSurface]:
        """The scene's meshes that can move a hit onto their exact surface
        (:class:`~codermind.exact_surface.ExactSurface` with a mesh)."""
        if not self.exact_hits:
            return []
        return [s for s in scene.shapes() if isinstance(s, ExactSurface) and s.tessellated]

    @staticmethod
    def _analytic_shapes(scene: mi.Scene) -> list[ExactSurface]:
        """The scene's shapes without a mesh whose exact surface is intersected here
        (:class:`~codermind.exact_surface.ExactSurface` without a mesh: a :monosp:`blob`
        with ``tessellate`` = ``false``)."""
        return [s for s in scene.shapes() if isinstance(s, ExactSurface)
                and not s.tessellated]

    @staticmethod
    def _analytic(analytic: list[ExactSurface], ray: mi.Ray3f, si: mi.SurfaceInteraction3f, active: mi.Bool,
                  strict: bool = False) -> tuple[mi.SurfaceInteraction3f, mi.Bool]:
        """``si`` replaced where a shape of ``analytic`` lies in front of it along ``ray``
        (beyond the tutorial's blob epsilon: rays leave their points without an offset),
        and the lanes replaced. ``strict``: the original's float32 running bound."""
        hit = mi.Bool(False)
        for shape in analytic:
            t = shape.analytic_hit(ray, shape.SELF_HIT, dr.minimum(si.t, ray.maxt), active,
                                   strict)
            on = active & (t < si.t)
            if dr.is_jit_v(mi.Float):
                si = dr.select(on, shape.interaction(ray, t, on), si)
            elif on:
                si = shape.interaction(ray, t, on)
            hit |= on
        return si, hit

    @staticmethod
    def _occluded(analytic: list[ExactSurface], ray: mi.Ray3f, active: mi.Bool, strict: bool = False
                  ) -> mi.Bool:
        """Lanes whose shadow ray ``ray`` meets a shape of ``analytic`` before its maxt."""
        blocked = mi.Bool(False)
        for shape in analytic:
            blocked |= dr.isfinite(shape.analytic_hit(ray, shape.SELF_HIT, ray.maxt, active,
                                                      strict))
        return blocked

    @staticmethod
    def _refine(exact: list[ExactSurface], ray: mi.Ray3f, si: mi.SurfaceInteraction3f, active: mi.Bool
                ) -> tuple[mi.SurfaceInteraction3f, mi.Bool, mi.UInt32]:
        """``si`` moved onto the exact surface of the shape it hit, if that shape is one of
        ``exact``; the lanes whose hit is the surface the ray leaves; which shape of
        ``exact`` was hit (its index + 1; 0: none)."""
        behind = mi.Bool(False)
        which = mi.UInt32(0)
        for k, shape in enumerate(exact):
            on = active & si.is_valid() & _is(si.shape, shape)
            moved = shape.exact_hit(ray, si, on)
            behind |= on & shape.left_surface(ray, si, moved)
            si = moved
            which = dr.select(on, k + 1, which)
        return si, behind, which

    @staticmethod
    def _past(ray: mi.Ray3f, hit: mi.SurfaceInteraction3f) -> mi.Ray3f:
        """``ray`` from just past ``hit`` along itself: the same line, the hit left behind."""
        scale = 1.0 + dr.max(dr.abs(hit.p))
        return mi.Ray3f(hit.p + ray.d * (scale * mi.math.RayEpsilon * 0.1), ray.d, ray.time,
                        ray.wavelengths)

    def _leave(self, si: mi.SurfaceInteraction3f, d: mi.Vector3f) -> mi.Ray3f:
        """The ray leaving ``si`` along ``d``: Mitsuba's spawn offset, or with
        ``min_distance`` from that distance along ``d`` itself."""
        if self.min_distance == 0:
            return si.spawn_ray(d)
        return mi.Ray3f(dr.fma(d, self.min_distance, si.p), d, si.time, si.wavelengths)

    def _shadow(self, si: mi.SurfaceInteraction3f, ds: mi.DirectionSample3f, squared: bool,
                on_exact: mi.Bool | None) -> mi.Ray3f:
        """The shadow ray from ``si`` towards the light ``ds``, testing occluders up to the
        light's distance (``squared``: strict's squared distance): Mitsuba's spawn offset, or
        with ``min_distance`` from that distance along the ray. Exact blob points
        (``on_exact``; None: the scene has none) keep the spawn offset: they may lie up to the
        mesh's error inside the mesh."""
        reach = dr.square(ds.dist) if squared else ds.dist
        if self.min_distance == 0 or on_exact is not None:
            if squared:
                offset = si.spawn_ray(ds.d)
                offset.maxt = reach * (1.0 - SHADOW_EPSILON)
            else:
                offset = si.spawn_ray_to(ds.p)
            if self.min_distance == 0:
                return offset
        eps = self.min_distance
        along = mi.Ray3f(dr.fma(ds.d, eps, si.p), ds.d, dr.maximum(reach - eps, 0.0), si.time,
                         si.wavelengths)
        return along if on_exact is None else dr.select(on_exact, offset, along)

    @staticmethod
    def _shadow_from_surface(si: mi.SurfaceInteraction3f, ds: mi.DirectionSample3f,
                             squared: bool) -> mi.Ray3f:
        """The shadow ray as the tutorial casts it from a point it computed on the exact
        surface: from the point itself, without an offset, up to the light's distance
        (``squared``: strict's squared distance); the blob's own epsilon (its roots count
        beyond 0.01, facts.md F4.2) is the only guard against the surface left. For the
        test against shapes without a mesh (an analytic :monosp:`blob`): a shadow ray
        offset along the normal (Mitsuba's spawn offset, about 4e-3 at the tutorial's
        scale) starts above the surface and misses the shallow chords by which a ray lit
        by the normal (the gradient of the exact field) runs back into the zone field's
        surface (facts.md F11.4), so the blob's self-shadow came out lit along its edges."""
        reach = dr.square(ds.dist) if squared else ds.dist
        return mi.Ray3f(si.p, ds.d, reach, si.time, si.wavelengths)

    @staticmethod
    def _environment(scene: mi.Scene, d: mi.Vector3f, active: mi.Bool) -> mi.Spectrum:
        """The environment emitter's radiance from direction ``d`` (world)."""
        env = scene.environment()
        if env is None:
            return mi.Spectrum(0.0)
        si = dr.zeros(mi.SurfaceInteraction3f) if dr.is_jit_v(mi.Float) else \
            mi.SurfaceInteraction3f()
        si.wi = -d
        si.t = dr.inf
        return env.eval(si, active)

    @dr.syntax
    def sample(self, scene: mi.Scene, sampler: mi.Sampler, ray: mi.RayDifferential3f,
               medium: mi.Medium = None, active: mi.Bool = True
               ) -> tuple[mi.Spectrum, mi.Bool, list[mi.Float]]:
        strict = self.quirks == "strict"
        draws = self._draws(scene)
        # no shape (an empty tutorial scene): every ray misses; the stand-in BSDF is masked off
        empty = len(scene.shapes()) == 0
        direct = self.scalar or empty          # call the BSDF itself, not through a dispatch
        deltas, generic = self._emitters(scene)
        exact = self._exact_shapes(scene)
        has_exact = len(exact) > 0
        analytic = self._analytic_shapes(scene)
        has_analytic = len(analytic) > 0
        # a scene of spheres (and analytic blobs) is traced here, not through Embree
        spheres = Spheres.of(scene, analytic)
        max_depth = mi.UInt32(0xFFFFFFFF if self.max_depth < 0 else self.max_depth)
        segments = mi.Float(float("inf") if self.max_depth < 0 else self.max_depth - 1)
        ctx = mi.BSDFContext()
        lambert_ctx = mi.BSDFContext()
        lambert_ctx.type_mask = mi.BSDFFlags.DiffuseReflection

        ray = mi.Ray3f(ray)
        L = mi.Spectrum(0.0)
        beta = mi.Spectrum(1.0)
        depth = mi.UInt32(0)
        n1 = mi.Float(1.0)                        # strict: the path's Fresnel index
        prev_si = dr.zeros(mi.Interaction3f)
        prev_pdf = mi.Float(1.0)
        prev_delta = mi.Bool(True)
        origin = mi.UInt32(0)                     # the exact shape the ray leaves (index + 1)
        valid_ray = mi.Bool(scene.environment() is not None)
        active = mi.Bool(active)

        while active:
            if dr.hint(spheres is not None, mode="scalar"):
                si = spheres.intersect(ray, mi.RayFlags.All, active)
            else:
                si = scene.ray_intersect(ray, ray_flags=mi.RayFlags.All,
                                         coherent=(depth == 0), active=active)
            valid_ray |= (depth == 0) & si.is_valid()
            # hits on the exact surface. Rays leave exact points without Mitsuba's spawn
            # offset (about 0.05 at the tutorial's scale of ~500 units; the tutorial offsets
            # nothing), so a crossing within the tutorial's blob epsilon is the surface the
            # ray left (facts.md F4.2: roots count only beyond 0.01): passed through, once here
            # (one more intersection, cheaper than a turn of the loop), then by the loop
            behind = mi.Bool(False)
            on_exact = mi.Bool(False)
            on_analytic = mi.Bool(False)
            from_mesh = si
            if dr.hint(has_exact, mode="scalar"):
                si, behind, which = self._refine(exact, ray, si, active)
                past = self._past(ray, from_mesh)
                si2 = scene.ray_intersect(past, ray_flags=mi.RayFlags.All, coherent=False,
                                          active=behind)
                from_mesh = dr.select(behind, si2, from_mesh)
                si2, behind2, which2 = self._refine(exact, past, si2, behind)
                ray = dr.select(behind, past, ray)
                si = dr.select(behind, si2, si)
                which = dr.select(behind, which2, which)
                behind &= behind2
                # a ray that left an exact point into the surface can run between the
                # inscribed mesh and the surface (a grazing chord): where it comes out, the
                # mesh has no hit (the ray escapes) or one the surface is not near (Newton
                # left it unmoved); the exact surface gives the exit
                unmoved = (which > 0) & (si.t == from_mesh.t)
                for k, shape in enumerate(exact):
                    limit = dr.select(unmoved & (which == k + 1), dr.inf, si.t)
                    si, out = shape.exit_hit(ray, si, limit, active & (origin == k + 1))
                    which = dr.select(out, k + 1, which)
                    unmoved &= _not(out)
                    behind &= _not(out)
                on_exact = which > 0
            if dr.hint(has_analytic, mode="scalar"):
                si, on_analytic = self._analytic(analytic, ray, si, active, strict)
                on_exact |= on_analytic
                behind &= _not(on_analytic)
                if dr.hint(has_exact, mode="scalar"):
                    which = dr.select(on_analytic, 0, which)
                    unmoved &= _not(on_analytic)
            active &= _not(behind)

            # Emission seen by this ray: the environment on escape, an area light on a hit
            emitter = si.emitter(scene)
            mis = mi.Float(1.0)
            if dr.hint(generic, mode="scalar"):
                ds_hit = mi.DirectionSample3f(scene, si, prev_si)
                if dr.hint(self.scalar, mode="scalar"):
                    # a scalar call dereferences the emitter: none on a miss without an
                    # environment, or on a surface that emits nothing
                    em_pdf = mi.Float(0.0) if emitter is None or prev_delta else \
                        scene.pdf_emitter_direction(prev_si, ds_hit, True)
                else:
                    em_pdf = scene.pdf_emitter_direction(prev_si, ds_hit, _not(prev_delta))
                mis = dr.select(prev_delta, 1.0, _mis_weight(prev_pdf, em_pdf))
            if dr.hint(self.scalar, mode="scalar"):
                if emitter is not None:
                    L += beta * mis * emitter.eval(si, active)
            else:
                L += beta * mis * emitter.eval(si, active)

            active_next = active & si.is_valid() & (depth + 1 < max_depth)
            if empty:
                bsdf = self.stand_in
            elif dr.hint(self.scalar, mode="scalar"):
                bsdf = si.bsdf(ray) if si.is_valid() else self.stand_in
            else:
                bsdf = si.bsdf(ray)
            d = mi.Vector3f(ray.d)

            if dr.hint(strict, mode="scalar"):
                page = bsdf.eval_attribute_1("tutorial_page", si, active_next)
                textured = bsdf.eval_attribute_1("tutorial_textured", si, active_next) > 0
                inside = bsdf.eval_attribute_1("tutorial_inside", si, active_next) > 0
                density = bsdf.eval_attribute_1("tutorial_density", si, active_next)
                refraction = bsdf.eval_attribute_1("tutorial_refraction", si, active_next)
                events = bsdf.eval_attribute_1("tutorial_events", si, active_next)
                squared = page >= 2
                # the carried index against the side's: n1 == n2 gives R = 0, unbent
                n2 = dr.select(inside, 1.0, density)
                n1_side = dr.select(inside, density, 1.0)
                unbent = (page == 4) & (density != 0) & (n1 != n1_side) & (n1 == n2)
                total = dr.select(unbent, refraction, events)
                clean_diffuse = 1.0 - events
                lit_scale = dr.select(unbent, dr.select(clean_diffuse != 0, (1.0 - refraction)
                                                        / dr.select(clean_diffuse != 0,
                                                                    clean_diffuse, 1.0), 0.0),
                                      1.0)

            # Other light sources, as `path` samples them (never in strict mode)
            if dr.hint(generic, mode="scalar"):
                active_em = active_next & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
                ds, em_weight = scene.sample_emitter_direction(si, sampler.next_2d(), True,
                                                               active_em)
                active_em &= (ds.pdf != 0) & _not(ds.delta)
                wo = si.to_local(ds.d)
                value, value_pdf = bsdf.eval_pdf(ctx, si, wo, active_em)
                L += dr.select(active_em, beta * _mis_weight(ds.pdf, value_pdf) * value
                               * em_weight, 0.0)

            # Every delta light's direction, then ONE call of the BSDF: its value towards each
            # light and its own continuation (the tutorial material's roulette)
            samples = [light.sample_direction(si, mi.Point2f(0.5), active_next)
                       for light in deltas]
            wos = [si.to_local(sample[0].d) for sample in samples]
            u = sampler.next_1d()
            u2 = sampler.next_2d()
            if dr.hint(direct, mode="scalar"):
                values, bs, weight = _eval_sample(bsdf, ctx, si, wos, u, u2, active_next)
            else:
                values, bs, weight = dr.dispatch(bsdf, _eval_sample, ctx, si, wos, u, u2,
                                                 active=active_next)

            # draw_diffuse: the lights at full weight where the draw u picked "diffuse" (the
            # BSDF's continuation ended there: u >= Rf + Tr in front), none elsewhere
            draw_scale = mi.Float(1.0)
            if dr.hint(draws, mode="scalar"):
                if dr.hint(strict, mode="scalar"):
                    chosen = total
                else:
                    chosen = bsdf.eval_attribute_1("tutorial_events", si, active_next)
                p_diffuse = 1.0 - chosen
                draw_scale = dr.select((u >= chosen) & (p_diffuse > 0),
                                       1.0 / dr.select(p_diffuse > 0, p_diffuse, 1.0), 0.0)

            # each delta light with its own shadow ray where the BSDF is lit
            for k in range(len(deltas)):
                ds, em_weight = samples[k]
                wo = wos[k]
                value = values[k]
                if dr.hint(strict, mode="scalar"):
                    lambert = bsdf.eval(lambert_ctx, si, wo, active_next & textured)
                    value = (value + dr.select(textured, (beta - 1.0) * lambert, 0.0)) \
                        * lit_scale
                if dr.hint(draws, mode="scalar"):
                    value = value * draw_scale
                lit = active_next & (dr.max(dr.abs(value * em_weight)) > 0)
                exact_lanes = on_exact if has_exact or has_analytic else None

                def occluded(lit, si=si, ds=ds, exact_lanes=exact_lanes,
                             on_analytic=on_analytic):
                    shadow = self._shadow(si, ds, False, exact_lanes)
                    if dr.hint(strict, mode="scalar"):
                        shadow = dr.select(squared, self._shadow(si, ds, True, exact_lanes),
                                           shadow)
                    if dr.hint(spheres is not None, mode="scalar"):
                        blocked = spheres.test(shadow, lit)
                    else:
                        blocked = scene.ray_test(shadow, lit)
                    if dr.hint(has_analytic, mode="scalar"):
                        # from a point of an analytic blob, as the tutorial: no offset
                        surface = self._shadow_from_surface(si, ds, False)
                        if dr.hint(strict, mode="scalar"):
                            surface = dr.select(squared, self._shadow_from_surface(si, ds, True),
                                                surface)
                        blocked |= self._occluded(analytic,
                                                  dr.select(on_analytic, surface, shadow),
                                                  lit & _not(blocked), strict)
                    return blocked

                # traced in a branch that a packet with no lit lane skips (the glass, the
                # mirror, the sky): on page 4 1.2x the speed of the unbranched test 8 wide
                if dr.hint(self.scalar, mode="scalar"):
                    blocked = occluded(lit)
                else:
                    blocked = dr.if_stmt((lit,), lit, occluded, lambda lit: mi.Bool(True),
                                         label="tutorialpath.shadow")
                L += dr.select(lit & _not(blocked), beta * value * em_weight, 0.0)

            # The BSDF's own continuation (the tutorial material's roulette)
            wo_world = si.to_world(bs.wo)
            step = mi.Float(1.0)
            if dr.hint(strict, mode="scalar"):
                # inside: failed 'diffuse' draws before a reflect/refract, each one segment
                p_fail = 1.0 - dr.minimum(total, 1.0)
                v = sampler.next_1d()
                fails = dr.select(p_fail <= 0, 0.0, dr.select(
                    p_fail >= 1, dr.inf,
                    dr.floor(dr.log(1.0 - v) / dr.log(dr.select((p_fail > 0) & (p_fail < 1),
                                                                p_fail, 0.5)))))
                retrace = active_next & (page == 4) & inside
                stuck = retrace & (mi.Float(depth) + fails >= segments)
                L += dr.select(stuck, beta * self._environment(scene, d, stuck), 0.0)
                step = dr.select(retrace, 1.0 + fails, 1.0)
                refracted = mi.has_flag(bs.sampled_type, mi.BSDFFlags.DeltaTransmission)
                # unbent lanes: R = 0, so refraction (weight Refraction, direction d) with
                # probability Refraction in front; inside it is the only event left
                unbent_go = unbent & (inside | (u < refraction))
                weight = dr.select(unbent, dr.select(unbent_go, mi.Spectrum(refraction), 0.0),
                                   weight)
                wo_world = dr.select(unbent, d, wo_world)
                n1 = dr.select(_not(unbent) & refracted & active_next & (dr.max(weight) > 0), n2, n1)
                weight = dr.select(stuck, 0.0, weight)

            beta = dr.select(behind, beta, beta * weight)
            active_next &= dr.max(dr.abs(beta)) != 0
            if dr.hint(generic, mode="scalar"):
                # only the MIS of sampled emitters reads them (else loop-invariant: not carried)
                prev_si = mi.Interaction3f(si)
                prev_pdf = bs.pdf
                prev_delta = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)
            if dr.hint(has_exact or has_analytic, mode="scalar"):
                # exact points are left without an offset
                leave = dr.select(on_exact, mi.Ray3f(si.p, wo_world, si.time, si.wavelengths),
                                  self._leave(si, wo_world))
            if dr.hint(has_exact, mode="scalar"):
                # past the mesh along the ray itself (the line is kept), or from the hit
                ray = dr.select(behind, self._past(ray, from_mesh), leave)
                # past the mesh the ray keeps its line, so its chord's origin; a mesh hit
                # Newton left unmoved is no point of the surface to start a chord from
                origin = dr.select(behind, origin, dr.select(unmoved, 0, which))
            elif dr.hint(has_analytic, mode="scalar"):
                ray = leave
            else:
                ray = self._leave(si, wo_world)

            if dr.hint(strict, mode="scalar"):
                # the segment limit: the cube map along the next direction, not traced
                at_limit = active_next & (mi.Float(depth) + step >= segments)
                L += dr.select(at_limit, beta * self._environment(scene, wo_world, at_limit),
                               0.0)
                active_next &= _not(at_limit)
                depth = dr.select(behind, depth,
                                  mi.UInt32(dr.minimum(mi.Float(depth) + step, 4.0e9)))
            else:
                depth = dr.select(behind, depth, depth + 1)
            active = active_next | behind

        return L, valid_ray, []

    def aov_names(self) -> list[str]:
        return []

    def traverse(self, callback: mi.TraversalCallback) -> None:
        # as Mitsuba values that mi.traverse can write (a Python int or float it cannot)
        nd = mi.ParamFlags.NonDifferentiable
        callback.put("max_depth", exposed(self, "max_depth"), nd)
        callback.put("min_distance", exposed(self, "min_distance"), nd)

    def parameters_changed(self, keys: list[str]) -> None:
        if not keys or "max_depth" in keys:
            take_int(self, "tutorialpath", "max_depth", -1, 2 ** 31 - 1)
        if not keys or "min_distance" in keys:
            take_float(self, "tutorialpath", "min_distance", lo=0.0)

    def to_string(self) -> str:
        return (f"TutorialIntegrator[\n  max_depth = {self.max_depth},\n  exact_hits = "
                f"{self.exact_hits},\n  min_distance = {self.min_distance},\n  quirks = {self.quirks},"
                f"\n  draw_diffuse = {self.draw_diffuse}\n]")


mi.register_integrator("tutorialpath", lambda props, cls=TutorialIntegrator: cls(props))
