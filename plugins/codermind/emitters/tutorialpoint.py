from __future__ import annotations  # Delayed parsing of type annotations

import math

import drjit as dr
import mitsuba as mi

from codermind.params import flag


class TutorialPointLight(mi.Emitter):
    r"""
    .. _emitter-tutorialpoint:

    Point light with optional falloff (:monosp:`tutorialpoint`)
    -----------------------------------------------------------

    .. pluginparameters::

     * - position
       - |point|
       - Position of the light (Default: the origin, or the translation of ``to_world``).

     * - to_world
       - |transform|
       - Alternative to ``position``; only its translation is used.

     * - intensity
       - |spectrum|
       - Radiant intensity :math:`I` (Default: 1). Must be uniform (no texture varying
         over space).

     * - falloff
       - |bool|
       - Inverse-square falloff (Default: |false|). With |false| the radiance reaching
         a point is :math:`I` whatever its distance, as the tutorial's lights (there
         world units are pixels and lights have no falloff). With |true| the plugin
         is identical to the built-in :monosp:`point` emitter (:math:`I/d^2`).

    A delta-position light for next-event estimation: it cannot be hit by rays and
    :monosp:`pdf_direction` is zero. Without falloff the emitted power is not
    defined physically (it is infinite), so ``sample_ray`` (light tracing) returns
    the same weight as :monosp:`point` would at unit distance: use this mode only with
    integrators that reach lights through :monosp:`sample_direction` (``path``,
    ``direct``, ``moment``).

    .. tabs::

        .. code-tab:: xml

            <emitter type="tutorialpoint">
                <point name="position" x="640" y="240" z="-100"/>
                <rgb name="intensity" value="2"/>
            </emitter>
    """

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        if "position" in props:
            if "to_world" in props:
                raise ValueError("tutorialpoint: give only one of 'position' and 'to_world'")
            self.position = mi.Point3f(props.get("position"))
        else:
            self.position = mi.Point3f(self.world_transform().translation())
        position = [float(dr.slice(c)) if dr.is_jit_v(mi.Float) else float(c)
                    for c in self.position]
        if not all(math.isfinite(c) for c in position):
            name = "position" if "position" in props else "to_world"
            raise ValueError(f"tutorialpoint: '{name}' must be finite, got {position}")
        self.intensity = props.get_emissive_texture("intensity", 1.0)
        if self.intensity.is_spatially_varying():
            raise ValueError("tutorialpoint: 'intensity' must not vary over space")
        mean = self.intensity.mean()
        if not math.isfinite(float(dr.slice(mean) if dr.is_jit_v(mean) else mean)):
            raise ValueError("tutorialpoint: 'intensity' must be finite")
        self.falloff = flag(props, "tutorialpoint", "falloff", False)
        self.m_flags = mi.EmitterFlags.DeltaPosition
        self.m_needs_sample_2 = False
        self.m_needs_sample_3 = False
        dr.make_opaque(self.position)

    def _intensity(self, it: mi.Interaction3f, active: mi.Bool) -> mi.Spectrum:
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wavelengths = it.wavelengths
        return self.intensity.eval(si, active)

    def sample_direction(self, it: mi.Interaction3f, sample: mi.Point2f,
                         active: mi.Bool = True) -> tuple[mi.DirectionSample3f, mi.Spectrum]:
        ds = mi.DirectionSample3f()  # dr.zeros() cannot build it in scalar variants
        ds.p = mi.Point3f(self.position)
        ds.n = mi.Normal3f(0.0)
        ds.uv = mi.Point2f(0.0)
        ds.time = it.time
        ds.pdf = mi.Float(1.0)
        ds.delta = mi.Bool(True)
        ds.emitter = mi.EmitterPtr(self) if dr.is_jit_v(mi.Float) else self
        ds.d = ds.p - it.p
        dist2 = dr.squared_norm(ds.d)
        inv_dist = dr.rsqrt(dist2)
        ds.dist = dr.sqrt(dist2)
        ds.d *= inv_dist
        value = self._intensity(it, active)
        if self.falloff:
            value *= dr.square(inv_dist)
        return ds, value & active

    def pdf_direction(self, it: mi.Interaction3f, ds: mi.DirectionSample3f,
                      active: mi.Bool = True) -> mi.Float:
        return mi.Float(0.0)

    def eval_direction(self, it: mi.Interaction3f, ds: mi.DirectionSample3f,
                       active: mi.Bool = True) -> mi.Spectrum:
        value = self._intensity(it, active)
        if self.falloff:
            value *= dr.rcp(dr.squared_norm(ds.p - it.p))
        return value & active

    def sample_position(self, time: mi.Float, sample: mi.Point2f,
                        active: mi.Bool = True) -> tuple[mi.PositionSample3f, mi.Float]:
        # every field set, as the built-in point light does: a default-constructed record
        # leaves n, uv and pdf empty, which the particle tracer's symbolic call refuses
        ps = dr.zeros(mi.PositionSample3f) if dr.is_jit_v(mi.Float) else mi.PositionSample3f()
        ps.p = mi.Point3f(self.position)
        ps.uv = mi.Point2f(0.5)
        ps.time = time
        ps.pdf = mi.Float(1.0)
        ps.delta = mi.Bool(True)
        return ps, mi.Float(1.0)

    def pdf_position(self, ps: mi.PositionSample3f, active: mi.Bool = True) -> mi.Float:
        return mi.Float(0.0)

    def sample_ray(self, time: mi.Float, sample1: mi.Float, sample2: mi.Point2f,
                   sample3: mi.Point2f, active: mi.Bool = True) -> tuple[mi.Ray3f, mi.Spectrum]:
        wavelengths, weight = self.sample_wavelengths(
            dr.zeros(mi.SurfaceInteraction3f), sample1, active)
        ray = mi.Ray3f(mi.Point3f(self.position), mi.warp.square_to_uniform_sphere(sample3),
                       time, wavelengths)
        return ray, weight * (4.0 * dr.pi)

    def sample_wavelengths(self, si: mi.SurfaceInteraction3f, sample: mi.Float,
                           active: mi.Bool = True) -> tuple[mi.Wavelength, mi.Spectrum]:
        return self.intensity.sample_spectrum(si, _shifted(type(si.wavelengths), sample), active)

    def eval(self, si: mi.SurfaceInteraction3f, active: mi.Bool = True) -> mi.Spectrum:
        return mi.Spectrum(0.0)

    def bbox(self) -> mi.ScalarBoundingBox3f:
        p = mi.ScalarPoint3f([float(dr.slice(c)) for c in self.position])
        return mi.ScalarBoundingBox3f(p)

    def traverse(self, callback: mi.TraversalCallback) -> None:
        callback.put("position", self.position, mi.ParamFlags.NonDifferentiable)
        callback.put("intensity", self.intensity, mi.ParamFlags.Differentiable)

    def parameters_changed(self, keys: list[str]) -> None:
        dr.make_opaque(self.position)

    def to_string(self) -> str:
        return (f"TutorialPointLight[\n  position = {self.position},\n"
                f"  intensity = {self.intensity},\n  falloff = {self.falloff}\n]")


def _shifted(kind, sample):
    """Mitsuba's ``math::sample_shifted`` (not exposed to Python): the wavelength sample's
    n equally spaced copies modulo 1; RGB variants have no wavelengths (n = 0)."""
    n = dr.size_v(kind)
    if n == 0:
        return dr.zeros(kind) if dr.is_jit_v(mi.Float) else kind()
    return kind([dr.fma(1.0 / n, k, sample) - dr.floor(dr.fma(1.0 / n, k, sample))
                 for k in range(n)])


mi.register_emitter("tutorialpoint", lambda props, cls=TutorialPointLight: cls(props))
