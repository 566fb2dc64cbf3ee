from __future__ import annotations  # Delayed parsing of type annotations

import mitsuba as mi

from . import _noise
from ..params import positive_float
from ._solid import SolidTexture


class PerlinTexture(SolidTexture):
    r"""
    .. _texture-perlin:

    Perlin noise (:monosp:`perlin`)
    -------------------------------

    .. pluginparameters::

     * - frequency
       - |float|
       - Noise frequency :math:`f` in 1/world units (Default: 1)

     * - gradient
       - |string|
       - Gradient function of the noise (spec 2.8): ``tutorial``, the tutorial's own, or
         ``reference``, Ken Perlin's 2002 reference; they differ for hashes 13 and 14
         (Default: ``tutorial``)

     * - to_world
       - |transform|
       - Placement of the noise in the scene: it is evaluated at
         :math:`\mathbf{p} = \mathtt{to\_world}^{-1}\,\mathbf{x}` for the world position
         :math:`\mathbf{x}` of the shading point (Default: identity)

    A solid (3D) texture: the raw value of the tutorial's Perlin noise (Ken Perlin's
    improved noise of 2002 with his permutation table and, by default, the tutorial's
    gradient function), :math:`\mathrm{noise}(f\,\mathbf{p})`, as a grey value in about
    :math:`[-1, 1]`, negative values included, evaluated in single precision (see the
    package README for where float32 stops being accurate). The texture ignores UV
    coordinates. :monosp:`mean()` is 0, the average of the noise over space.

    .. tabs::

        .. code-tab:: xml

            <texture type="perlin" name="reflectance">
                <float name="frequency" value="0.1"/>
            </texture>
    """

    plugin = "perlin"

    def __init__(self, props: mi.Properties):
        super().__init__(props, mixes_colors=False)
        self.frequency = positive_float(props, self.plugin, "frequency", 1.0)
        self.gradient = _noise.read_gradient(props, self.plugin)

    def weight(self, p: mi.Point3f) -> mi.Float:
        f = self.frequency
        return _noise.noise(p.x * f, p.y * f, p.z * f, self.gradient)

    def mean_weight(self) -> float:
        return 0.0

    def describe(self) -> str:
        return f"frequency = {self.frequency},\n  gradient = {self.gradient}"


mi.register_texture("perlin", lambda props, cls=PerlinTexture: cls(props))
