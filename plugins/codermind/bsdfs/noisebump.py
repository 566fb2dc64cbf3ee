from __future__ import annotations  # Delayed parsing of type annotations

import drjit as dr
import mitsuba as mi

from ..exposed import exposed, kernel_value, scalar_matrix, take_float
from ..textures import _noise
from ..textures._solid import placement
from ..params import flag, read_float


class NoiseBumpBSDF(mi.BSDF):
    r"""
    .. _bsdf-noisebump:

    Noise bump mapping (:monosp:`noisebump`)
    ----------------------------------------

    .. pluginparameters::

     * - (Nested plugin)
       - |bsdf|
       - The BSDF evaluated with the perturbed shading frame (exactly one)

     * - bumplevel
       - |float|
       - Bump strength :math:`b` in [0, 1], the tutorial's ``Bumplevel`` (Default: 0.1)

     * - frequency
       - |float|
       - Noise frequency :math:`f` per world unit (Default: 10, the tutorial's 0.1 per
         pixel scaled to a scene in units 100 times the tutorial's pixels, where bumps on
         an object of radius 1 look as on the tutorial's spheres of radius 100; at 0.1 the
         noise hardly varies over such an object, which then only tilts evenly;
         ``codermind convert`` writes the tutorial's 0.1)

     * - gradient
       - |string|
       - Gradient function of the noise (facts.md F9.2): ``tutorial``, the tutorial's own, or
         ``reference``, Ken Perlin's 2002 reference; they differ for hashes 13 and 14
         (Default: ``tutorial``)

     * - to_world
       - |transform|
       - Placement of the noise: it is evaluated at
         :math:`\mathbf{p} = \mathtt{to\_world}^{-1}\,\mathbf{x}` for the world position
         :math:`\mathbf{x}` (Default: identity)

     * - (traverse)
       -
       - ``mi.traverse`` exposes ``bumplevel`` and ``frequency`` (differentiable),
         ``to_world`` (non-differentiable) and the nested BSDF's parameters.

     * - leak_check
       - |boolean|
       - Reject directions on different sides of the perturbed and the original shading
         normal, as Mitsuba's :monosp:`normalmap` does (no light through the surface).
         The tutorial does not do this (Default: |false|)

    The tutorial's bump mapping (facts.md F10) as a wrapper around any BSDF, in the manner of
    Mitsuba's :monosp:`normalmap`: the nested BSDF is evaluated and sampled in a
    perturbed shading frame whose normal is

    .. math::

        n' = \mathrm{normalize}\bigl((1 - b)\,n + s\,b\,N(\mathbf{p})\bigr),\qquad
        N = \bigl(\mathrm{noise}(f(x, y, z)), \mathrm{noise}(f(y, z, x)),
                  \mathrm{noise}(f(z, x, y))\bigr),

    with the tutorial's Perlin noise (see ``gradient``) at the world position (no unit
    conversion: world units as in the tutorial) and :math:`n` the shading normal. The
    tutorial flips the normal towards the ray BEFORE bumping, so for a hit from behind its
    unbumped normal (the tutorial's "inside", e.g. inside its glass blob) it bumps
    :math:`-n` with :math:`+N`; the outward normal is then :math:`\mathrm{normalize}((1-b)\,n - b\,N)`.
    This plugin reproduces that with :math:`s = -1` behind the unbumped shading normal and
    :math:`s = +1` in front. The tangent of the new frame is the original one,
    orthogonalized. The nested BSDF's cosine is taken with the perturbed normal, so a
    nested :monosp:`tutorial` BSDF sees exactly the tutorial's bumped normal in its
    lighting, Fresnel, reflection and refraction; the nested BSDF receives the unbumped
    shading normal in ``si.n``, from which :monosp:`tutorial` decides "inside" as the
    tutorial does. (On a blob mesh the unbumped shading normal, the exact field's gradient,
    and the geometric normal of the triangles can disagree about the side near creases
    and necks: up to cos 0.1 against -0.2 on the page-4 blob.)

    .. tabs::

        .. code-tab:: xml

            <bsdf type="noisebump">
                <float name="bumplevel" value="0.1"/>
                <bsdf type="tutorial">
                    <rgb name="specular" value="1.2"/>
                    <float name="power" value="60"/>
                    <float name="reflection" value="1"/>
                </bsdf>
            </bsdf>
    """

    plugin = "noisebump"

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        name = self.plugin
        # only the nested objects are read here: a parameter this plugin does not know (a
        # typo) stays unqueried, and Mitsuba refuses it when loading
        nested = []
        for key, obj in props.objects():
            if not isinstance(obj, mi.BSDF):
                raise ValueError(f"{name}: '{key}' is a {obj.class_name()}, but the only "
                                 f"nested object it takes is one BSDF")
            nested.append(obj)
        if len(nested) != 1:
            raise ValueError(f"{name}: needs exactly one nested BSDF, got {len(nested)}")
        self.nested = nested[0]
        self.bumplevel = read_float(props, name, "bumplevel", 0.1, lo=0.0, hi=1.0)
        self.frequency = read_float(props, name, "frequency", 10.0, lo=0.0, open_lo=True)
        self.leak_check = flag(props, name, "leak_check", False)
        self.gradient = _noise.read_gradient(props, name)
        self.identity = "to_world" not in props
        if not self.identity:
            self.to_world, self.to_local = placement(props.get("to_world").matrix)
        self.m_components = [self.nested.flags(i) for i in range(self.nested.component_count())]
        self.m_flags = self.nested.flags()

    def _perturbed(self, si: mi.SurfaceInteraction3f, active: mi.Bool):
        """The perturbed interaction (frame and wi) for the nested BSDF."""
        p = si.p if self.identity else self.to_local @ si.p
        f = kernel_value(self, "frequency")
        x, y, z = p.x * f, p.y * f, p.z * f
        bump = _noise.rotated_noise(x, y, z, self.gradient)
        frame = si.sh_frame
        wi = frame.to_world(si.wi)
        # in float32 from the start, as after a write-back through mi.traverse
        b = self.bumplevel if dr.is_array_v(self.bumplevel) else mi.Float(self.bumplevel)
        # the tutorial flips its UNBUMPED normal towards the ray: that decides the side
        # (on a blob mesh it can disagree with the geometric normal near creases and necks)
        sign_b = dr.select(dr.dot(frame.n, wi) < 0, -b, b)
        n = dr.fma(mi.Vector3f(frame.n), 1.0 - b, bump * sign_b)
        len2 = dr.squared_norm(n)
        n = dr.select(len2 > 1e-12, n * dr.rsqrt(dr.select(len2 > 1e-12, len2, 1.0)), frame.n)
        s = dr.fma(n, -dr.dot(n, frame.s), frame.s)
        s_len2 = dr.squared_norm(s)
        fallback = mi.Frame3f(n)
        s = dr.select(s_len2 > 1e-8, s * dr.rsqrt(dr.select(s_len2 > 1e-8, s_len2, 1.0)),
                      fallback.s)
        perturbed = mi.SurfaceInteraction3f(si)
        perturbed.sh_frame = mi.Frame3f(s, dr.cross(n, s), n)
        perturbed.wi = perturbed.sh_frame.to_local(wi)
        perturbed.n = frame.n       # the side reference of a nested `tutorial` BSDF
        return perturbed

    def _same_side(self, wo: mi.Vector3f, perturbed_wo: mi.Vector3f) -> mi.Bool:
        if not self.leak_check:
            return True
        return mi.Frame3f.cos_theta(wo) * mi.Frame3f.cos_theta(perturbed_wo) > 0

    def sample(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, sample1: mi.Float,
               sample2: mi.Point2f, active: mi.Bool = True) -> tuple[mi.BSDFSample3f, mi.Spectrum]:
        perturbed = self._perturbed(si, active)
        bs, weight = self.nested.sample(ctx, perturbed, sample1, sample2, active)
        perturbed_wo = bs.wo
        bs.wo = si.sh_frame.to_local(perturbed.sh_frame.to_world(perturbed_wo))
        ok = self._same_side(bs.wo, perturbed_wo)
        bs.pdf = dr.select(ok, bs.pdf, 0.0)
        return bs, weight & ok

    def eval_sample(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f,
                    wos: list[mi.Vector3f], sample1: mi.Float, sample2: mi.Point2f,
                    active: mi.Bool = True
                    ) -> tuple[list[mi.Spectrum], mi.BSDFSample3f, mi.Spectrum]:
        """``[eval(wo) for wo in wos]`` and ``sample`` in one call, with ONE perturbed frame
        (one noise evaluation per hit instead of one per light and one for the sample)."""
        perturbed = self._perturbed(si, active)
        perturbed_wos = [self._local(si, perturbed, wo) for wo in wos]
        masks = [active & self._same_side(wo, pwo) for wo, pwo in zip(wos, perturbed_wos)]
        fused = getattr(self.nested, "eval_sample", None)
        if fused is not None and not self.leak_check:
            values, bs, weight = fused(ctx, perturbed, perturbed_wos, sample1, sample2, active)
        else:
            values = [self.nested.eval(ctx, perturbed, pwo, m)
                      for pwo, m in zip(perturbed_wos, masks)]
            bs, weight = self.nested.sample(ctx, perturbed, sample1, sample2, active)
        values = [v & m for v, m in zip(values, masks)]
        perturbed_wo = bs.wo
        bs.wo = si.sh_frame.to_local(perturbed.sh_frame.to_world(perturbed_wo))
        ok = self._same_side(bs.wo, perturbed_wo)
        bs.pdf = dr.select(ok, bs.pdf, 0.0)
        return values, bs, weight & ok

    def _local(self, si, perturbed, wo):
        return perturbed.sh_frame.to_local(si.sh_frame.to_world(wo))

    def eval(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
             active: mi.Bool = True) -> mi.Spectrum:
        perturbed = self._perturbed(si, active)
        perturbed_wo = self._local(si, perturbed, wo)
        active = active & self._same_side(wo, perturbed_wo)
        return self.nested.eval(ctx, perturbed, perturbed_wo, active) & active

    def pdf(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
            active: mi.Bool = True) -> mi.Float:
        perturbed = self._perturbed(si, active)
        perturbed_wo = self._local(si, perturbed, wo)
        active = active & self._same_side(wo, perturbed_wo)
        return dr.select(active, self.nested.pdf(ctx, perturbed, perturbed_wo, active), 0.0)

    def eval_pdf(self, ctx: mi.BSDFContext, si: mi.SurfaceInteraction3f, wo: mi.Vector3f,
                 active: mi.Bool = True) -> tuple[mi.Spectrum, mi.Float]:
        perturbed = self._perturbed(si, active)
        perturbed_wo = self._local(si, perturbed, wo)
        active = active & self._same_side(wo, perturbed_wo)
        value, pdf = self.nested.eval_pdf(ctx, perturbed, perturbed_wo, active)
        return value & active, dr.select(active, pdf, 0.0)

    def has_attribute(self, name: str, active: mi.Bool = True) -> bool:
        return self.nested.has_attribute(name, active)

    def eval_attribute_1(self, name: str, si: mi.SurfaceInteraction3f,
                         active: mi.Bool = True) -> mi.Float:
        """The nested BSDF's attribute at the bumped frame (as its ``sample`` sees it)."""
        return self.nested.eval_attribute_1(name, self._perturbed(si, active), active)

    def eval_diffuse_reflectance(self, si: mi.SurfaceInteraction3f,
                                 active: mi.Bool = True) -> mi.Spectrum:
        return self.nested.eval_diffuse_reflectance(si, active)

    def traverse(self, callback: mi.TraversalCallback) -> None:
        callback.put("nested_bsdf", self.nested, mi.ParamFlags.Differentiable)
        callback.put("bumplevel", exposed(self, "bumplevel"), mi.ParamFlags.Differentiable)
        callback.put("frequency", exposed(self, "frequency"), mi.ParamFlags.Differentiable)
        nd = mi.ParamFlags.NonDifferentiable
        callback.put("to_world", exposed(self, "to_world", lambda: mi.Transform4f(
            mi.ScalarMatrix4f(1.0) if self.identity else self.to_world.matrix)), nd)

    def parameters_changed(self, keys: list[str]) -> None:
        if not keys or "bumplevel" in keys:
            take_float(self, self.plugin, "bumplevel", lo=0.0, hi=1.0, keep_array=True)
        if not keys or "frequency" in keys:
            take_float(self, self.plugin, "frequency", lo=0.0, open_lo=True)
        if not keys or "to_world" in keys:
            self.identity = False
            self.to_world, self.to_local = placement(scalar_matrix(exposed(self, "to_world")))

    def to_string(self) -> str:
        return (f"NoiseBumpBSDF[\n  bumplevel = {self.bumplevel},\n"
                f"  frequency = {self.frequency},\n  gradient = {self.gradient},\n"
                f"  leak_check = {self.leak_check},\n"
                f"  nested_bsdf = {self.nested}\n]")


mi.register_bsdf("noisebump", lambda props, cls=NoiseBumpBSDF: cls(props))
