"""Common part of the solid (3D) noise textures ``perlin``, ``turbulence`` and ``marble``:
the lookup position (world position through an optional ``to_world``), the colours and
turbulence parameters (read by :mod:`codermind.params`), and the two-colour mix
``w * color0 + (1 - w) * color1`` of the tutorial (unclamped)."""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from ..exposed import exposed, kernel_value, scalar_matrix, take_float, take_int
from ..params import finite_color, octave_count, positive_float
from . import _noise


class SolidTexture(mi.Texture):
    """Base of the noise textures: ``weight(p)`` is the scalar field at the (to_world^-1
    transformed) world position; subclasses with colours mix them with that weight."""

    plugin = "solid"

    def __init__(self, props: mi.Properties, mixes_colors: bool):
        super().__init__(props)
        self.identity = "to_world" not in props
        if not self.identity:
            # a double-precision transform, kept as float32 as mi.traverse hands it out
            self.to_world, self.to_local = placement(props.get("to_world").matrix)
        self.mixes_colors = mixes_colors
        if mixes_colors:
            # Unbounded: the tutorial's colours are plain multipliers and may exceed 1.
            self.color0 = finite_color(props, self.plugin, "color0", 1.0)
            self.color1 = finite_color(props, self.plugin, "color1", 0.0)

    # -- to be provided by subclasses ---------------------------------------------------
    def weight(self, p: mi.Point3f) -> mi.Float:
        raise NotImplementedError

    def mean_weight(self) -> float:
        raise NotImplementedError

    def describe(self) -> str:
        raise NotImplementedError

    # -- mi.Texture interface -----------------------------------------------------------
    def position(self, si: mi.SurfaceInteraction3f) -> mi.Point3f:
        return si.p if self.identity else self.to_local @ si.p

    def eval(self, si: mi.SurfaceInteraction3f, active: mi.Bool = True) -> mi.UnpolarizedSpectrum:
        w = self.weight(self.position(si))
        if not self.mixes_colors:
            return mi.UnpolarizedSpectrum(w)
        return w * self.color0.eval(si, active) + (1.0 - w) * self.color1.eval(si, active)

    def eval_1(self, si: mi.SurfaceInteraction3f, active: mi.Bool = True) -> mi.Float:
        w = self.weight(self.position(si))
        if not self.mixes_colors:
            return w
        return w * self.color0.eval_1(si, active) + (1.0 - w) * self.color1.eval_1(si, active)

    def eval_3(self, si: mi.SurfaceInteraction3f, active: mi.Bool = True) -> mi.Color3f:
        w = self.weight(self.position(si))
        if not self.mixes_colors:
            return mi.Color3f(w)
        return w * self.color0.eval_3(si, active) + (1.0 - w) * self.color1.eval_3(si, active)

    def highest_frequency(self) -> float:
        """Highest spatial frequency of ``weight`` (cycles of the noise lattice per unit)."""
        return float(self.frequency) * getattr(self, "octaves", 1)

    def eval_1_grad(self, si: mi.SurfaceInteraction3f, active: mi.Bool = True) -> mi.Vector2f:
        """Derivatives of ``eval_1`` along the surface's u and v (what the built-in
        ``bumpmap`` needs): the weight's 3D gradient, by central differences with a step
        of 1/100 of the highest frequency's lattice cell (the noise is C2), dotted with
        ``dp_du`` and ``dp_dv``. The gradients of textured colours are ignored."""
        p = self.position(si)
        h = 0.01 / self.highest_frequency()
        grad = []
        for axis in range(3):
            step = mi.Vector3f(*[h if a == axis else 0.0 for a in range(3)])
            grad.append((self.weight(p + step) - self.weight(p - step)) * (0.5 / h))
        g = mi.Vector3f(*grad)
        if not self.identity:       # d/dx w(M x) = M^T grad w
            g = _transposed(self.to_local, g)
        if self.mixes_colors:
            g = g * (self.color0.eval_1(si, active) - self.color1.eval_1(si, active))
        return mi.Vector2f(dr.dot(g, si.dp_du), dr.dot(g, si.dp_dv))

    def mean(self) -> float:
        w = self.mean_weight()
        if not self.mixes_colors:
            return w
        return w * self.color0.mean() + (1.0 - w) * self.color1.mean()

    def is_spatially_varying(self) -> bool:
        return True

    #: Frequencies exposed to ``mi.traverse``, each > 0 and differentiable: the noise is
    #: C2 in its argument, so the texture is smooth in them (the lattice cell, a floor(),
    #: has zero derivative; the fractional part within the cell carries it). The kernels
    #: use the traversed ``mi.Float`` (:func:`codermind.exposed.kernel_value`); the
    #: attribute stays a Python float.
    exposed_floats: tuple[str, ...] = ("frequency",)

    def traverse(self, callback: mi.TraversalCallback) -> None:
        if self.mixes_colors:
            callback.put("color0", self.color0, mi.ParamFlags.Differentiable)
            callback.put("color1", self.color1, mi.ParamFlags.Differentiable)
        for name in self.exposed_floats:
            callback.put(name, exposed(self, name), mi.ParamFlags.Differentiable)
        nd = mi.ParamFlags.NonDifferentiable
        if hasattr(self, "octaves"):
            callback.put("octaves", exposed(self, "octaves"), nd)
        callback.put("to_world", exposed(self, "to_world", lambda: mi.Transform4f(
            mi.ScalarMatrix4f(1.0) if self.identity else self.to_world.matrix)), nd)

    def parameters_changed(self, keys: list[str]) -> None:
        for name in self.exposed_floats:
            if not keys or name in keys:
                take_float(self, self.plugin, name, lo=0.0, open_lo=True)
        if hasattr(self, "octaves") and (not keys or "octaves" in keys):
            take_int(self, self.plugin, "octaves", 1, 64)
        if not keys or "to_world" in keys:
            self.identity = False
            self.to_world, self.to_local = placement(scalar_matrix(exposed(self, "to_world")))

    def to_string(self) -> str:
        colors = (f",\n  color0 = {self.color0},\n  color1 = {self.color1}"
                  if self.mixes_colors else "")
        placement = "" if self.identity else f",\n  to_world = {self.to_world.matrix}"
        return f"{type(self).__name__}[\n  {self.describe()}{placement}{colors}\n]"


