"""Rendering a converted tutorial scene with the tutorial's image pipeline.

>>> import mitsuba as mi; mi.set_variant("llvm_ad_rgb"); import codermind
>>> from codermind.tutorial import render as tr
>>> scene, settings = tr.load("page4.xml")                 # settings: the codermind-tutorial block
>>> result = tr.render(scene, settings, seed=0, variance=True)
>>> result.linear      # float32 (2H, 2W, 3), display order: each sub-sample's mean radiance
>>> result.variance    # the variance of that mean (None unless asked), same layout
>>> result.exposure    # E (page 4: auto, from the probe grid unless given)
>>> result.image.rgb8  # uint8 (H, W, 3), display order: the tutorial's bytes
>>> tr.write_outputs(result, "out")                    # out.exr, out.png, out.tga[, out.variance.exr]

Auto exposure (page 4), ``exposure=``:

* ``"probes"`` (default, the tutorial's): the 16 x 16 probe rays (facts.md F6.3) from the sensor
  whose id the block names (``probes``: pinhole, no pixel offset, a W x H film, so that
  ``sample2`` = (x / W, 1 - y / H) reaches past the image top as the tutorial's grid does),
  each traced once with the scene's integrator through ``SamplingIntegrator.sample``, a
  ``tutorialpath`` one with ``draw_diffuse`` on (:func:`probe_integrator`): E is a nonlinear
  function of single rays (the square root of the mean of L^2), so the probes need the
  original's distribution per ray (facts.md F6.3: "the ordinary stochastic path code", whose
  roulette draws the diffuse event, F8.3), not only its expectation, which is what the
  image's lighting at every hit times the diffuse probability keeps (E from the expected
  lighting differs by up to tens of percent where probes see partly reflective materials,
  and does not vary with the seed where no probe path goes on);
* ``"render"``: from the render's own sub-samples (every film pixel, each the mean of its
  samples): deterministic given the render and less noisy, but not the tutorial's statistic
  (other positions, averaged rays), so E differs slightly;
* a number: that E (to tone-map two renderers identically).

Lights (``lights=``): the tutorial shades every hit with ALL its lights; Mitsuba's ``path``
samples ONE emitter per hit (probability 1/N, weight N): the same expectation, but noise even
in a scene where nothing else is random. ``"sum"`` (default) renders the scene once per light
(the sky with the first one), with the same seed, and adds the linear images: radiance is
linear in the emitters and the random numbers (lens, roulette) are the same in every render,
so the sum is per sample exactly the tutorial's all-lights estimate (deterministic scenes
are exact at one sample, and a stochastic scene has the tutorial's noise), at N times the
cost. ``"sample"``: one render with Mitsuba's light selection (what the plain ``mitsuba``
command does with the XML).

``variance=True`` renders in at least 16 passes and estimates, per film pixel and channel,
the variance of the mean from the pass means (s^2 = sum n_i (m_i - m)^2 / (k - 1) over k
passes of n_i samples, divided by the total count): RGB, unlike the XYZ moments of
Mitsuba's ``moment`` integrator.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import mitsuba as mi
import numpy as np

from ..errors import CodermindError
from ..imageio import atomic_path, write_exr, write_png_bytes
from ..passes import LANE_BUDGET, Progress, accumulate, pass_seed, sampler_plan, scene_spp
from ..scene import load_scene
from .image import (ToneBlockError, ToneSettings, TutorialImage, exposure_from_luminance,
                             luminance, parse_block, probe_film_positions, tga_bytes,
                             tutorial_image)

#: Passes at least, when the variance is estimated from pass means.
VARIANCE_PASSES = 16
#: Seed stream of the probe rays (apart from the render passes').
PROBE_STREAM = 0x7072


def read_settings(xml_path: str | os.PathLike) -> ToneSettings | None:
    """The ``codermind-tutorial`` block of an XML file, None if it has none."""
    path = Path(xml_path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        raise CodermindError(f"{path}: cannot read: {e.strerror or e}") from None
    try:
        return parse_block(text)
    except ToneBlockError as e:
        raise CodermindError(f"{path}: codermind-tutorial block: {e}") from None


def load(xml_path: str | os.PathLike, **defines) -> tuple[mi.Scene, ToneSettings]:
    """Load a converted scene (``defines``: XML ``<default>`` overrides, e.g. spp=4)."""
    settings = read_settings(xml_path)
    if settings is None:
        raise CodermindError(f"{xml_path}: not a converted tutorial scene (no "
                             "codermind-tutorial block)")
    scene = load_scene(xml_path, **defines)
    check_film(scene, settings, xml_path)
    return scene, settings


def check_film(scene: mi.Scene, settings: ToneSettings, source) -> None:
    film = scene.sensors()[0].film()
    size = tuple(int(v) for v in film.size())
    crop = tuple(int(v) for v in film.crop_size())
    if size != settings.film_size or crop != size:
        raise CodermindError(f"{source}: the first sensor's film is {size[0]}x{size[1]}"
                             f"{'' if crop == size else ' (cropped)'}, the page-{settings.page} "
                             f"pipeline of a {settings.width}x{settings.height} image needs "
                             f"{settings.film_size[0]}x{settings.film_size[1]} uncropped")


def probe_sensor(scene: mi.Scene, settings: ToneSettings) -> mi.Sensor:
    for sensor in scene.sensors():
        if sensor.id() == settings.probes:
            return sensor
    raise CodermindError(f"no sensor with id '{settings.probes}' (the auto-exposure probes)")


def probe_integrator(integrator: mi.Integrator) -> mi.Integrator:
    """The integrator the probes are traced with: a ``tutorialpath`` with the settings of
    ``integrator`` and ``draw_diffuse`` on (the original's roulette, module doc); any other
    integrator as it is. One copy per integrator, kept."""
    if not hasattr(integrator, "draw_diffuse") or integrator.draw_diffuse:
        return integrator
    key = id(integrator)
    cached = _PROBE_INTEGRATORS.get(key)
    if cached is not None and cached[0] is integrator \
            and cached[2] == _integrator_settings(integrator):
        return cached[1]
    settings = _integrator_settings(integrator)
    copy = mi.load_dict({"type": "tutorialpath", "max_depth": settings[0],
                         "exact_hits": settings[1], "min_distance": settings[2],
                         "quirks": settings[3], "draw_diffuse": True})
    _PROBE_INTEGRATORS[key] = (integrator, copy, settings)
    return copy


def _integrator_settings(integrator) -> tuple:
    return (int(integrator.max_depth), bool(integrator.exact_hits),
            float(integrator.min_distance), str(integrator.quirks))


#: id(scene integrator) -> (that integrator, its probe copy, the settings copied)
_PROBE_INTEGRATORS: dict = {}


def probe_radiance(scene: mi.Scene | list[mi.Scene], settings: ToneSettings, seed: int = 0,
                   integrator: mi.Integrator | None = None) -> np.ndarray:
    """(256, 3) radiance of the probe rays, each traced once (a list of scenes: the sum over
    them, with the same random numbers); ``integrator``: default, the scene's own as
    :func:`probe_integrator` turns it."""
    if isinstance(scene, list):
        return sum(probe_radiance(s, settings, seed, integrator) for s in scene)
    sensor = probe_sensor(scene, settings)
    pos = probe_film_positions(settings.width, settings.height)
    n = pos.shape[0]
    sampler = mi.load_dict({"type": "independent", "sample_count": 1})
    sampler.seed(pass_seed(seed, PROBE_STREAM), n)
    sample2 = mi.Point2f(mi.Float(pos[:, 0].astype(np.float32)),
                         mi.Float(pos[:, 1].astype(np.float32)))
    ray, weight = sensor.sample_ray(mi.Float(0.0), mi.Float(0.5), sample2,
                                    mi.Point2f(0.0, 0.0))
    integrator = integrator or probe_integrator(scene.integrator())
    colour, _, _ = integrator.sample(scene, sampler, mi.RayDifferential3f(ray))
    # a Color3f of n lanes converts to a (3, n) array: transpose, do not reshape
    out = np.array(colour * weight, dtype=np.float64)
    return out.T.reshape(n, 3)


def probe_exposure(scene: mi.Scene | list[mi.Scene], settings: ToneSettings, seed: int = 0,
                   integrator: mi.Integrator | None = None) -> float:
    """The tutorial's auto exposure E from the probe grid traced through Mitsuba."""
    return exposure_from_luminance(luminance(probe_radiance(scene, settings, seed, integrator)),
                                   settings.midpoint)


def exposure_from_render(linear: np.ndarray, settings: ToneSettings) -> float:
    """E from every sub-sample of a render (see the module doc)."""
    return exposure_from_luminance(luminance(np.asarray(linear)[..., :3]), settings.midpoint)


@dataclass
class TutorialRender:
    settings: ToneSettings
    linear: np.ndarray                 #: float32 film, display order (RGB)
    variance: np.ndarray | None        #: variance of each pixel's mean, or None
    image: TutorialImage
    exposure: float | None
    exposure_source: str               #: "probes", "render", "given", "fixed" or "none"
    spp: int
    spp_requested: int
    seconds: float
    pass_times: list[float]

    @property
    def interrupted(self) -> bool:
        return self.spp < self.spp_requested


def light_scenes(scene: mi.Scene) -> list[mi.Scene]:
    """One scene per light (every environment emitter goes with the first), sharing the
    shapes, sensors and integrator of ``scene``; ``[scene]`` with at most one light, or when
    the integrator adds every light at every hit itself (``tutorialpath``)."""
    if sums_lights(scene):
        return [scene]
    lights = [e for e in scene.emitters()
              if not mi.has_flag(e.flags(), mi.EmitterFlags.Infinite)]
    if len(lights) <= 1:
        return [scene]
    env = [e for e in scene.emitters() if mi.has_flag(e.flags(), mi.EmitterFlags.Infinite)]
    out = []
    for k, light in enumerate(lights):
        d = {"type": "scene", "integrator": scene.integrator()}
        # keys = ids: load_dict gives each object its key as id (the probes are found by id)
        d.update({s.id() or f"sensor{i}": s for i, s in enumerate(scene.sensors())})
        d.update({f"shape{i}": s for i, s in enumerate(scene.shapes())})
        d.update({f"emitter{i}": e for i, e in enumerate(([light] + env) if k == 0 else [light])})
        out.append(mi.load_dict(d))
    return out


def sums_lights(scene: mi.Scene) -> bool:
    """The scene's integrator adds every delta light at every hit (``tutorialpath``)."""
    return bool(getattr(scene.integrator(), "sums_lights", False))


def check_light_sampling(scene: mi.Scene, spp: int) -> None:
    """Mitsuba's light choice needs random (or N^2 stratified) samples: a jitter-free
    stratified sampler with fewer picks the same light at every sample."""
    if sums_lights(scene):
        return
    n = sum(not mi.has_flag(e.flags(), mi.EmitterFlags.Infinite) for e in scene.emitters())
    sampler = str(scene.sensors()[0].sampler())
    if n > 1 and sampler.startswith("StratifiedSampler") and "jitter = 0" in sampler \
            and spp < n * n:
        raise CodermindError(f"lights=sample with {n} lights needs {n * n} samples of this "
                             f"jitter-free sampler (each light picked equally often), got "
                             f"{spp}: use lights=sum, more samples, or convert with "
                             "--lights sample")


def render_linear(scene: mi.Scene | list[mi.Scene], spp: int, seed: int = 0,
                  pass_spp: int | None = None, variance: bool = False,
                  progress: Progress | None = None,
                  should_stop: Callable[[], bool] = lambda: False):
    """The first sensor's film (RGB mean of ``spp`` samples, in passes; a list of scenes:
    the sum of their films, rendered with the same seeds) and, if asked, the variance of
    that mean from the pass means. Returns (mean, variance|None, spp done, pass times)."""
    scenes = scene if isinstance(scene, list) else [scene]
    sensor = scenes[0].sensors()[0]     # the same object in every light scene
    film = sensor.film()
    pixels = int(film.crop_size()[0]) * int(film.crop_size()[1])
    if variance and spp > 1:
        k = min(spp, VARIANCE_PASSES)
        pass_spp = min(pass_spp or max(1, LANE_BUDGET // pixels), -(-spp // k))
    # passes of counts the sampler keeps (codermind.passes.sampler_plan)
    plan = sampler_plan(sensor.sampler(), spp, pixels, pass_spp)
    # mi.render(spp=n) sets the sampler's sample count for good: restore it afterwards
    sampler = sensor.sampler()
    count = sampler.sample_count()
    try:
        return accumulate(scenes, sensor, plan, seed, rgb=True, variance=variance,
                          progress=progress, should_stop=should_stop)
    finally:
        sampler.set_sample_count(count)


def render(scene: mi.Scene, settings: ToneSettings, spp: int | None = None, seed: int = 0,
           exposure: float | str = "probes", lights: str | None = None,
           pass_spp: int | None = None, variance: bool = False,
           progress: Progress | None = None,
           should_stop: Callable[[], bool] = lambda: False) -> TutorialRender | None:
    """Render the first sensor and apply the tutorial's pipeline (module doc). ``lights``:
    "sum" or "sample" (default: the block's). Returns None if stopped before the first
    pass finished."""
    t0 = time.perf_counter()
    spp = spp or scene_spp(scene)
    lights = lights or settings.lights
    if lights not in ("sum", "sample"):
        raise CodermindError(f"lights must be 'sum' or 'sample', got {lights!r}")
    if lights == "sample":
        check_light_sampling(scene, spp)
    scene = light_scenes(scene) if lights == "sum" else scene
    e, source = None, "none"
    exposure = "probes" if exposure is None else exposure
    if settings.page == 2:
        e, source = 1.0, "fixed"
    if settings.page in (2, 4) and not isinstance(exposure, str):
        e, source = float(exposure), "given"
    elif settings.page == 4 and exposure == "probes":
        e, source = probe_exposure(scene, settings, seed), "probes"
    elif settings.page == 4 and exposure != "render":
        raise CodermindError(f"exposure must be 'probes', 'render' or a number, got {exposure!r}")
    linear, var, done, times = render_linear(scene, spp, seed, pass_spp, variance, progress,
                                             should_stop)
    if linear is None:
        return None
    if settings.page == 4 and e is None:
        e, source = exposure_from_render(linear, settings), "render"
    image = tutorial_image(linear, settings, e)
    return TutorialRender(settings, linear, var, image, e, source, done, spp,
                          time.perf_counter() - t0, times)


def output_writers(result: TutorialRender) -> dict[str, Callable[[Path], None]]:
    """How to write each file of a render, by the suffix after OUT: ``.exr`` (the linear
    film), ``.png`` and ``.tga`` (the tutorial's bytes), ``.variance.exr`` when the variance
    was estimated."""
    def tga(path: Path) -> None:
        with atomic_path(path) as tmp:
            tmp.write_bytes(tga_bytes(result.image.rgb8))
    writers = {".exr": lambda path: write_exr(path, result.linear),
               ".png": lambda path: write_png_bytes(path, result.image.rgb8), ".tga": tga}
    if result.variance is not None:
        writers[".variance.exr"] = lambda path: write_exr(path, result.variance)
    return writers


def write_outputs(result: TutorialRender, base: str | os.PathLike) -> list[Path]:
    """``base.exr``, ``base.png``, ``base.tga`` [, ``base.variance.exr``] (the name kept
    whole, the extension appended); each file written atomically."""
    base = Path(base)
    paths = []
    for suffix, write in output_writers(result).items():
        paths.append(base.with_name(base.name + suffix))
        write(paths[-1])
    return paths
