from __future__ import annotations  # Delayed parsing of type annotations

import drjit as dr
import mitsuba as mi

from ..exposed import exposed, kernel_value, take_float
from ..masks import logical_not as _not
from ..params import FLOAT32_MIN_NORMAL, read_float, read_texture

PAGES = (1, 2, 4)


class TutorialBSDF(mi.BSDF):
    r"""
    .. _bsdf-tutorial:

    The Codermind tutorial's material (:monosp:`tutorial`)
    ------------------------------------------------------

    .. pluginparameters::

     * - diffuse
       - |spectrum| or |texture|
       - The tutorial's ``Diffuse`` colour; a nested :monosp:`turbulence` or
         :monosp:`marble` texture gives the tutorial's procedural materials (Default: 0)

     * - specular
       - |spectrum| or |texture|
       - ``Specular`` colour of the Blinn term (Default: 0)

     * - power
       - |float|
       - ``Power``, the Blinn exponent, >= 0 (Default: 0)

     * - reflection
       - |float|
       - ``Reflection`` coefficient in [0, 1] (Default: 0)

     * - refraction
       - |float|
       - ``Refraction`` coefficient in [0, 1]; page 4 only (Default: 0)

     * - density
       - |float|
       - ``Density``, the index of refraction, >= 0; 0 means metal (no Fresnel); page 4
         only (Default: 0)

     * - page
       - |int|
       - Which tutorial program's transport the material follows: 1 or 2 (mirror model)
         or 4 (Fresnel roulette) (Default: 4). Page 1 is page 2 with ``specular`` 0.

    ``mi.traverse`` exposes ``diffuse``, ``specular``, ``power``, ``reflection``,
    ``refraction`` and ``density`` (page 4 only for the last two), all differentiable
    (``power`` not at 0, where the lobe switches to a constant; ``density`` not at 0, the
    metal, nor where ``reflection`` = ``refraction`` = 0). The weights and the density set
    the lighting factor :math:`1 - R_f - T_r` of ``eval`` and both the weight and the
    probability of the sampled mirror and refraction events; the roulette's choice has no
    derivative, so ``sample`` returns the weight times :math:`p / \mathrm{detach}(p)` for
    the event's probability :math:`p` (value unchanged; its derivative, averaged over the
    roulette, is that of the expected weight :math:`\sum p\,w`), and the refracted
    direction follows ``density``. Checked against finite differences of the expectation
    (tests/plugins/test_gradients.py). An integrator sees these derivatives if it differentiates
    ``sample``'s weight (Dr.Jit AD through :monosp:`path` with evaluated loops does);
    :monosp:`prb` takes the derivatives of the indirect light from ``eval`` at the sampled
    direction instead, which for a delta event here is the lighting term, not the event.

    The material of the Codermind ray-tracing tutorial, written so that Mitsuba's
    built-in :monosp:`path` integrator computes exactly the tutorial's light transport
    (in expectation) with the tutorial's point lights (:monosp:`tutorialpoint`, no
    falloff). :monosp:`path` does, at every vertex, light sampling with ``eval`` and then
    continues with ``sample``; the contract is:

    **Lighting** (``eval``, the only smooth part, reached only through emitter sampling;
    ``pdf`` is 0 everywhere, so the MIS weight of light samples is 1 and the smooth part
    is never sampled). With :math:`\omega_o` towards the light, :math:`h` the half vector
    of :math:`\omega_i` and :math:`\omega_o` in the shading frame, and the tutorial's
    unnormalized formula (the Blinn term is NOT multiplied by the cosine; the light's
    intensity :math:`I` multiplies the result):

    .. math::

        L = \mathtt{diffuse}\,\cos\theta_o + \mathtt{specular}\,\max(h_z, 0)^{\mathtt{power}}
        \quad\text{if } \cos\theta_o > 0, \text{ else } 0.

    - pages 1 and 2: ``eval`` = :math:`L` (the tutorial lights every hit with the
      unflipped normal, also when seen from behind);
    - page 4: ``eval`` = :math:`(1 - R_f - T_r)\,L` when :math:`\omega_i` is in front of
      ``si.n``, 0 behind it (the tutorial's "inside" hit adds no light). ``si.n`` is the
      geometric normal, or under :monosp:`noisebump` the unbumped shading normal (the
      tutorial's side test); on a blob mesh without a bump the geometric normal decides,
      which differs from the tutorial near creases and necks (wrap the BSDF in
      :monosp:`noisebump` with ``bumplevel`` 0 to get the tutorial's side there).

    **Continuation** (``sample``, delta events only; weights are the tutorial's
    multipliers of its path coefficient, NOT divided by the event probability;
    ``bs.pdf`` is the event probability, ``bs.eta`` = 1 so that :monosp:`path`'s
    Russian roulette is not biased towards refraction; there is no
    :math:`\eta^2` radiance scaling):

    - pages 1 and 2: if ``reflection`` > 0 the mirror direction with weight
      ``reflection`` (probability 1), else an invalid sample (weight 0) that ends the path;
    - page 4 (facts.md F8): with :math:`\cos\theta_i = |\omega_i \cdot n|` for the facing
      (possibly bumped) normal, :math:`n_1 = 1, n_2 = \mathtt{density}` in front of
      ``si.n`` and :math:`n_1 = \mathtt{density}, n_2 = 1` behind it: Fresnel
      :math:`R` (:math:`((n_1 - n_2)/(n_1 + n_2))^2` and :math:`\cos\theta_t = 1` for
      :math:`\cos\theta_i \ge 0.999`; :math:`R = 1` for :math:`\sin^2\theta_t > 0.9999`,
      total internal reflection; else the mean of the s and p reflectances); density 0
      (or reflection = refraction = 0) is a metal, :math:`R = 1`. Then
      :math:`R_f = \mathtt{reflection}\,R` and :math:`T_r = \mathtt{refraction}\,(1 - R)`.
      In front: reflect with probability :math:`R_f` (weight ``reflection``), refract
      with probability :math:`T_r` (weight ``refraction``, direction
      :math:`(n_1/n_2)(d + \cos\theta_i\,n) - \cos\theta_t\,n`, normalized), otherwise an
      invalid sample that ends the path: the tutorial's "diffuse" event, whose lighting
      ``eval`` already carries with weight :math:`1 - R_f - T_r`; so there is no indirect
      diffuse light. Behind (inside an object) the tutorial re-draws "diffuse" events;
      this plugin uses the clean limit: reflect with probability
      :math:`R_f/(R_f + T_r)`, refract with :math:`T_r/(R_f + T_r)`, same weights, and
      ends the path if :math:`R_f + T_r = 0`.

    The expected value of one :monosp:`path` sample then equals the tutorial's
    (clean) roulette exactly. Mirror and refraction samples are delta
    (``DeltaReflection``, ``DeltaTransmission``), so emission found along them (an
    environment map, area lights) gets MIS weight 1, as the tutorial's cube-map lookup
    on a miss. The smooth components (``DiffuseReflection``, ``GlossyReflection``)
    exist so that :monosp:`path` performs light sampling.

    For the tutorial's transport use :monosp:`path` with ``max_depth`` = 11 (the
    tutorial's 10 segments) and ``rr_depth`` >= ``max_depth`` (Russian roulette is
    unbiased but adds noise, and the tutorial has none). Not reproduced (clean model):
    the tutorial applies its path coefficient twice to turbulence and marble lighting
    (facts.md F7); its inside re-draws count against the 10-segment limit; it adds the cube
    map along the next direction when the segment limit is reached; it carries the Fresnel
    index :math:`n_1` along the path (a BSDF sees one hit: here :math:`n_1` follows the
    side, ``density`` behind ``si.n``, 1 in front; they differ only where the side test
    disagrees with the path's history, as on a few spots of the page-4 blob).

    .. tabs::

        .. code-tab:: xml

            <bsdf type="tutorial">
                <texture type="turbulence" name="diffuse">
                    <rgb name="color0" value="0.35, 0.25, 0.01"/>
                    <rgb name="color1" value="0.5, 0.5, 0.01"/>
                </texture>
                <rgb name="specular" value="1.2"/>
                <float name="power" value="60"/>
                <float name="density" value="1"/>
            </bsdf>
    """

    plugin = "tutorial"

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        name = self.plugin
        page = props.get("page", 4)
        if isinstance(page, bool) or not isinstance(page, int) or page not in PAGES:
            raise ValueError(f"{name}: 'page' must be 1, 2 or 4 (page 3's program is not "
                             f"known; page 4 contains its features), got {page!r}")
        self.page = page
        if page != 4:
            for key in ("refraction", "density"):
                if key in props:
                    raise ValueError(f"{name}: '{key}' exists only with page 4 "
                                     f"(this material has page {page})")
        # The tutorial's colours are plain multipliers: values above 1 are allowed (its
        # page-4 scene has Specular 1.2); negative only where a texture extrapolates.
        self.diffuse = read_texture(props, name, "diffuse", 0.0, unbounded=True)
        self.specular = read_texture(props, name, "specular", 0.0, unbounded=True)
        self.power = read_float(props, name, "power", 0.0, lo=0.0)
        self.reflection = read_float(props, name, "reflection", 0.0, lo=0.0, hi=1.0)
        self.refraction = read_float(props, name, "refraction", 0.0, lo=0.0, hi=1.0) \
            if page == 4 else 0.0
        self.density = read_float(props, name, "density", 0.0, lo=0.0) if page == 4 else 0.0
        if 0.0 < self.density < FLOAT32_MIN_NORMAL:
            raise ValueError(f"{name}: 'density' must be 0 (a metal) or at least "
                             f"{FLOAT32_MIN_NORMAL:.3g} (float32), got {self.density:g}")
        self.metal = self.density == 0 or (self.reflection == 0 and self.refraction == 0)

        both = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
        lit_side = both if page != 4 else mi.BSDFFlags.FrontSide
        self.m_components = [mi.BSDFFlags.DiffuseReflection | lit_side,
                             mi.BSDFFlags.GlossyReflection | lit_side,
                             mi.BSDFFlags.DeltaReflection | both]
        if page == 4:
            self.m_components.append(mi.BSDFFlags.DeltaTransmission | mi.BSDFFlags.NonSymmetric
                                     | both)
        flags = self.m_components[0]
        for f in self.m_components[1:]:
            flags = flags | f
        self.m_flags = flags

    # -- the tutorial's formulas ----------------------------------------------------------
    @staticmethod
    def _inside(si: mi.SurfaceInteraction3f) -> mi.Bool:
        """wi behind ``si.n``: the tutorial's "inside" hit (decided before bumping). Standalone
        ``si.n`` is the geometric normal; under :monosp:`noisebump` it is the unbumped
        shading normal, which is what the tutorial tests (they differ on a blob mesh)."""
        return dr.dot(si.n, si.sh_frame.to_world(si.wi)) < 0

    def _fresnel(self, cos_i: mi.Float, inside: mi.Bool):
        """facts.md F8, step 1-2: reflectance R, cos_t and n1/n2."""
        if self.metal:
            return mi.Float(1.0), mi.Float(1.0), mi.Float(1.0)
        density = kernel_value(self, "density")
        n1 = dr.select(inside, density, 1.0)
        n2 = dr.select(inside, 1.0, density)
        eta = n1 / n2
        sin2_t = dr.square(eta) * dr.maximum(1.0 - dr.square(cos_i), 0.0)
        normal = cos_i >= 0.999
        tir = sin2_t > 0.9999                   # (only where not 'normal')
        cos_t = dr.select(normal, 1.0, dr.select(tir, 0.0, dr.safe_sqrt(1.0 - sin2_t)))
        # Both denominators are 0 only at tangent incidence under TIR (cos_i = cos_t = 0),
        # where R = 1 is selected below; guarded because scalar variants raise on 0 / 0.
        den_s, den_p = n1 * cos_i + n2 * cos_t, n2 * cos_i + n1 * cos_t
        rs = (n1 * cos_i - n2 * cos_t) / dr.select(den_s > 0, den_s, 1.0)
        rp = (n2 * cos_i - n1 * cos_t) / dr.select(den_p > 0, den_p, 1.0)
        r0 = dr.square((n1 - n2) / (n1 + n2))
        r = dr.select(normal, r0, dr.select(tir, 1.0, 0.5 * (dr.square(rs) + dr.square(rp))))
        return r, cos_t, eta

    def _events(self, si: mi.SurfaceInteraction3f):
        """Page 4: inside flag, Rf, Tr, cos_i, cos_t, n1/n2."""
        inside = self._inside(si)
        cos_i = dr.abs(mi.Frame3f.cos_theta(si.wi))
        r, cos_t, eta = self._fresnel(cos_i, inside)
        return (inside, kernel_value(self, "reflection") * r,
                kernel_value(self, "refraction") * (1.0 - r), cos_i, cos_t, eta)

    def _colours(self, ctx, si, active):
        """The ``diffuse`` and ``specular`` colours at the hit (None where ``ctx`` disables
        the lobe): evaluated once per hit, shared by every light."""
        diffuse = self.diffuse.eval(si, active) \
            if ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 0) else None
        specular = self.specular.eval(si, active) \
            if ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1) else None
        return diffuse, specular

    def _lighting(self, ctx, si, wo, active, colours=None) -> mi.Spectrum:
        """Lambert + unnormalized Blinn for a light in direction wo (cos_o > 0)."""
        diffuse, specular = self._colours(ctx, si, active) if colours is None else colours
        cos_o = mi.Frame3f.cos_theta(wo)
        value = mi.Spectrum(0.0)
        if diffuse is not None:
            value += diffuse * cos_o
        if specular is not None:
            h = si.wi + wo
            len2 = dr.squared_norm(h)
            cos_h = dr.maximum(h.z * dr.rsqrt(dr.select(len2 > 0, len2, 1.0)), 0.0)
            blinn = mi.Float(1.0) if self.power == 0 else dr.power(cos_h, self._power())
            value += specular * dr.select(len2 > 0, blinn, 0.0)
        return value & (active & (cos_o > 0))

    # -- mi.BSDF interface ----------------------------------------------------------------
    def eval(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
             active: mi.Bool = True) -> mi.Spectrum:
        if self.page != 4:
            return self._lighting(ctx, si, wo, active)
        inside, rf, tr, *_ = self._events(si)
        active = active & _not(inside)
        return self._lighting(ctx, si, wo, active) * (1.0 - rf - tr)

    def pdf(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
            active: mi.Bool = True) -> mi.Float:
        return mi.Float(0.0)

    def eval_pdf(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
                 active: mi.Bool = True) -> tuple[mi.Spectrum, mi.Float]:
        return self.eval(ctx, si, wo, active), mi.Float(0.0)

    def sample(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, sample1: mi.Float,
               sample2: mi.Point2f, active: mi.Bool = True) -> tuple[mi.BSDFSample3f, mi.Spectrum]:
        return self._sample(ctx, si, sample1, active,
                            self._events(si) if self.page == 4 else None)

    def eval_sample(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f,
                    wos: list[mi.Vector3f], sample1: mi.Float, sample2: mi.Point2f,
                    active: mi.Bool = True
                    ) -> tuple[list[mi.Spectrum], mi.BSDFSample3f, mi.Spectrum]:
        """``[eval(wo) for wo in wos]`` and ``sample`` in one call (what the
        :monosp:`tutorialpath` integrator needs at a hit): the Fresnel terms and the
        colours (a procedural texture) are computed once, not once per light."""
        events = self._events(si) if self.page == 4 else None
        lit = active if self.page != 4 else active & _not(events[0])
        colours = self._colours(ctx, si, lit)
        scale = 1.0 if self.page != 4 else 1.0 - events[1] - events[2]
        values = [self._lighting(ctx, si, wo, lit, colours) * scale for wo in wos]
        return (values,) + self._sample(ctx, si, sample1, active, events)

    def _sample(self, ctx, si, sample1, active, events):
        """``sample`` from the page-4 ``events`` (see :meth:`_events`; None on pages 1-2)."""
        wi = si.wi
        bs = dr.zeros(mi.BSDFSample3f)
        bs.eta = 1.0
        mirror = mi.Vector3f(-wi.x, -wi.y, wi.z)
        can_reflect = ctx.is_enabled(mi.BSDFFlags.DeltaReflection, 2)
        if self.page != 4:
            ok = active & (self.reflection > 0 and can_reflect)
            bs.wo = mirror
            bs.pdf = dr.select(ok, 1.0, 0.0)
            bs.sampled_type = mi.UInt32(int(mi.BSDFFlags.DeltaReflection))
            bs.sampled_component = mi.UInt32(2)
            return bs, mi.Spectrum(kernel_value(self, "reflection")) & ok

        inside, rf, tr, cos_i, cos_t, eta = events
        if not can_reflect:
            rf = mi.Float(0.0)
        if not ctx.is_enabled(mi.BSDFFlags.DeltaTransmission, 3):
            tr = mi.Float(0.0)
        total = rf + tr
        # In front: u < Rf reflects, u < Rf + Tr refracts, else the path ends.
        # Inside: the same thresholds on u * (Rf + Tr), so one of the two always happens.
        scale = dr.select(inside, total, 1.0)
        u = sample1 * scale
        reflect = u < rf
        refract = _not(reflect) & (u < total)
        ok = active & (reflect | refract) & (total > 0)

        # Snell with the facing normal f = (0, 0, +-1): (n1/n2)(d + cos_i f) - cos_t f, d = -wi
        f = dr.select(inside, -1.0, 1.0)
        refracted = dr.normalize(mi.Vector3f(-eta * wi.x, -eta * wi.y,
                                             eta * dr.fma(cos_i, f, -wi.z) - cos_t * f))
        # the refracted direction only where refraction happens (under TIR with a huge
        # density it overflows to NaN; an invalid sample gets the finite mirror direction)
        bs.wo = dr.select(refract, refracted, mirror)
        prob = dr.select(ok, dr.select(reflect, rf, tr) / dr.select(ok, scale, 1.0), 0.0)
        bs.pdf = dr.detach(prob)
        bs.sampled_type = dr.select(reflect, mi.UInt32(int(mi.BSDFFlags.DeltaReflection)),
                                    mi.UInt32(int(mi.BSDFFlags.DeltaTransmission)))
        bs.sampled_component = dr.select(reflect, mi.UInt32(2), mi.UInt32(3))
        weight = dr.select(reflect, kernel_value(self, "reflection"),
                           kernel_value(self, "refraction"))
        # The event's probability depends on the parameters too: weight / 1 = weight *
        # prob / detach(prob) has the same value, and its derivative (in expectation over
        # the roulette) is that of the expected weight, sum_events prob * weight (the
        # standard estimator of a derivative through a discrete choice, unbiased).
        weight = weight * (prob / dr.select(ok, dr.detach(prob), 1.0))
        return bs, mi.Spectrum(weight) & ok

    #: Per-hit quantities the ``tutorial`` integrator's strict mode reads through
    #: ``eval_attribute_1`` (the path state a one-hit BSDF cannot keep, facts.md F7-F8).
    ATTRIBUTES = ("tutorial_page", "tutorial_textured", "tutorial_inside", "tutorial_density",
                  "tutorial_refraction", "tutorial_events")

    def has_attribute(self, name: str, active: mi.Bool = True) -> bool:
        return name in self.ATTRIBUTES

    def eval_attribute_1(self, name: str, si: mi.SurfaceInteraction3f,
                         active: mi.Bool = True) -> mi.Float:
        """``tutorial_page``: 1, 2 or 4; ``tutorial_textured``: 1 where ``diffuse`` varies
        over space (turbulence, marble); ``tutorial_inside``: 1 on the tutorial's "inside"
        side; ``tutorial_density``, ``tutorial_refraction``: the parameters;
        ``tutorial_events``: Rf + Tr with this BSDF's (side-based) Fresnel (0 on pages 1-2)."""
        zero = dr.zeros(mi.Float, dr.width(si.p.x)) if dr.is_jit_v(mi.Float) else mi.Float(0.0)
        if name == "tutorial_page":
            return zero + float(self.page)
        if name == "tutorial_textured":
            return zero + (1.0 if self.diffuse.is_spatially_varying() else 0.0)
        if name == "tutorial_density":
            return zero + self.density
        if name == "tutorial_refraction":
            return zero + self.refraction
        if name == "tutorial_inside":
            return dr.select(self._inside(si), 1.0, 0.0) + zero if self.page == 4 else zero
        if name == "tutorial_events":
            if self.page != 4:
                return zero
            _, rf, tr, *_ = self._events(si)
            return rf + tr + zero
        raise ValueError(f"{self.plugin}: no attribute {name!r}")

    def eval_diffuse_reflectance(self, si: mi.SurfaceInteraction3f,
                                 active: mi.Bool = True) -> mi.Spectrum:
        return self.diffuse.eval(si, active)

    def _power(self):
        """The Blinn exponent for the kernels: the traversed ``mi.Float`` (gradients
        included) once ``mi.traverse`` has exposed it, else the float."""
        return kernel_value(self, "power")

    def _scalar_names(self) -> tuple[str, ...]:
        return ("power", "reflection", "refraction", "density") if self.page == 4 else \
            ("power", "reflection")

    def traverse(self, callback: mi.TraversalCallback) -> None:
        callback.put("diffuse", self.diffuse, mi.ParamFlags.Differentiable)
        callback.put("specular", self.specular, mi.ParamFlags.Differentiable)
        # all differentiable: the kernels use the traversed mi.Float (kernel_value); the
        # Python tests (power == 0, the metal case) stay on the floats
        for name in self._scalar_names():
            callback.put(name, exposed(self, name), mi.ParamFlags.Differentiable)

    def parameters_changed(self, keys: list[str]) -> None:
        name = self.plugin
        limits = {"power": (0.0, None), "reflection": (0.0, 1.0), "refraction": (0.0, 1.0),
                  "density": (0.0, None)}
        for key in self._scalar_names():
            if not keys or key in keys:
                take_float(self, name, key, *limits[key])
        if 0.0 < self.density < FLOAT32_MIN_NORMAL:
            raise ValueError(f"{name}: 'density' must be 0 (a metal) or at least "
                             f"{FLOAT32_MIN_NORMAL:.3g} (float32), got {self.density:g}")
        self.metal = self.density == 0 or (self.reflection == 0 and self.refraction == 0)

    def to_string(self) -> str:
        extra = (f",\n  refraction = {self.refraction},\n  density = {self.density}"
                 if self.page == 4 else "")
        return (f"TutorialBSDF[\n  page = {self.page},\n  diffuse = {self.diffuse},\n"
                f"  specular = {self.specular},\n  power = {self.power},\n"
                f"  reflection = {self.reflection}{extra}\n]")


mi.register_bsdf("tutorial", lambda props, cls=TutorialBSDF: cls(props))
