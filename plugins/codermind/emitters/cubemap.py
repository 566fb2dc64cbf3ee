from __future__ import annotations  # Delayed parsing of type annotations

import os
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np

from codermind.emitters._records import emitter_ptr, zero_direction_sample, zero_position_sample
from codermind.exposed import exposed, scalar, scalar_matrix, take_float
from codermind.params import FLOAT32_MAX, flag, float32, read_float

#: Face parameters in the tutorial's loading order, with the axis each one covers.
FACES = ("up", "down", "right", "left", "forward", "backward")
FACE_AXES = ("+y", "-y", "+x", "-x", "+z", "-z")
#: Default radius of the sphere assumed to bound the scene until ``attach_scene``.
DEFAULT_SCENE_RADIUS = 1e5


class CubeMap(mi.Emitter):
    r"""
    .. _emitter-cubemap:

    Cube-map environment (:monosp:`cubemap`)
    ----------------------------------------

    .. pluginparameters::

     * - up, down, right, left, forward, backward
       - |string| or Bitmap
       - The six faces, covering local :math:`+y, -y, +x, -x, +z, -z`: file names of
         any format ``mi.Bitmap`` reads (TGA included), resolved like every file of a
         scene (relative to the XML file's folder), or ``mi.Bitmap`` objects (Python).
         All faces must have the size of ``up``.

     * - mode
       - |string|
       - ``light`` (default): an environment light, importance-sampled over texels.
         ``background``: seen by rays that escape (camera, mirror and BSDF-sampled rays)
         but never sampled as a light: ``sample_direction`` returns weight and pdf 0,
         ``pdf_direction`` is 0, and ``sampling_weight`` defaults to 0 so that the
         scene never picks it (a scene whose emitters all have weight 0 cannot be
         built: with no other emitter, give ``sampling_weight`` 1).

     * - srgb
       - |bool|
       - Decode the looked-up value with a plain power 2.2 (the tutorial's
         ``Cubemap.sRGB``; not the exact sRGB curve) (Default: |false|).

     * - exposed
       - |bool|
       - Undo an exposure curve baked into the faces: :math:`c \to -\ln(1.001 - c)`,
         after ``srgb`` (the tutorial's ``Cubemap.Exposed``) (Default: |false|).

     * - exposure
       - |float|
       - Divisor applied after the decodes (the tutorial's ``Cubemap.Exposure``),
         > 0 (Default: 1).

     * - scale
       - |float|
       - Multiplier of the radiance (Default: 1).

     * - to_world
       - |transform|
       - Orientation of the cube (rotation or reflection; the translation is ignored)
         (Default: identity, the faces' axes are the world's).

    The cube-map environment of the Codermind tutorial (page 4), exactly as its program
    looks it up. For a direction :math:`d = (a, b, c)` in local space:

    - the face is that of the dominant axis (ties go to x, then y, then z), its sign
      picks the positive or negative face;
    - :math:`(u, v)`: :math:`+x`: :math:`(1 - (c/a + 1)/2, (b/a + 1)/2)`;
      :math:`-x`: :math:`(1 - (c/a + 1)/2, 1 - (b/a + 1)/2)`;
      :math:`+y`: :math:`((a/b + 1)/2, 1 - (c/b + 1)/2)`;
      :math:`-y`: :math:`(1 - (a/b + 1)/2, (c/b + 1)/2)`;
      :math:`+z`: :math:`((a/c + 1)/2, (b/c + 1)/2)`;
      :math:`-z`: :math:`((a/c + 1)/2, 1 - (b/c + 1)/2)`;
    - texel fetch on a face of :math:`S_u \times S_v` texels: :math:`u \to |u|`,
      :math:`i_0 = \lfloor S_u u \rfloor`, :math:`i_1 = i_0 + 1`, weight
      :math:`S_u u - i_0` (texel :math:`i` sits at :math:`u = i/S_u`, no half-texel
      offset), indices clamped to :math:`[0, S_u - 1]`, bilinear; the same for
      :math:`v`. Column :math:`i` runs left to right; row :math:`v = 0` is the first
      row the tutorial's loader reads, the first STORED row of the TGA, which is the
      BOTTOM row as a viewer shows a bottom-left-origin TGA. (Mitsuba's TGA reader
      flips such files to top-down; the plugin undoes that. A top-left-origin TGA is
      read in stored order too, as the tutorial does. Other formats have no stored
      bottom-up order: their bottom row is :math:`v = 0`.) Texel values are the stored
      values normalised to [0, 1] (bytes / 255), without Mitsuba's sRGB decoding;
    - the value is decoded (``srgb``, then ``exposed``), divided by ``exposure`` and
      multiplied by ``scale``.

    As a light (``mode=light``), a direction is sampled by picking a texel cell (the
    square between four neighbouring texels) with probability proportional to the
    mean absolute luminance of its four corner texels (decoded) times its solid
    angle, then a point uniformly in the cell. ``sample_direction``, ``pdf_direction``
    and ``eval`` are consistent (checked with ``mitsuba.chi2``).

    **Scene bounds**: Python plugins cannot receive Mitsuba's ``set_scene`` call, so the
    emitter does not know the scene's bounding sphere when Mitsuba loads it. It assumes
    the scene lies within a sphere of radius 1e5 around the origin (shadow rays toward
    the environment are ``2 max(1e5, |p|)`` long; ``sample_ray`` starts rays on that
    sphere) until ``attach_scene(scene)`` is called, which ``codermind render`` and
    ``codermind.scene.load_scene`` do after loading.

    ``mi.traverse`` exposes ``data``, the texels of the six faces as a tensor of shape
    (6, :math:`S_v`, :math:`S_u`, 3) in the order of FACES (up, down, right, left,
    forward, backward), rows from :math:`v = 0`, before the decodes; and ``scale``, both
    differentiable (the sampling distribution is rebuilt, detached, when ``data``
    changes); ``exposure`` and ``to_world`` (non-differentiable; a new ``to_world`` must
    be a rotation or reflection too, as for the built-in :monosp:`envmap` it turns the
    whole map, importance sampling included). JIT variants only.

    RGB and monochromatic variants only.

    .. tabs::

        .. code-tab:: xml

            <emitter type="cubemap">
                <string name="mode" value="background"/>
                <string name="up" value="alpup.tga"/>
                <string name="down" value="alpdown.tga"/>
                <string name="right" value="alpright.tga"/>
                <string name="left" value="alpleft.tga"/>
                <string name="forward" value="alpforward.tga"/>
                <string name="backward" value="alpback.tga"/>
                <boolean name="srgb" value="true"/>
                <boolean name="exposed" value="true"/>
            </emitter>
    """

    MODES = ("light", "background")

    def __init__(self, props: mi.Properties):
        self.mode = str(props.get("mode", "light"))
        if self.mode not in self.MODES:
            raise ValueError(f"cubemap: 'mode' must be 'light' or 'background', got "
                             f"{self.mode!r}")
        if self.mode == "background" and "sampling_weight" not in props:
            props["sampling_weight"] = 0.0
        super().__init__(props)
        if mi.is_spectral:
            raise ValueError("cubemap: spectral variants are not supported (use an RGB or "
                             "monochromatic variant)")
        if self.mode == "background" and self.sampling_weight() != 0.0:
            mi.Log(mi.LogLevel.Debug, "cubemap: background mode with a nonzero "
                   "sampling_weight: light samples that pick it are wasted")
        self.srgb = flag(props, "cubemap", "srgb", False)
        self.exposed = flag(props, "cubemap", "exposed", False)
        # kept as float32, as mi.traverse hands them out (their own values written back then
        # change nothing; _decode divides in float32 either way)
        self.exposure = float32(read_float(props, "cubemap", "exposure", 1.0, lo=0.0,
                                           open_lo=True))
        self.scale = float32(read_float(props, "cubemap", "scale", 1.0))
        if not abs(self.scale / self.exposure) <= FLOAT32_MAX:
            raise ValueError(f"cubemap: 'scale' / 'exposure' = {self.scale / self.exposure:g} "
                             f"is beyond float32")
        self._set_orientation(np.array(self.world_transform().matrix,
                                       dtype=np.float64).reshape(4, 4))

        faces = load_faces(props)                     # (6, H, W, 3), row 0 = v = 0
        self.names = [name for name, _ in faces]
        texels = np.stack([pixels for _, pixels in faces])
        self.res = mi.ScalarVector2u(texels.shape[2], texels.shape[1])   # (S_u, S_v)
        if mi.is_monochromatic:
            texels = texels @ np.array([0.212671, 0.715160, 0.072169])
            texels = np.repeat(texels[..., None], 3, axis=-1)
        texels = np.ascontiguousarray(texels, dtype=np.float32)
        # JIT variants gather from a Dr.Jit array; scalar variants index numpy rows.
        if dr.is_jit_v(mi.Float):       # RGBx: one 4-wide packet gather per texel
            self.data = mi.Float(np.pad(texels.reshape(-1, 3), ((0, 0), (0, 1))).ravel())
        else:
            self.data = texels.reshape(-1, 3)

        self.bsphere_center = mi.Point3f(0.0)
        self.bsphere_radius = mi.Float(DEFAULT_SCENE_RADIUS)
        if self.mode == "light":
            self.distr = mi.DiscreteDistribution2D(self._cell_weights(texels))
        self.m_flags = mi.EmitterFlags.Infinite | mi.EmitterFlags.SpatiallyVarying
        dr.make_opaque(self.bsphere_center, self.bsphere_radius)
        if dr.is_jit_v(mi.Float):
            dr.make_opaque(self.data)

    # -- radiance ----------------------------------------------------------------------

    def _decode(self, c):
        """The tutorial's decodes, for Dr.Jit colours or numpy arrays."""
        np_mode = isinstance(c, np.ndarray)
        if self.srgb:
            c = np.power(c, 2.2) if np_mode else dr.power(c, 2.2)
        if self.exposed:
            c = -np.log(1.001 - c) if np_mode else -dr.log(1.001 - c)
        if np_mode:
            return c * (float(self.scale) / self.exposure)
        return c * (self.scale / mi.Float(self.exposure))

    def lookup(self, d: mi.Vector3f, active: mi.Bool = True) -> mi.Color3f:
        """Radiance arriving from local direction ``d`` (need not be normalised); none from
        a direction that is not finite."""
        finite, d = _finite(d)
        face, u, v = face_uv(d)
        w, h = int(self.res.x), int(self.res.y)
        x, y = dr.abs(u) * w, dr.abs(v) * h
        i0, j0 = mi.Int32(x), mi.Int32(y)
        fx, fy = x - mi.Float(i0), y - mi.Float(j0)
        i1 = dr.clip(i0 + 1, 0, w - 1)
        j1 = dr.clip(j0 + 1, 0, h - 1)
        i0, j0 = dr.clip(i0, 0, w - 1), dr.clip(j0, 0, h - 1)
        row0, row1 = (face * h + j0) * w, (face * h + j1) * w
        c00, c10 = self._texel(row0 + i0, active), self._texel(row0 + i1, active)
        c01, c11 = self._texel(row1 + i0, active), self._texel(row1 + i1, active)
        c = dr.lerp(dr.lerp(c00, c10, fx), dr.lerp(c01, c11, fx), fy)
        return dr.select(finite, self._decode(c), 0.0)

    def _texel(self, index: mi.Int32, active: mi.Bool) -> mi.Color3f:
        if dr.is_jit_v(mi.Float):
            texel = dr.gather(mi.Vector4f, self.data, mi.UInt32(index), active)
            return mi.Color3f(texel.x, texel.y, texel.z)
        return mi.Color3f(*(float(x) for x in self.data[int(index)]))

    def _spectrum(self, c: mi.Color3f) -> mi.Spectrum:
        if mi.is_monochromatic:
            return mi.Spectrum(c.x)
        return mi.Spectrum(c)

    def _set_orientation(self, matrix: np.ndarray) -> None:
        """The cube's orientation from a 4x4 ``to_world`` (its translation is ignored):
        ``to_env`` takes local directions to the world, ``to_local`` back."""
        linear = matrix[:3, :3]
        if not (np.isfinite(linear).all() and
                np.allclose(linear.T @ linear, np.eye(3), atol=1e-4)):
            raise ValueError("cubemap: 'to_world' must be a rotation or reflection (no scale)")
        rotation = np.eye(4)
        rotation[:3, :3] = linear
        self.orientation = rotation
        self.to_env = mi.Transform4f(mi.ScalarMatrix4f(rotation))
        self.to_local = mi.Transform4f(mi.ScalarMatrix4f(np.ascontiguousarray(rotation.T)))

    def _to_local(self, d: mi.Vector3f) -> mi.Vector3f:
        return self.to_local @ mi.Vector3f(d)

    def eval(self, si: mi.SurfaceInteraction3f, active: mi.Bool = True) -> mi.Spectrum:
        return self._spectrum(self.lookup(self._to_local(-si.wi), active)) & active

    def eval_direction(self, it: mi.Interaction3f, ds: mi.DirectionSample3f,
                       active: mi.Bool = True) -> mi.Spectrum:
        return self._spectrum(self.lookup(self._to_local(ds.d), active)) & active

    # -- sampling ----------------------------------------------------------------------

    def _cell_weights(self, texels: np.ndarray) -> np.ndarray:
        """Sampling weight of each texel cell, rows of all faces stacked: (6 H, W)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            decoded = self._decode(texels.astype(np.float64))
        bad = ~np.isfinite(decoded).all(axis=-1)
        if bad.any():
            mi.Log(mi.LogLevel.Warn, f"cubemap: the decodes give non-finite radiance for "
                   f"{int(bad.sum())} texels ('exposed' needs values below 1.001, 'srgb' "
                   f"values >= 0); they are never sampled")
        lum = np.abs(np.where(bad[..., None], 0.0, decoded)) @ np.array([0.212671, 0.715160, 0.072169])
        nxt = lambda a, axis: np.concatenate([np.delete(a, 0, axis), np.take(a, [-1], axis)], axis)
        corners = (lum + nxt(lum, 2) + nxt(lum, 1) + nxt(nxt(lum, 1), 2)) / 4
        h, w = lum.shape[1:]
        s = np.linspace(-1.0, 1.0, w + 1)[None, :]
        t = np.linspace(-1.0, 1.0, h + 1)[:, None]
        f = np.arctan2(s * t, np.sqrt(1.0 + s * s + t * t))   # solid angle of [0,s]x[0,t]
        solid_angle = f[1:, 1:] - f[1:, :-1] - f[:-1, 1:] + f[:-1, :-1]
        weights = corners * solid_angle
        if not weights.sum() > 0:
            weights = np.broadcast_to(solid_angle, lum.shape)
        # scale-free: a dim map (radiance near 1e-38) would underflow in float32
        weights = weights / weights.max()
        return np.ascontiguousarray(weights.reshape(6 * h, w), dtype=np.float32)

    def _sample_local(self, sample: mi.Point2f, active: mi.Bool
                      ) -> tuple[mi.Vector3f, mi.Float]:
        """A local unit direction and its solid-angle pdf."""
        index, prob, re = self.distr.sample(sample, active)
        w, h = int(self.res.x), int(self.res.y)
        face = index.y // h
        u = (mi.Float(index.x) + re.x) / w
        v = (mi.Float(index.y - face * h) + re.y) / h
        d = face_direction(mi.Int32(face), u, v)
        length = dr.norm(d)
        pdf = prob * (0.25 * w * h) * length * length * length
        return d / length, pdf

    def _pdf_local(self, d: mi.Vector3f, active: mi.Bool) -> mi.Float:
        finite, d = _finite(d)
        face, u, v = face_uv(d)
        w, h = int(self.res.x), int(self.res.y)
        i = dr.clip(mi.Int32(dr.abs(u) * w), 0, w - 1)
        j = dr.clip(mi.Int32(dr.abs(v) * h), 0, h - 1)
        prob = self.distr.pdf(mi.Point2u(mi.UInt32(i), mi.UInt32(face * h + j)), active)
        major = dr.max(dr.abs(d)) * dr.rcp(dr.norm(d))
        return dr.select(finite, prob * (0.25 * w * h) * dr.rcp(major * major * major), 0.0)

    def sample_direction(self, it: mi.Interaction3f, sample: mi.Point2f,
                         active: mi.Bool = True) -> tuple[mi.DirectionSample3f, mi.Spectrum]:
        ds = zero_direction_sample()
        ds.time = it.time
        ds.delta = mi.Bool(False)
        ds.emitter = emitter_ptr(self)
        if self.mode == "background":
            ds.pdf = mi.Float(0.0)
            return ds, mi.Spectrum(0.0)
        local, pdf = self._sample_local(sample, active)
        d = self.to_env @ local
        radius = dr.maximum(self.bsphere_radius, dr.norm(it.p - self.bsphere_center))
        ds.dist = 2.0 * radius
        ds.p = it.p + d * ds.dist
        ds.n = -d
        ds.uv = mi.Point2f(0.0)
        ds.d = d
        active &= pdf > 0.0
        ds.pdf = dr.select(active, pdf, 0.0)
        # From the world direction, as eval_direction(ds) does, so that weight * pdf is
        # that value to the last bit (the exposed decode magnifies rounding up to 1000x).
        value = self._spectrum(self.lookup(self._to_local(d), active))
        weight = dr.select(active, value / dr.select(active, pdf, 1.0), 0.0)
        return ds, mi.Spectrum(weight)

    def pdf_direction(self, it: mi.Interaction3f, ds: mi.DirectionSample3f,
                      active: mi.Bool = True) -> mi.Float:
        if self.mode == "background":
            return mi.Float(0.0)
        return self._pdf_local(self._to_local(ds.d), active)

    def sample_ray(self, time: mi.Float, sample1: mi.Float, sample2: mi.Point2f,
                   sample3: mi.Point2f, active: mi.Bool = True) -> tuple[mi.Ray3f, mi.Spectrum]:
        """A ray from the scene's bounding sphere towards the scene (light tracing)."""
        if self.mode == "background":
            return mi.Ray3f(mi.Point3f(0.0), mi.Vector3f(0.0, 0.0, 1.0), time,
                            _no_wavelengths()), mi.Spectrum(0.0)
        local, pdf = self._sample_local(sample3, active)
        to_env = self.to_env @ local
        offset = mi.warp.square_to_uniform_disk_concentric(sample2)
        perpendicular = mi.Frame3f(to_env).to_world(mi.Vector3f(offset.x, offset.y, 0.0))
        origin = self.bsphere_center + (perpendicular + to_env) * self.bsphere_radius
        active &= pdf > 0.0
        value = self._spectrum(self.lookup(local, active))
        area = dr.pi * dr.square(self.bsphere_radius)
        weight = dr.select(active, value * area / dr.select(active, pdf, 1.0), 0.0)
        return mi.Ray3f(origin, -to_env, time, _no_wavelengths()), mi.Spectrum(weight)

    def sample_wavelengths(self, si: mi.SurfaceInteraction3f, sample: mi.Float,
                           active: mi.Bool = True) -> tuple[mi.Wavelength, mi.Spectrum]:
        return _no_wavelengths(), mi.Spectrum(1.0)

    def sample_position(self, time: mi.Float, sample: mi.Point2f,
                        active: mi.Bool = True) -> tuple[mi.PositionSample3f, mi.Float]:
        return zero_position_sample(), mi.Float(0.0)

    def pdf_position(self, ps: mi.PositionSample3f, active: mi.Bool = True) -> mi.Float:
        return mi.Float(0.0)

    # -- scene ---------------------------------------------------------------------------

    def attach_scene(self, scene: mi.Scene) -> None:
        """Take the scene's bounding sphere (what Mitsuba's ``set_scene`` does for the
        built-in environment emitters; Python plugins never receive that call)."""
        bbox = scene.bbox()
        if bbox.valid():
            sphere = bbox.bounding_sphere()
            eps = float(mi.math.RayEpsilon)
            self.bsphere_center = mi.Point3f(*[float(c) for c in sphere.center])
            self.bsphere_radius = mi.Float(max(eps, float(sphere.radius) * (1 + eps)))
        else:
            self.bsphere_center = mi.Point3f(0.0)
            self.bsphere_radius = mi.Float(float(mi.math.RayEpsilon))
        dr.make_opaque(self.bsphere_center, self.bsphere_radius)

    def bbox(self) -> mi.ScalarBoundingBox3f:
        return mi.ScalarBoundingBox3f()

    def _texel_tensor(self) -> mi.TensorXf:
        w, h = int(self.res.x), int(self.res.y)
        rgbx = np.array(self.data, dtype=np.float32).reshape(6, h, w, 4)
        return mi.TensorXf(np.ascontiguousarray(rgbx[..., :3]))

    def traverse(self, callback: mi.TraversalCallback) -> None:
        super().traverse(callback)
        if not dr.is_jit_v(mi.Float):
            return
        callback.put("data", exposed(self, "data", self._texel_tensor),
                     mi.ParamFlags.Differentiable | mi.ParamFlags.Discontinuous)
        callback.put("scale", exposed(self, "scale"), mi.ParamFlags.Differentiable)
        callback.put("exposure", exposed(self, "exposure"), mi.ParamFlags.NonDifferentiable)
        callback.put("to_world", exposed(self, "to_world", lambda: mi.Transform4f(
            mi.ScalarMatrix4f(self.orientation))), mi.ParamFlags.NonDifferentiable)

    def parameters_changed(self, keys: list[str]) -> None:
        super().parameters_changed(keys)
        if not dr.is_jit_v(mi.Float):
            return
        if not keys or "scale" in keys:
            take_float(self, "cubemap", "scale", keep_array=True)
        if not keys or "exposure" in keys:
            take_float(self, "cubemap", "exposure", lo=0.0, open_lo=True)
        if not keys or "to_world" in keys:
            self._set_orientation(np.array(scalar_matrix(exposed(self, "to_world")),
                                           dtype=np.float64).reshape(4, 4))
        if not keys or "data" in keys:
            tensor = exposed(self, "data")
            shape = tuple(tensor.shape)
            if len(shape) != 4 or shape[0] != 6 or shape[3] != 3:
                raise ValueError(f"cubemap: 'data' must have shape (6, height, width, 3), "
                                 f"got {shape}")
            self.res = mi.ScalarVector2u(shape[2], shape[1])
            # RGB -> RGBx rows by a gather, which keeps the texels' gradients
            j = dr.arange(mi.UInt32, 4 * shape[0] * shape[1] * shape[2])
            channel = j % 4
            self.data = dr.gather(mi.Float, tensor.array, (j // 4) * 3 + channel, channel < 3)
            if self.mode == "light":
                texels = np.array(dr.detach(tensor), dtype=np.float64)
                scale = self.scale
                self.scale = scalar(scale)        # the weights are computed in numpy
                try:
                    self.distr = mi.DiscreteDistribution2D(self._cell_weights(texels))
                finally:
                    self.scale = scale

    def to_string(self) -> str:
        return (f"CubeMap[\n  mode = {self.mode},\n  faces = {self.names},\n"
                f"  resolution = {self.res},\n  srgb = {self.srgb},\n"
                f"  exposed = {self.exposed},\n  exposure = {self.exposure},\n"
                f"  scale = {self.scale}\n]")


def _no_wavelengths():
    """The (empty) wavelength record of RGB and monochromatic variants."""
    return dr.zeros(type(mi.Ray3f().wavelengths))


def _finite(d: mi.Vector3f) -> tuple[mi.Bool, mi.Vector3f]:
    """Whether ``d`` is finite, and ``d`` with +z in its place where it is not (a NaN would
    become a texel index: a ValueError in scalar variants, any texel in JIT ones)."""
    finite = dr.isfinite(d.x) & dr.isfinite(d.y) & dr.isfinite(d.z)
    return finite, dr.select(finite, d, mi.Vector3f(0.0, 0.0, 1.0))


def face_uv(d: mi.Vector3f) -> tuple[mi.Int32, mi.Float, mi.Float]:
    """Face index (in ``FACES`` order) and the tutorial's (u, v) for direction d."""
    a, b, c = d.x, d.y, d.z
    ax, ay, az = dr.abs(a), dr.abs(b), dr.abs(c)
    # Written without mask negation, which scalar variants (Python bools) lack.
    is_x = (ax >= ay) & (ax >= az)
    is_y = (ay >= az) & (ay > ax)
    is_z = (az > ax) & (az > ay)
    m = dr.select(is_x, a, dr.select(is_y, b, c))
    p = dr.select(is_x, c, a)
    q = dr.select(is_x, b, dr.select(is_y, c, b))
    positive, negative = m > 0, m <= 0
    m = dr.select(m == 0, 1.0, m)        # the zero vector: any face, no division by 0
    big_u, big_v = (p / m + 1.0) / 2.0, (q / m + 1.0) / 2.0
    flip_u = is_x | (is_y & negative)
    flip_v = (is_x & negative) | (is_y & positive) | (is_z & negative)
    u = dr.select(flip_u, 1.0 - big_u, big_u)
    v = dr.select(flip_v, 1.0 - big_v, big_v)
    axis = dr.select(is_x, 2, dr.select(is_y, 0, 4))
    face = mi.Int32(axis) + dr.select(positive, 0, 1)
    return face, u, v


def face_direction(face: mi.Int32, u: mi.Float, v: mi.Float) -> mi.Vector3f:
    """Inverse of :func:`face_uv`: the point of the face's unit-distance plane at (u, v)."""
    s, t = 2.0 * u - 1.0, 2.0 * v - 1.0
    one = mi.Float(1.0)
    x = dr.select(face == 2, one, dr.select(face == 3, -one, dr.select(face == 5, -s, s)))
    y = dr.select(face == 0, one, dr.select(face == 1, -one, t))
    z = dr.select(face == 2, -s, dr.select(face == 3, s, dr.select(
        face == 4, one, dr.select(face == 5, -one, -t))))
    return mi.Vector3f(x, y, z)


def load_faces(props: mi.Properties) -> list[tuple[str, np.ndarray]]:
    """The six faces as float64 RGB arrays (H, W, 3) whose row 0 is the tutorial's v = 0."""
    missing = [name for name in FACES if name not in props]
    if missing:
        raise ValueError(f"cubemap: missing face parameter(s) {', '.join(map(repr, missing))} "
                         f"(need all of {', '.join(FACES)})")
    faces = []
    for name in FACES:
        value = props.get(name)
        if isinstance(value, mi.Bitmap):
            faces.append((f"<Bitmap for '{name}'>", _bitmap_rgb(value)[::-1]))
        else:
            faces.append(_read_face(name, str(value)))
    up_label, up = faces[0]
    for (label, pixels), name in zip(faces, FACES):
        if pixels.shape != up.shape:
            raise ValueError(f"cubemap: face '{name}' ({label}) is {pixels.shape[1]}x"
                             f"{pixels.shape[0]} but 'up' ({up_label}) is {up.shape[1]}x"
                             f"{up.shape[0]}: all faces must have the size of 'up'")
    return faces


def _bitmap_rgb(bitmap: mi.Bitmap) -> np.ndarray:
    """Stored values normalised to [0, 1] (no sRGB decoding), rows top to bottom."""
    rgb = bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32,
                         bitmap.srgb_gamma())
    return np.array(rgb, dtype=np.float64).reshape(rgb.height(), rgb.width(), 3)


def _read_face(name: str, filename: str) -> tuple[str, np.ndarray]:
    """Face ``name`` from ``filename`` (resolved like Mitsuba's own files), rows ordered
    so that the tutorial's v = 0 comes first."""
    path = Path(str(mi.file_resolver().resolve(filename)))
    if not path.is_file():
        raise ValueError(f"cubemap: face '{name}': file '{filename}' not found")
    is_tga = path.suffix.lower() == ".tga"
    if is_tga:
        _check_tga_size(name, filename, path)
    try:
        pixels = _bitmap_rgb(mi.Bitmap(str(path)))
    except Exception as e:        # Mitsuba raises RuntimeError with its own prefix
        # Mitsuba recognises only TGAs with the version-2 footer; read plain ones here.
        stored = _read_plain_tga(path) if is_tga else None
        if stored is None:
            lines = str(e).strip().splitlines()
            raise ValueError(f"cubemap: face '{name}': cannot read '{filename}': "
                             f"{lines[-1] if lines else type(e).__name__}") from None
        return str(path), stored
    if is_tga:
        # Mitsuba flips bottom-left-origin TGAs to top-down; the tutorial reads stored order.
        with open(path, "rb") as f:
            header = f.read(18)
        if len(header) == 18 and header[17] & 0x20:     # top-left origin: stored = Mitsuba's
            return str(path), pixels
    return str(path), pixels[::-1]


#: Largest face, in pixels (16384 x 16384). A TGA header may claim 65535 x 65535 (12.9 GB
#: at 24 bits); the claim is checked against this and the file's size before reading.
MAX_FACE_PIXELS = 16384 * 16384


def _check_tga_size(name: str, filename: str, path: Path) -> None:
    with open(path, "rb") as f:
        header = f.read(18)
        size = os.fstat(f.fileno()).st_size
    if len(header) < 18:
        return                                      # Mitsuba's own error follows
    width, height = header[12] | header[13] << 8, header[14] | header[15] << 8
    if width * height > MAX_FACE_PIXELS:
        raise ValueError(f"cubemap: face '{name}': '{filename}' claims {width}x{height} "
                         f"pixels, more than a face may have (16384 x 16384)")
    channels = {(2, 24): 3, (2, 32): 4, (3, 8): 1}.get((header[2], header[16]))
    if channels and size < 18 + header[0] + width * height * channels:
        raise ValueError(f"cubemap: face '{name}': '{filename}' is truncated (its header "
                         f"says {width}x{height}, the file has {size} bytes)")


def _read_plain_tga(path: Path) -> np.ndarray | None:
    """An uncompressed true-colour (24/32 bit) or grey (8 bit) TGA in stored row order,
    as the tutorial's loader reads it; None if the file is not one."""
    data = path.read_bytes()
    if len(data) < 18:
        return None
    kind, width, height, bits = data[2], data[12] | data[13] << 8, data[14] | data[15] << 8, data[16]
    channels = {(2, 24): 3, (2, 32): 4, (3, 8): 1}.get((kind, bits))
    start = 18 + data[0]
    if channels is None or width == 0 or len(data) < start + width * height * channels:
        return None
    pixels = np.frombuffer(data, np.uint8, width * height * channels, start)
    pixels = pixels.reshape(height, width, channels) / 255.0
    if channels == 1:
        return np.repeat(pixels, 3, axis=2)
    return pixels[..., 2::-1]                 # B, G, R(, A) -> R, G, B


mi.register_emitter("cubemap", lambda props, cls=CubeMap: cls(props))
