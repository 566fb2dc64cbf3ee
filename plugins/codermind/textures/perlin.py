from __future__ import annotations  # Delayed parsing of type annotations

import drjit as dr
import mitsuba as mi

from ..exposed import exposed, kernel_value, scalar, take_float
from ..params import positive_float, read_float
from . import _noise
from ._solid import SolidTexture


class PerlinTexture(SolidTexture):
    r"""
    .. _texture-perlin:

    Perlin noise (:monosp:`perlin`)
    -------------------------------

    .. pluginparameters::

     * - frequency
       - |float|
       - Noise frequency :math:`f` per world unit (Default: 1)

     * - scale, offset
       - |float|
       - The texture returns :math:`\mathtt{scale}\cdot\mathrm{noise} + \mathtt{offset}`
         (Defaults: 1 and 0, the raw noise). E.g. scale 0.5 and offset 0.5 map the noise
         into about [0, 1] for use as a reflectance. Both are differentiable.

     * - gradient
       - |string|
       - Gradient function of the noise (facts.md F9.2): ``tutorial``, the tutorial's own, or
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
    coordinates. :monosp:`mean()` is ``offset``, the average over space (the noise
    averages 0). Parameters exposed to ``mi.traverse``: ``frequency``, ``scale`` and
    ``offset`` (differentiable) and ``to_world`` (non-differentiable).

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
        self.scale = read_float(props, self.plugin, "scale", 1.0)
        self.offset = read_float(props, self.plugin, "offset", 0.0)

    def weight(self, p: mi.Point3f) -> mi.Float:
        f = kernel_value(self, "frequency")
        return dr.fma(_noise.noise(p.x * f, p.y * f, p.z * f, self.gradient), self.scale,
                      self.offset)

    def mean_weight(self) -> float:
        return scalar(self.offset)

    def describe(self) -> str:
        return (f"frequency = {self.frequency},\n  gradient = {self.gradient},\n"
                f"  scale = {self.scale},\n  offset = {self.offset}")

    def traverse(self, callback: mi.TraversalCallback) -> None:
        super().traverse(callback)
        callback.put("scale", exposed(self, "scale"), mi.ParamFlags.Differentiable)
        callback.put("offset", exposed(self, "offset"), mi.ParamFlags.Differentiable)

    def parameters_changed(self, keys: list[str]) -> None:
        super().parameters_changed(keys)
        for name in ("scale", "offset"):
            if not keys or name in keys:
                take_float(self, self.plugin, name, keep_array=True)


mi.register_texture("perlin", lambda props, cls=PerlinTexture: cls(props))
