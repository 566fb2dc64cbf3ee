from __future__ import annotations  # Delayed parsing of type annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np

from codermind.exposed import exposed, scalar, scalar_matrix, take_float
from codermind.params import (FLOAT32_MAX, float32, number, read_clip, read_pixel_offset,
                              to_world_matrix, x_fov)
from codermind.sensors._film import FilmMap, check_rigid, origin_of


class ConicCamera(mi.Sensor):
    r"""
    .. _sensor-conic:

    Thin-lens perspective camera (:monosp:`conic`)
    ----------------------------------------------

    .. pluginparameters::

     * - to_world
       - |transform|
       - Camera-to-world transformation: a rotation or a reflection, and a translation
         (no scale). Camera space is Mitsuba's: it looks along :math:`+z`, :math:`+y` is
         up in the image and :math:`+x` is to the image's LEFT. (Default: identity)

     * - fov, fov_axis
       - |float|, |string|
       - Field of view in degrees, in (0, 180), and the image axis it applies to: ``x``
         (default), ``y``, ``diagonal``, ``smaller``, ``larger`` (as :monosp:`perspective`).

     * - focal_length
       - |string|
       - Alternative to ``fov``: 35 mm equivalent focal length (Default: ``50mm``).

     * - aperture_radius
       - |float|
       - ``disc`` lens only: radius of the lens disc in world units, >= 0, finite, as in
         the built-in :monosp:`thinlens`. 0 gives a pinhole (Default: 0).

     * - aperture
       - |float|
       - Aperture size in world units, >= 0, finite. ``tutorial``: the SIDE of the square
         aperture (the tutorial's ``Dispersion``); ``disc``: the same as
         ``aperture_radius`` (give one of the two). 0 gives a pinhole (Default: 0).

     * - focus_distance
       - |float|
       - Distance at which the image is sharp, >= 0 (> 0 and finite if ``aperture`` > 0).
         ``disc``: of the focal PLANE :math:`z` = focus_distance; ``tutorial``: of the
         focus SPHERE, measured along each un-jittered ray (Default: ``far_clip``).

     * - lens
       - |string|
       - ``disc`` (default): centred disc aperture and focal plane, the model of the
         built-in :monosp:`thinlens`. ``tutorial``: the Codermind tutorial's lens: a square
         aperture :math:`[0, D]^2` off the optical centre, extending towards the image's
         right and top edges, with the focus sphere (:math:`u_1` = ``sample3.x`` along the
         image's right, :math:`u_2` = ``sample3.y`` along its top).

     * - near_clip, far_clip
       - |float|
       - Clip distances, 0 <= near < far (Default: 0.01, 10000). ``disc``: planes
         perpendicular to the view axis, as :monosp:`thinlens` (the ray starts on the near
         plane). ``tutorial``: distances along each ray (the ray starts ``near_clip``
         from the lens and is ``far_clip - near_clip`` long).

     * - pixel_offset_x, pixel_offset_y
       - |float|
       - Optional fixed position of every film sample inside its film pixel, in pixels
         from the pixel's top-left corner (x right, y down, as film rows), each in
         [0, 1]. Both or neither. Without them the integrator's random jitter is used.
         Meant for a ``box`` reconstruction filter. (0, 1) is the pixel's bottom-left
         corner: with a film of twice the tutorial's resolution it reproduces the
         tutorial's 2x2 sub-sample grid (see below). The pixel is
         ``floor(sample2 * size)``: with a jittering sampler about 5e-5 of the samples
         (those within a float ulp of the pixel's edge) take the neighbour's point; a
         sampler without jitter (``stratified``, ``jitter`` false) has none.

    With ``lens`` = ``tutorial``, ``sample3`` = (0, 0) gives the un-jittered ray from the
    optical centre (the tutorial's auto-exposure probes); with ``disc``, (0.5, 0.5). A
    ``sample2`` outside [0, 1]^2 extrapolates (the probes reach above the image), unless
    a pixel offset is set, which snaps every position to its pixel's point.

    ``mi.traverse`` exposes (all non-differentiable, as for :monosp:`thinlens`) ``x_fov``,
    ``to_world``, ``aperture_radius`` (``disc``) or ``aperture`` (``tutorial``),
    ``focus_distance``, ``near_clip`` and ``far_clip``; ``parameters_changed`` checks them
    as the constructor does. The projective integrators (``direct_projective``,
    ``prb_projective``) support only Mitsuba's :monosp:`perspective` camera: with this one
    they stop with an error saying so.

    A Python port of Mitsuba's perspective camera with a thin lens. ``sample_ray`` and
    ``sample_ray_differential`` are implemented (the camera cannot be sampled from the
    scene side: no ``sample_direction``, so light tracing is not supported).

    **The tutorial's page-4 camera** (image :math:`W \times H`, ``FOV``, ``ClearPoint``,
    ``Dispersion``): the tutorial's world is left-handed (x right, y up, z into the
    screen), camera space is Mitsuba's (x left), so ``to_world`` mirrors x and moves the
    eye to :math:`(W/2, H/2, 0)`; ``fov`` is the tutorial's horizontal FOV. Its 2x2
    sub-sample grid at :math:`(x + \{0, \frac12\}, y + \{0, \frac12\})` is a film of
    :math:`2W \times 2H` with ``pixel_offset`` (0, 1) and a box filter.

    .. tabs::

        .. code-tab:: xml

            <sensor type="conic">
                <string name="lens" value="tutorial"/>
                <float name="fov" value="90"/>
                <float name="focus_distance" value="450"/>
                <float name="aperture" value="10"/>
                <float name="near_clip" value="0"/>
                <float name="far_clip" value="2000"/>
                <float name="pixel_offset_x" value="0"/>
                <float name="pixel_offset_y" value="1"/>
                <transform name="to_world">
                    <scale x="-1"/>
                    <translate x="320" y="240" z="0"/>
                </transform>
                <film type="hdrfilm">
                    <integer name="width" value="1280"/>
                    <integer name="height" value="960"/>
                    <rfilter type="box"/>
                </film>
            </sensor>
    """

    LENSES = ("disc", "tutorial")

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        matrix = to_world_matrix(props)
        check_rigid(matrix, "conic")
        film = self.film()
        size = film.size()
        self.x_fov = x_fov(props, size[0] / size[1], "conic")
        self.lens = str(props.get("lens", "disc"))
        if self.lens not in self.LENSES:
            raise ValueError(f"conic: 'lens' must be 'disc' or 'tutorial', got {self.lens!r}")
        self.near_clip, self.far_clip = read_clip(props, "conic")
        if "aperture_radius" in props and ("aperture" in props or self.lens != "disc"):
            raise ValueError("conic: 'aperture_radius' (the disc lens's radius, as in "
                             "thinlens) cannot be combined with 'aperture' or lens 'tutorial'")
        self.aperture = number(props, "conic", "aperture_radius" if "aperture_radius" in props
                               else "aperture", 0.0)
        self.focus_distance = number(props, "conic", "focus_distance", self.far_clip)
        if not 0.0 <= self.aperture <= FLOAT32_MAX:
            raise ValueError(f"conic: 'aperture' must be >= 0 and finite (in float32), got "
                             f"{self.aperture:g}")
        if not self.focus_distance >= 0.0:
            raise ValueError(f"conic: 'focus_distance' must be >= 0, got "
                             f"{self.focus_distance:g}")
        if self.aperture > 0.0 and self.focus_distance == 0.0:
            raise ValueError("conic: 'focus_distance' must be > 0 when 'aperture' > 0")
        if self.aperture > 0.0 and not self.focus_distance <= FLOAT32_MAX:
            default = "" if "focus_distance" in props else " (it defaults to 'far_clip')"
            raise ValueError(f"conic: 'focus_distance' must be finite (in float32) when "
                             f"'aperture' > 0, got {self.focus_distance:g}{default}")
        # kept as float32, as mi.traverse hands them out (its own values written back then
        # change nothing)
        self.x_fov, self.aperture, self.focus_distance, self.near_clip, self.far_clip = map(
            float32, (self.x_fov, self.aperture, self.focus_distance, self.near_clip,
                      self.far_clip))
        # Rays are aimed on a scale where neither the aperture nor the focus point overflows.
        self.lens_scale = max(self.aperture, self.focus_distance) if self.aperture > 0 else 1.0
        self.film_map = FilmMap(film, read_pixel_offset(props, "conic"), "conic")
        # Near-plane direction for a whole-film position s in [0, 1]^2:
        # ((1 - 2 s.x) tan_x, (1 - 2 s.y) tan_y, 1) (x left, y up).
        tan_x = math.tan(math.radians(0.5 * self.x_fov))
        self.tan_half = mi.ScalarVector2f(tan_x, tan_x * size[1] / size[0])
        self.pixel_step = mi.ScalarVector2f(2.0 / size[0], 2.0 / size[1]) * self.tan_half
        self.m_needs_sample_3 = self.aperture > 0.0

    def _local_direction(self, sample2: mi.Point2f) -> mi.Vector3f:
        s = self.film_map(sample2)
        xy = (1.0 - 2.0 * s) * self.tan_half
        return mi.Vector3f(xy.x, xy.y, 1.0)

    def _lens_offset(self, sample3: mi.Point2f) -> mi.Vector3f:
        """Aperture point of an aperture of size 1 (the lens centre is the origin)."""
        if self.lens == "disc":
            p = mi.warp.square_to_uniform_disk_concentric(sample3)
            return mi.Vector3f(p.x, p.y, 0.0)
        # Towards the image's right (camera -x) and top (camera +y).
        return mi.Vector3f(-sample3.x, sample3.y, 0.0)

    def _aim(self, offset: mi.Vector3f, q: mi.Vector3f) -> mi.Vector3f:
        """Unit direction from the aperture point ``aperture * offset`` to the focus point
        of near-plane direction ``q``. Both points are divided by ``lens_scale`` first, so
        that no aperture or focus distance overflows float32; a pinhole just follows q."""
        if self.aperture == 0.0:
            return dr.normalize(q)
        f = self.focus_distance / self.lens_scale
        focus = q * f if self.lens == "disc" else dr.normalize(q) * f
        v = focus - offset * (self.aperture / self.lens_scale)
        # divided by its largest component first: one of the two terms may be tiny (its
        # squared norm would underflow to 0 at the lens centre, where the other one is 0)
        m = dr.maximum(dr.maximum(dr.abs(v.x), dr.abs(v.y)), dr.abs(v.z))
        return dr.normalize(dr.select(m > 0, v / dr.select(m > 0, m, 1.0), q))

    def _ray(self, offset: mi.Vector3f, q: mi.Vector3f) -> tuple[mi.Point3f, mi.Vector3f, mi.Float]:
        """World origin, world direction and length of the ray from the aperture point
        ``aperture * offset`` through the focus point of near-plane direction ``q``, clipped."""
        d = self._aim(offset, q)
        to_world = self.world_transform()
        o = to_world @ mi.Point3f(offset * self.aperture)
        d_world = to_world @ d
        if self.lens == "disc":
            inv_z = dr.rcp(d.z)
            near_t, far_t = self.near_clip * inv_z, self.far_clip * inv_z
        else:
            near_t, far_t = mi.Float(self.near_clip), mi.Float(self.far_clip)
        start = o + d_world * near_t
        # A ray nearly parallel to the lens (aperture / focus_distance near the float32
        # range) meets the near plane beyond float32: it stays on its aperture point, empty.
        ok = dr.all(dr.isfinite(start))
        return dr.select(ok, start, o), d_world, dr.select(ok, far_t - near_t, 0.0)

    def sample_ray(self, time: mi.Float, sample1: mi.Float, sample2: mi.Point2f,
                   sample3: mi.Point2f, active: mi.Bool = True) -> tuple[mi.Ray3f, mi.Spectrum]:
        wavelengths, weight = self.sample_wavelengths(
            dr.zeros(mi.SurfaceInteraction3f), sample1, active)
        o, d, maxt = self._ray(self._lens_offset(sample3), self._local_direction(sample2))
        ray = mi.Ray3f(o, d, time, wavelengths)
        ray.maxt = maxt
        return ray, weight

    def sample_ray_differential(self, time: mi.Float, sample1: mi.Float, sample2: mi.Point2f,
                                sample3: mi.Point2f, active: mi.Bool = True
                                ) -> tuple[mi.RayDifferential3f, mi.Spectrum]:
        wavelengths, weight = self.sample_wavelengths(
            dr.zeros(mi.SurfaceInteraction3f), sample1, active)
        offset = self._lens_offset(sample3)
        q = self._local_direction(sample2)
        o, d, maxt = self._ray(offset, q)
        # One pixel right (camera -x) and one pixel down (camera -y).
        to_world = self.world_transform()
        q_x = mi.Vector3f(q.x - self.pixel_step.x, q.y, q.z)
        q_y = mi.Vector3f(q.x, q.y - self.pixel_step.y, q.z)
        ray = mi.RayDifferential3f(mi.Ray3f(o, d, time, wavelengths))
        ray.maxt = maxt
        ray.o_x = ray.o_y = o
        ray.d_x = to_world @ self._aim(offset, q_x)
        ray.d_y = to_world @ self._aim(offset, q_y)
        ray.has_differentials = True
        return ray, weight

    def bbox(self) -> mi.ScalarBoundingBox3f:
        return mi.ScalarBoundingBox3f(origin_of(self.world_transform()))

    def _aperture_key(self) -> str:
        return "aperture_radius" if self.lens == "disc" else "aperture"

    def traverse(self, callback: mi.TraversalCallback) -> None:
        mi.Sensor.traverse(self, callback)
        nd = mi.ParamFlags.NonDifferentiable
        callback.put("x_fov", exposed(self, "x_fov"), nd)
        callback.put("to_world", self.m_to_world, nd)
        callback.put(self._aperture_key(),
                     exposed(self, self._aperture_key(), lambda: mi.Float(self.aperture)), nd)
        for name in ("focus_distance", "near_clip", "far_clip"):
            callback.put(name, exposed(self, name), nd)

    def parameters_changed(self, keys: list[str]) -> None:
        mi.Sensor.parameters_changed(self, keys)
        x_fov = take_float(self, "conic", "x_fov", lo=0.0, open_lo=True, hi=180.0)
        if x_fov == 180.0:
            raise ValueError("conic: 'x_fov' must be in (0, 180) degrees, got 180")
        for name in ("focus_distance", "near_clip"):
            take_float(self, "conic", name, lo=0.0)
        far = scalar(exposed(self, "far_clip"))
        if not self.near_clip < far:
            raise ValueError(f"conic: need 'near_clip' < 'far_clip', got {self.near_clip:g} "
                             f"and {far:g}")
        self.far_clip = far
        self.aperture = take_float(self, "conic", self._aperture_key(), lo=0.0)
        if self.aperture > 0.0 and self.focus_distance == 0.0:
            raise ValueError("conic: 'focus_distance' must be > 0 when the aperture is > 0")
        check_rigid(np.array(scalar_matrix(self.m_to_world), dtype=np.float64), "conic")
        film = self.film()
        size = film.size()
        self.lens_scale = max(self.aperture, self.focus_distance) if self.aperture > 0 else 1.0
        self.film_map = FilmMap(film, self.film_map.offset, "conic")
        tan_x = math.tan(math.radians(0.5 * self.x_fov))
        self.tan_half = mi.ScalarVector2f(tan_x, tan_x * size[1] / size[0])
        self.pixel_step = mi.ScalarVector2f(2.0 / size[0], 2.0 / size[1]) * self.tan_half
        self.m_needs_sample_3 = self.aperture > 0.0

    def projection_transform(self):
        # Called by Mitsuba's projective integrators, which also require the class name
        # PerspectiveCamera: stop with one line instead of an AttributeError.
        raise RuntimeError("conic: the projective integrators (direct_projective, "
                           "prb_projective) support only Mitsuba's 'perspective' camera; use "
                           "'perspective' (conic with lens 'disc' and no aperture is the same "
                           "camera) or a non-projective integrator such as 'prb'")

    def to_string(self) -> str:
        return (f"ConicCamera[\n  lens = {self.lens},\n  x_fov = {self.x_fov},\n"
                f"  aperture = {self.aperture},\n  focus_distance = {self.focus_distance},\n"
                f"  near_clip = {self.near_clip},\n  far_clip = {self.far_clip},\n"
                f"  pixel_offset = {self.film_map.offset},\n  film = {self.film()},\n"
                f"  to_world = {self.world_transform()}\n]")


mi.register_sensor("conic", lambda props, cls=ConicCamera: cls(props))
