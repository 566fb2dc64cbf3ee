from __future__ import annotations  # Delayed parsing of type annotations

import drjit as dr
import mitsuba as mi

from ..exposed import kernel_value
from ..params import positive_float
from ._solid import TurbulenceBase


#: The stripe phase is clamped to +-2^23: float32 has no fraction bits beyond, and Dr.Jit's
#: float32 sine leaves [-1, 1] from about 1.5e7 and is infinite from about 1e9 (measured by
#: the perlin_float32 stability sweep).
PHASE_LIMIT = float(2 ** 23)


class MarbleTexture(TurbulenceBase):
    r"""
    .. _texture-marble:

    Marble (:monosp:`marble`)
    -------------------------

    .. pluginparameters::

     * - color0
       - |spectrum| or |texture|
       - Colour weighted by :math:`m`: the tutorial's ``Diffuse`` (Default: 1)

     * - color1
       - |spectrum| or |texture|
       - Colour weighted by :math:`1 - m`: the tutorial's ``Diffuse2`` (Default: 0). Both
         colours may exceed 1 (they are multipliers, as in the tutorial)

     * - frequency
       - |float|
       - Base frequency :math:`f` of the turbulence per world unit (Default: 5, the
         tutorial's 0.05 per pixel scaled to a scene in units 100 times the tutorial's
         pixels, where an object of radius 1 gets the look of the tutorial's spheres of
         radius 100; ``codermind convert`` writes the tutorial's 0.05)

     * - octaves
       - |int|
       - Number of turbulence octaves :math:`K`, 1 to 64 (Default: 9)

     * - stripe_frequency
       - |float|
       - Frequency :math:`s` of the stripes along :math:`x + y`, per world unit (Default: 5,
         the tutorial's 0.05 per pixel at the scale of ``frequency``)

     * - gradient
       - |string|
       - Gradient function of the noise (facts.md F9.2): ``tutorial``, the tutorial's own, or
         ``reference``, Ken Perlin's 2002 reference; they differ for hashes 13 and 14
         (Default: ``tutorial``)

     * - to_world
       - |transform|
       - Placement: the texture is evaluated at
         :math:`\mathbf{p} = \mathtt{to\_world}^{-1}\,\mathbf{x}` for the world position
         :math:`\mathbf{x}` (Default: identity)

    The tutorial's marble material colour (page 4): with the turbulence :math:`T` of the
    :monosp:`turbulence` texture,

    .. math::

        m(\mathbf{p}) = \tfrac12 \sin\bigl(s\,(p_x + p_y) + T(\mathbf{p})\bigr) + \tfrac12,
        \qquad c = m\,\mathtt{color0} + (1 - m)\,\mathtt{color1}.

    The frequencies' defaults are the tutorial's constants scaled to units of 100 of its
    pixels (``frequency``); with the default colours the texture
    returns :math:`m`. The stripe phase is clamped to :math:`\pm 2^{23}`, beyond which float32
    has no fractional bits (and the float32 sine leaves [-1, 1]), so :math:`m` stays in
    [0, 1] at any position. :monosp:`mean()` takes :math:`m` to average 1/2 over space.
    ``mi.traverse`` exposes ``color0``, ``color1``, ``frequency`` and ``stripe_frequency``
    (differentiable), ``octaves`` and ``to_world`` (non-differentiable). As for
    :monosp:`turbulence`, the tutorial's double application of the path weight to marble
    surfaces is not reproduced (the :monosp:`tutorial` BSDF applies it once).

    .. tabs::

        .. code-tab:: xml

            <texture type="marble" name="diffuse">
                <rgb name="color0" value="0.5, 0.5, 0.5"/>
                <rgb name="color1" value="0.15, 0.01, 0.15"/>
            </texture>
    """

    plugin = "marble"

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        self.stripe_frequency = positive_float(props, self.plugin, "stripe_frequency", 5.0)

    exposed_floats = ("frequency", "stripe_frequency")

    def weight(self, p: mi.Point3f) -> mi.Float:
        t = self.turbulence(p)
        phase = dr.clip(dr.fma(p.x + p.y, kernel_value(self, "stripe_frequency"), t), -PHASE_LIMIT, PHASE_LIMIT)
        return dr.fma(0.5, dr.sin(phase), 0.5)

    def mean_weight(self) -> float:
        return 0.5

    def highest_frequency(self) -> float:
        return max(super().highest_frequency(), float(self.stripe_frequency))

    def describe(self) -> str:
        return f"{super().describe()},\n  stripe_frequency = {self.stripe_frequency}"


mi.register_texture("marble", lambda props, cls=MarbleTexture: cls(props))
