from __future__ import annotations  # Delayed parsing of type annotations

import mitsuba as mi

from . import _noise
from ._solid import TurbulenceBase


class TurbulenceTexture(TurbulenceBase):
    r"""
    .. _texture-turbulence:

    Turbulence (:monosp:`turbulence`)
    ---------------------------------

    .. pluginparameters::

     * - color0
       - |spectrum| or |texture|
       - Colour weighted by :math:`T`: the tutorial's ``Diffuse`` (Default: 1)

     * - color1
       - |spectrum| or |texture|
       - Colour weighted by :math:`1 - T`: the tutorial's ``Diffuse2`` (Default: 0). Both
         colours may exceed 1 (they are multipliers, as in the tutorial)

     * - frequency
       - |float|
       - Base frequency :math:`f` per world unit (Default: 5, the tutorial's 0.05 per
         pixel scaled to a scene in units 100 times the tutorial's pixels, where an
         object of radius 1 gets the look of the tutorial's spheres of radius 100;
         ``codermind convert`` writes the tutorial's 0.05)

     * - octaves
       - |int|
       - Number of octaves :math:`K`, 1 to 64 (Default: 9, the tutorial's)

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

    The tutorial's turbulence material colour (page 4): with the tutorial's Perlin noise,

    .. math::

        T(\mathbf{p}) = \sum_{k=1}^{K} \frac{1}{k}\,\bigl|\mathrm{noise}(k f \mathbf{p})\bigr|,
        \qquad c = T\,\mathtt{color0} + (1 - T)\,\mathtt{color1}.

    The mix is NOT clamped, as in the tutorial: :math:`T` can exceed 1 and then the colour
    extrapolates beyond ``color0`` (it can even become negative). With the default colours
    the texture returns :math:`T` itself. :monosp:`mean()` uses the spatial average
    :math:`E|\mathrm{noise}|`, measured: 0.2180 with the tutorial's gradient, 0.2204 with
    the reference's. ``mi.traverse`` exposes ``color0``, ``color1`` and ``frequency``
    (differentiable: the noise is smooth in its argument), ``octaves`` and ``to_world``
    (non-differentiable).

    The tutorial multiplies the lighting of turbulence and marble surfaces by its path
    weight twice (a quirk, facts.md F7); this texture is only the colour, and the
    :monosp:`tutorial` BSDF applies path weights once, as for every other material.

    .. tabs::

        .. code-tab:: xml

            <texture type="turbulence" name="diffuse">
                <rgb name="color0" value="0.35, 0.25, 0.01"/>
                <rgb name="color1" value="0.5, 0.5, 0.01"/>
            </texture>
    """

    plugin = "turbulence"

    def weight(self, p: mi.Point3f) -> mi.Float:
        return self.turbulence(p)

    def mean_weight(self) -> float:
        harmonic = sum(1.0 / k for k in range(1, self.octaves + 1))
        return _noise.MEAN_ABS_NOISE[self.gradient] * harmonic


mi.register_texture("turbulence", lambda props, cls=TurbulenceTexture: cls(props))