def placement(matrix) -> tuple[mi.ScalarTransform4f, mi.Transform4f]:
    """``to_world`` as float32 and ``to_local``, its inverse taken in double precision
    from that float32 matrix: the same pair whether the matrix comes from the scene (a
    double-precision transform) or back from ``mi.traverse`` (its float32 copy), so writing
    a texture's own ``to_world`` back changes no bit of its lookups."""
    m = mi.ScalarMatrix4f(matrix)
    inverse = mi.ScalarTransform4d(mi.ScalarMatrix4d(m)).inverse().matrix
    return mi.ScalarTransform4f(m), mi.Transform4f(mi.ScalarMatrix4f(inverse))


def _transposed(to_local: mi.Transform4f, g: mi.Vector3f) -> mi.Vector3f:
    """The transpose of the linear part of ``to_local`` applied to ``g``."""
    m = to_local.matrix
    return mi.Vector3f(*[m[0][j] * g.x + m[1][j] * g.y + m[2][j] * g.z for j in range(3)])


class TurbulenceBase(SolidTexture):
    """Colours, ``frequency`` (default 5 per unit) and ``octaves`` (default 9) of the
    tutorial's turbulence, shared by ``turbulence`` and ``marble``."""

    def __init__(self, props: mi.Properties):
        super().__init__(props, mixes_colors=True)
        self.frequency = positive_float(props, self.plugin, "frequency", 5.0)
        self.octaves = octave_count(props, self.plugin)
        self.gradient = _noise.read_gradient(props, self.plugin)

    def turbulence(self, p: mi.Point3f) -> mi.Float:
        return _noise.turbulence(p, kernel_value(self, "frequency"), self.octaves,
                                 self.gradient)

    def describe(self) -> str:
        return (f"frequency = {self.frequency},\n  octaves = {self.octaves},\n"
                f"  gradient = {self.gradient}")
