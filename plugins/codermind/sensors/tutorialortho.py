from __future__ import annotations  # Delayed parsing of type annotations

import drjit as dr
import mitsuba as mi

from codermind.exposed import exposed, scalar, take_float
from codermind.params import read_clip, read_pixel_offset
from codermind.sensors._film import FilmMap, origin_of


class TutorialOrthoCamera(mi.Sensor):
    r"""
    .. _sensor-tutorialortho:

    Orthographic camera of the tutorial's pages 1-2 (:monosp:`tutorialortho`)
    ------------------------------------------------------------------------

    .. pluginparameters::

     * - to_world
       - |transform|
       - Camera-to-world transformation, as for the built-in :monosp:`orthographic`:
         the film covers :math:`[-1, 1] \times [-1/a, 1/a]` (:math:`a` = width / height)
         of the camera's :math:`z = 0` plane with :math:`+x` to the image's LEFT and
         :math:`+y` up, rays go along :math:`+z`; scale it to the world's size. A
         negative x scale (a reflection) is allowed. (Default: identity)

     * - near_clip, far_clip
       - |float|
       - The ray starts at camera :math:`z` = ``near_clip`` and is
         ``far_clip - near_clip`` long, 0 <= near < far (Default: 0.01, 10000). Unlike
         the built-in, ``near_clip`` may be 0.

     * - pixel_offset_x, pixel_offset_y
       - |float|
       - Optional fixed position of every film sample inside its film pixel, in pixels
         from the pixel's top-left corner (x right, y down), each in [0, 1]; both or
         neither (Default: the integrator's random jitter). Use a ``box`` filter, and
         for exact positions a sampler without jitter (``stratified``, ``jitter``
         false): with jitter about 5e-5 of the samples take the neighbour's point.

    ``mi.traverse`` exposes ``to_world``, ``near_clip`` and ``far_clip``
    (non-differentiable, as for :monosp:`orthographic`).

    The built-in :monosp:`orthographic` camera (same rays for the same samples) with a
    clip range that may start at 0 and the fixed sample position of :monosp:`conic`.

    **The tutorial's pages 1 and 2** (image :math:`W \times H`): pixel :math:`(x, y)`,
    :math:`y` up, fires a ray from :math:`(x, y, -1000)` along :math:`+z` that ends at
    :math:`t = 2000`. With ``pixel_offset`` (0, 1) (the film pixel's bottom-left corner)
    and ``to_world`` = translate(W/2, H/2, -1000) scale(-W/2, W/2, 1), a W x H film gives
    page 1's rays and a 2W x 2H film page 2's 2x2 sub-sample grid.

    .. tabs::

        .. code-tab:: xml

            <sensor type="tutorialortho">
                <float name="near_clip" value="0"/>
                <float name="far_clip" value="2000"/>
                <float name="pixel_offset_x" value="0"/>
                <float name="pixel_offset_y" value="1"/>
                <transform name="to_world">
                    <scale x="-320" y="320" z="1"/>
                    <translate x="320" y="240" z="-1000"/>
                </transform>
                <film type="hdrfilm">
                    <integer name="width" value="640"/>
                    <integer name="height" value="480"/>
                    <rfilter type="box"/>
                </film>
            </sensor>
    """

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        self.near_clip, self.far_clip = read_clip(props, "tutorialortho")
        film = self.film()
        size = film.size()
        self.film_map = FilmMap(film, read_pixel_offset(props, "tutorialortho"), "tutorialortho")
        self.inv_aspect = size[1] / size[0]
        self.pixel_step = mi.ScalarVector2f(2.0 / size[0], 2.0 * self.inv_aspect / size[1])
        self.m_needs_sample_3 = False

    def _near_point(self, sample2: mi.Point2f) -> mi.Point3f:
        s = self.film_map(sample2)
        return mi.Point3f(1.0 - 2.0 * s.x, (1.0 - 2.0 * s.y) * self.inv_aspect, self.near_clip)

    def sample_ray(self, time: mi.Float, sample1: mi.Float, sample2: mi.Point2f,
                   sample3: mi.Point2f, active: mi.Bool = True) -> tuple[mi.Ray3f, mi.Spectrum]:
        wavelengths, weight = self.sample_wavelengths(
            dr.zeros(mi.SurfaceInteraction3f), sample1, active)
        to_world = self.world_transform()
        ray = mi.Ray3f(to_world @ self._near_point(sample2),
                       dr.normalize(to_world @ mi.Vector3f(0.0, 0.0, 1.0)), time, wavelengths)
        ray.maxt = mi.Float(self.far_clip - self.near_clip)
        return ray, weight

    def sample_ray_differential(self, time: mi.Float, sample1: mi.Float, sample2: mi.Point2f,
                                sample3: mi.Point2f, active: mi.Bool = True
                                ) -> tuple[mi.RayDifferential3f, mi.Spectrum]:
        ray, weight = self.sample_ray(time, sample1, sample2, sample3, active)
        to_world = self.world_transform()
        ray = mi.RayDifferential3f(ray)
        ray.o_x = ray.o + to_world @ mi.Vector3f(-self.pixel_step.x, 0.0, 0.0)
        ray.o_y = ray.o + to_world @ mi.Vector3f(0.0, -self.pixel_step.y, 0.0)
        ray.d_x = ray.d_y = ray.d
        ray.has_differentials = True
        return ray, weight

    def traverse(self, callback: mi.TraversalCallback) -> None:
        mi.Sensor.traverse(self, callback)
        nd = mi.ParamFlags.NonDifferentiable
        callback.put("to_world", self.m_to_world, nd)
        for name in ("near_clip", "far_clip"):
            callback.put(name, exposed(self, name), nd)

    def parameters_changed(self, keys: list[str]) -> None:
        mi.Sensor.parameters_changed(self, keys)
        take_float(self, "tutorialortho", "near_clip", lo=0.0)
        far = scalar(exposed(self, "far_clip"))
        if not self.near_clip < far:
            raise ValueError(f"tutorialortho: need 'near_clip' < 'far_clip', got "
                             f"{self.near_clip:g} and {far:g}")
        self.far_clip = far
        film = self.film()
        size = film.size()
        self.film_map = FilmMap(film, self.film_map.offset, "tutorialortho")
        self.inv_aspect = size[1] / size[0]
        self.pixel_step = mi.ScalarVector2f(2.0 / size[0], 2.0 * self.inv_aspect / size[1])

    def bbox(self) -> mi.ScalarBoundingBox3f:
        return mi.ScalarBoundingBox3f(origin_of(self.world_transform()))

    def to_string(self) -> str:
        return (f"TutorialOrthoCamera[\n  near_clip = {self.near_clip},\n"
                f"  far_clip = {self.far_clip},\n  pixel_offset = {self.film_map.offset},\n"
                f"  film = {self.film()},\n  to_world = {self.world_transform()}\n]")


mi.register_sensor("tutorialortho", lambda props, cls=TutorialOrthoCamera: cls(props))
