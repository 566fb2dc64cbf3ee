from __future__ import annotations  # Delayed parsing of type annotations

import drjit as dr
import mitsuba as mi

from ..params import read_float, read_texture, uniform_rgb


class BlinnPhongBSDF(mi.BSDF):
    r"""
    .. _bsdf-blinnphong:

    Energy-conserving Blinn-Phong (:monosp:`blinnphong`)
    ----------------------------------------------------

    .. pluginparameters::

     * - diffuse_reflectance
       - |spectrum| or |texture|
       - Lambertian albedo :math:`k_d` (Default: 0.5)
       - |exposed|, |differentiable|

     * - specular_reflectance
       - |spectrum| or |texture|
       - Scale :math:`k_s` of the Blinn-Phong lobe: its albedo at normal incidence in the
         limit of a large exponent (Default: 0.2)
       - |exposed|, |differentiable|

     * - exponent
       - |float|
       - Blinn-Phong exponent :math:`n \ge 0` of :math:`\cos^n\theta_h` (Default: 30)
       - |exposed|

    A physically based Lambert plus Blinn-Phong material for any integrator:

    .. math::

        f(\omega_i, \omega_o) = \frac{k_d}{\pi}
            + k_s\,\frac{D(\omega_h)}{4\,(\omega_i\cdot\omega_h)\,
                        \max(\cos\theta_i, \cos\theta_o)},
        \qquad D(\omega_h) = \frac{n + 1}{2\pi}\cos^n\theta_h,

    with :math:`\omega_h` the half vector. :math:`D` is the Blinn-Phong lobe normalized
    as a density of half vectors (:math:`\int D\,d\omega_h = 1`), and the denominator is
    the Ashikhmin-Shirley normalization. This choice (rather than the usual
    :math:`(n+8)/(8\pi)` factor, which is an approximation and exceeds albedo 1 for
    :math:`n \gtrsim 5` at normal incidence) makes the lobe

    - energy conserving for every exponent and angle: its albedo is
      :math:`k_s \int p(\omega_o)\,\min(1, \cos\theta_o/\cos\theta_i)\,d\omega_o \le k_s`,
      where :math:`p` is the density of the half-vector sampling below; it tends to
      :math:`k_s` for large exponents away from grazing angles;
    - reciprocal (symmetric in :math:`\omega_i, \omega_o`);
    - exactly importance sampled: half vectors are drawn from :math:`D`
      (:math:`\cos\theta_h = u^{1/(n+1)}`), so the sample weight of the lobe is
      :math:`k_s \cos\theta_o / \max(\cos\theta_i, \cos\theta_o) \le k_s`.

    The total albedo is at most :math:`k_d + k_s`: uniform (non-textured) values with
    :math:`k_d + k_s > 1` in some channel are rejected; with textures keep the sum
    :math:`\le 1` yourself. The lobe is chosen with probability
    :math:`\bar k_s / (\bar k_d + \bar k_s)` (channel means at the shading point),
    otherwise a cosine-weighted diffuse direction; :monosp:`pdf` is the mixture density.

    The material is one-sided, as Mitsuba's :monosp:`diffuse`: it is black when seen
    from the back of the shading normal and reflects nothing below it (wrap it in
    :monosp:`twosided` for a two-sided surface).

    .. tabs::

        .. code-tab:: xml

            <bsdf type="blinnphong">
                <rgb name="diffuse_reflectance" value="0.4, 0.2, 0.1"/>
                <rgb name="specular_reflectance" value="0.3"/>
                <float name="exponent" value="200"/>
            </bsdf>
    """

    plugin = "blinnphong"

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        name = self.plugin
        self.diffuse = read_texture(props, name, "diffuse_reflectance", 0.5)
        self.specular = read_texture(props, name, "specular_reflectance", 0.2)
        self.exponent = mi.Float(read_float(props, name, "exponent", 30.0, lo=0.0, hi=1e6))
        kd, ks = uniform_rgb(self.diffuse), uniform_rgb(self.specular)
        if kd is not None and ks is not None and max(d + s for d, s in zip(kd, ks)) > 1 + 1e-6:
            raise ValueError(
                f"{name}: 'diffuse_reflectance' + 'specular_reflectance' must be <= 1 in every "
                f"channel (energy conservation), got {kd} + {ks}")
        diffuse = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
        glossy = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
        self.m_components = [diffuse, glossy]
        self.m_flags = diffuse | glossy
        dr.make_opaque(self.exponent)

    # -- helpers --------------------------------------------------------------------------
    def _lobe_prob(self, ctx: mi.BSDFContext, kd: mi.Spectrum, ks: mi.Spectrum):
        """Probability of sampling the glossy lobe; flags of the enabled lobes."""
        has_d = ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 0)
        has_s = ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1)
        wd = dr.maximum(dr.mean(kd, axis=0), 0.0) if has_d else mi.Float(0.0)
        ws = dr.maximum(dr.mean(ks, axis=0), 0.0) if has_s else mi.Float(0.0)
        total = wd + ws
        p_spec = dr.select(total > 0, ws / dr.select(total > 0, total, 1.0),
                           1.0 if has_s and not has_d else 0.0)
        return p_spec, has_d, has_s

    def _lobe(self, cos_h: mi.Float) -> mi.Float:
        """D(h) = (n+1)/(2 pi) cos^n(theta_h), zero for cos_h <= 0."""
        n = self.exponent
        safe = dr.maximum(cos_h, 1e-30)
        return dr.select(cos_h > 0, (n + 1.0) * dr.inv_two_pi * dr.exp2(n * dr.log2(safe)), 0.0)

    def _eval_pdf(self, ctx, si, wo, kd, ks, active):
        p_spec, has_d, has_s = self._lobe_prob(ctx, kd, ks)
        wi = si.wi
        cos_i, cos_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
        active = active & (cos_i > 0) & (cos_o > 0)
        h = dr.normalize(wi + wo)
        i_dot_h = dr.maximum(dr.dot(wi, h), 1e-20)
        d_over = self._lobe(mi.Frame3f.cos_theta(h)) / (4.0 * i_dot_h)  # half-vector -> wo
        value = mi.Spectrum(0.0)
        if has_d:
            value += kd * dr.inv_pi * cos_o
        if has_s:
            value += ks * (d_over * cos_o / dr.maximum(cos_i, cos_o))
        pdf = dr.fma(p_spec, d_over, (1.0 - p_spec) * cos_o * dr.inv_pi)
        return value & active, dr.select(active, pdf, 0.0)

    def _textures(self, si, active):
        return self.diffuse.eval(si, active), self.specular.eval(si, active)

    # -- mi.BSDF interface ----------------------------------------------------------------
    def sample(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, sample1: mi.Float,
               sample2: mi.Point2f, active: mi.Bool = True) -> tuple[mi.BSDFSample3f, mi.Spectrum]:
        kd, ks = self._textures(si, active)
        p_spec, _, _ = self._lobe_prob(ctx, kd, ks)
        glossy = sample1 < p_spec

        # Half vector with density D: cos = u^(1/(n+1)); sin^2 = 1 - u^(2/(n+1)) computed
        # without cancellation for sharp lobes (series of -expm1(x) for small x).
        a = dr.log2(dr.maximum(sample2.x, 1e-38)) / (self.exponent + 1.0)
        cos_h = dr.exp2(a)
        x = -2.0 * dr.log_two * a
        sin2_h = dr.select(x < 1e-3, x * dr.fma(x, dr.fma(x, 1.0 / 6.0, -0.5), 1.0),
                           1.0 - cos_h * cos_h)
        sin_h = dr.safe_sqrt(sin2_h)
        s, c = dr.sincos(dr.two_pi * sample2.y)
        h = mi.Vector3f(sin_h * c, sin_h * s, cos_h)
        wo_glossy = dr.fma(2.0 * dr.dot(si.wi, h), h, -si.wi)
        wo_diffuse = mi.warp.square_to_cosine_hemisphere(sample2)

        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = dr.select(glossy, wo_glossy, wo_diffuse)
        bs.eta = 1.0
        bs.sampled_component = dr.select(glossy, mi.UInt32(1), mi.UInt32(0))
        bs.sampled_type = dr.select(glossy, mi.UInt32(int(mi.BSDFFlags.GlossyReflection)),
                                    mi.UInt32(int(mi.BSDFFlags.DiffuseReflection)))
        value, bs.pdf = self._eval_pdf(ctx, si, bs.wo, kd, ks, active)
        active &= bs.pdf > 0
        return bs, dr.select(active, value / dr.select(active, bs.pdf, 1.0), 0.0)

    def eval(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
             active: mi.Bool = True) -> mi.Spectrum:
        kd, ks = self._textures(si, active)
        return self._eval_pdf(ctx, si, wo, kd, ks, active)[0]

    def pdf(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
            active: mi.Bool = True) -> mi.Float:
        kd, ks = self._textures(si, active)
        return self._eval_pdf(ctx, si, wo, kd, ks, active)[1]

    def eval_pdf(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
                 active: mi.Bool = True) -> tuple[mi.Spectrum, mi.Float]:
        kd, ks = self._textures(si, active)
        return self._eval_pdf(ctx, si, wo, kd, ks, active)

    def eval_diffuse_reflectance(self, si: mi.SurfaceInteraction3f,
                                 active: mi.Bool = True) -> mi.Spectrum:
        return self.diffuse.eval(si, active)

    def traverse(self, callback: mi.TraversalCallback) -> None:
        callback.put("diffuse_reflectance", self.diffuse, mi.ParamFlags.Differentiable)
        callback.put("specular_reflectance", self.specular, mi.ParamFlags.Differentiable)
        if dr.is_jit_v(mi.Float):
            callback.put("exponent", self.exponent, mi.ParamFlags.NonDifferentiable)

    def parameters_changed(self, keys: list[str]) -> None:
        dr.make_opaque(self.exponent)

    def to_string(self) -> str:
        return (f"BlinnPhongBSDF[\n  diffuse_reflectance = {self.diffuse},\n"
                f"  specular_reflectance = {self.specular},\n  exponent = {self.exponent}\n]")


mi.register_bsdf("blinnphong", lambda props, cls=BlinnPhongBSDF: cls(props))
