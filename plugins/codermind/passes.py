"""Rendering in passes: the sample budget is split into passes with distinct seeds,
accumulated as a sample-weighted mean, with progress, ETA and clean interruption. A film
larger than ``TILE_BUDGET`` pixels is rendered tile by tile within each pass (:func:`accumulate`).

The split depends only on the sample count and the image size (never on timing), so
a fixed seed gives the same image on every run.
"""

from __future__ import annotations

import math
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable, TextIO

import drjit as dr
import mitsuba as mi
import numpy as np

from .errors import CodermindError

#: Samples in flight per pass (pixels x spp), for plain and tutorial renders alike. Memory
#: does not grow with it (Mitsuba's megakernel derives each sample from its index), and
#: larger passes pay the fixed cost of a pass less often: on page 4 a pass of 1 << 25 lanes
#: costs less CPU per sample than one of 1 << 23 and about as much as one of 1 << 26
#: (``benchmarks/bench_page4_c256.py --breakdown``, pass size). It also sets how often
#: progress is shown and Ctrl-C is polled.
LANE_BUDGET = 1 << 25

#: The lane budget of a pass of a stratifying sampler (:func:`sampler_plan`). Its passes are
#: independent stratified sets, and a larger set has less variance per sample: on page 4's
#: whole film, multijitter's relative MSE x spp is 0.076 in passes of 16 spp, 0.063 in one
#: of 64 and 0.057 in one of 256 (docs/results/integrator.md). 1 << 27 lanes is 109 spp per
#: pass of that film, about 9 s of rendering between progress lines.
STRATA_BUDGET = 1 << 27


def pass_plan(spp: int, pixels: int, pass_spp: int | None = None) -> list[int]:
    """Samples per pixel of each pass; they add up to ``spp``."""
    if spp < 1:
        raise ValueError("spp must be >= 1")
    per = pass_spp or max(1, LANE_BUDGET // max(pixels, 1))
    per = min(per, spp)
    full, rest = divmod(spp, per)
    return [per] * full + ([rest] if rest else [])


def divisors_of(n: int) -> list[int]:
    """The divisors of ``n`` >= 1, ascending, in O(sqrt n) steps (2^32: 65 536 steps)."""
    small, large = [], []
    i = 1
    while i * i <= n:
        if n % i == 0:
            small.append(i)
            if i * i != n:
                large.append(n // i)
        i += 1
    return small + large[::-1]


def sampler_plan(sampler: mi.Sampler, spp: int, pixels: int,
                 pass_spp: int | None = None) -> list[int]:
    """Samples per pixel of each pass of ``sampler``, adding up to ``spp``.

    Mitsuba's stratifying samplers round a count up to their grid with a warning (stratified
    to a square, multijitter to a x b, ldsampler to a power of 4, orthogonal to a prime's
    square), so a pass of another count would render more samples than it counts. Every
    pass here is a count that ``sampler`` keeps (asked of the sampler itself, which is left
    at its count): :func:`pass_plan` where its passes are such counts (``independent``),
    else equal passes of the largest such divisor of ``spp`` within ``pass_spp`` (default:
    ``STRATA_BUDGET`` lanes), else of the smallest one above it. A stratifying sampler's
    pass is one stratified set per pixel, so its passes are allowed to be larger than
    ``LANE_BUDGET``'s (memory does not grow with a pass; progress comes less often)."""
    if spp < 1:
        raise ValueError("spp must be >= 1")
    count = sampler.sample_count()
    logger = mi.logger()
    level = logger.log_level()

    def kept(n: int) -> bool:
        if n >= 1 << 32:                        # Mitsuba's sample count is 32-bit
            return False
        sampler.set_sample_count(n)
        return sampler.sample_count() == n

    logger.set_log_level(mi.LogLevel.Error)    # the probes' rounding warnings
    try:
        plan = pass_plan(spp, pixels, pass_spp)
        if all(kept(n) for n in {plan[0], plan[-1]}):     # its only counts
            return plan
        limit = min(spp, pass_spp or max(1, STRATA_BUDGET // max(pixels, 1)))
        divisors = [n for n in divisors_of(spp) if kept(n)]
        if not divisors:
            kept(spp)
            rounded = sampler.sample_count() if spp < 1 << 32 else spp  # for the message
    finally:
        sampler.set_sample_count(count)
        logger.set_log_level(level)
    if not divisors:
        raise CodermindError(f"{sampler.class_name()}: it rounds {spp} samples per pixel up "
                             f"to {rounded}, and no divisor of {spp} is a count it keeps: "
                             f"ask for {rounded}")
    below = [n for n in divisors if n <= limit]
    n = below[-1] if below else divisors[0]
    return [n] * (spp // n)


def pass_seed(seed: int, index: int) -> int:
    """A 32-bit seed for pass ``index`` of a render with base ``seed`` (splitmix-style mix)."""
    z = (seed * 0x9E3779B97F4A7C15 + (index + 1) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
    return (z ^ (z >> 31)) & 0xFFFFFFFF


class Progress:
    """A progress bar with ETA on a terminal; one line per pass otherwise."""

    def __init__(self, total_spp: int, stream: TextIO | None = None, label: str = "render"):
        self.total = total_spp
        self.stream = stream if stream is not None else sys.stderr
        self.label = label
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()

    def update(self, done_spp: int, passes_done: int, passes_total: int) -> None:
        elapsed = time.perf_counter() - self.start
        frac = done_spp / self.total
        eta = elapsed * (1 - frac) / frac if frac > 0 else float("nan")
        bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
        text = (f"{self.label} [{bar}] {done_spp}/{self.total} spp, pass {passes_done}/{passes_total}, "
                f"{elapsed:.1f} s, ETA {eta:.1f} s")
        if self.tty:
            self.stream.write("\r" + text + ("\n" if done_spp >= self.total else ""))
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def finish_early(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


@dataclass
class RenderResult:
    image: np.ndarray                 #: float32 (H, W, C) sample mean
    channel_names: list[str]
    spp: int                          #: samples per pixel actually accumulated
    spp_requested: int
    seconds: float
    pass_times: list[float] = field(default_factory=list)

    @property
    def interrupted(self) -> bool:
        return self.spp < self.spp_requested


def scene_spp(scene: mi.Scene, sensor: int = 0) -> int:
    return int(scene.sensors()[sensor].sampler().sample_count())


#: Film pixels rendered at once. A larger film is rendered tile by tile (passes outer, tiles
#: inner): Mitsuba's film, its image block, the developed tensor and the float64 sum of the
#: light scenes are then tile-sized, and only the running mean (and, with ``variance``, the
#: running sum of squares) is film-sized (``codermind_cli.limits`` has the measured bytes).
TILE_BUDGET = 1 << 22


def tile_size(size: tuple[int, int], budget: int | None = None) -> tuple[int, int]:
    """Width and height of the largest tile of :func:`film_tiles` for a window of ``size``."""
    w, h = (int(v) for v in size)
    budget = TILE_BUDGET if budget is None else budget
    if budget < 1:
        raise ValueError("tile budget must be >= 1 pixel")
    if w * h <= budget:
        return w, h
    tw = min(w, max(1, math.isqrt(budget)))
    return tw, min(h, max(1, budget // tw))


def film_tiles(offset: tuple[int, int], size: tuple[int, int],
               budget: int | None = None) -> list[tuple[int, int, int, int]]:
    """(x, y, width, height) tiles, in film pixels, covering the crop window at ``offset`` of
    ``size``, row by row; the window itself when it has at most ``budget`` pixels (default:
    ``TILE_BUDGET``, read at the call). Tiles are
    ``min(W, isqrt(budget))`` wide and as tall as the budget allows (a narrow film gets tall
    tiles); the last column and row hold the remainder."""
    (x0, y0), (w, h) = (int(v) for v in offset), (int(v) for v in size)
    tw, th = tile_size((w, h), budget)
    return [(x0 + x, y0 + y, min(tw, w - x), min(th, h - y))
            for y in range(0, h, th) for x in range(0, w, tw)]


def tile_seed(seed: int, index: int, tile: int, tiles: int) -> int:
    """The seed of pass ``index`` on tile ``tile`` of ``tiles``: ``pass_seed(seed, index)`` for
    an untiled film, else one of its own per tile (a seed shared by two tiles would repeat
    the same random numbers lane by lane in both)."""
    base = pass_seed(seed, index)
    return base if tiles == 1 else pass_seed(base, tile)


@contextmanager
def film_crop(sensor: mi.Sensor):
    """A function ``set(offset, size)`` that sets ``sensor``'s film crop window through
    ``mi.traverse`` (the sensor rebuilds what depends on it in ``parameters_changed``); the
    crop found on entry is restored on exit, also on an error or an interrupt."""
    film = sensor.film()
    saved = [int(v) for v in film.crop_offset()], [int(v) for v in film.crop_size()]
    params = []             # traversed at the first change: an untiled render changes nothing

    def set_crop(offset, size) -> None:
        if not params:
            params.append(mi.traverse(sensor))
        params[0]["film.crop_size"] = mi.ScalarVector2u(*(int(v) for v in size))
        params[0]["film.crop_offset"] = mi.ScalarPoint2u(*(int(v) for v in offset))
        params[0].update()      # Film.parameters_changed checks and sets the window

    try:
        yield set_crop
    finally:
        if ([int(v) for v in film.crop_offset()], [int(v) for v in film.crop_size()]) != saved:
            set_crop(*saved)


def accumulate(scenes: list[mi.Scene], sensor: mi.Sensor | int, plan: list[int], seed: int,
               rgb: bool = False, variance: bool = False, progress: Progress | None = None,
               should_stop: Callable[[], bool] = lambda: False,
               tile_budget: int | None = None, margin: int | None = None):
    """Render the passes of ``plan`` (samples per pixel of each, pass i with seed
    ``pass_seed(seed, i)``) and return their sample-weighted mean: the film of ``sensor``
    summed over ``scenes`` (rendered with the same seeds), every channel (``rgb``: the first
    three). With ``variance``, also the variance of that mean from the pass means
    (s^2 = sum n_i (m_i - m)^2 / (k - 1) over k passes, divided by the sample count).

    A film (its crop window) of more than ``tile_budget`` pixels (default: ``TILE_BUDGET``,
    read at the call) is rendered in tiles
    (:func:`film_tiles`) through the film's crop window, every tile of a pass before the
    next pass, each (pass, tile) with its own seed (:func:`tile_seed`); a tile is rendered
    with a margin of ``margin`` pixels (default: the reconstruction filter's border),
    clamped to the crop window, and only its own pixels are kept, so that a pixel next to a
    seam receives the samples of its neighbours across it, as in an untiled render (without
    the margin, Mitsuba drops what a crop window's samples splat outside it, and the pixels
    along a seam lose their neighbours' share: a visible bias with the default Gaussian
    filter). The crop window is restored afterwards.
    The mean (float32) and the sum of squares of the variance are updated in place, pass by
    pass and tile by tile (West's weighted update: m += (m_i - m) n_i / N,
    M2 += (m_i - m)^2 n_i (N - n_i) / N with N the samples so far), so that besides them
    only tile-sized arrays are held.

    ``should_stop`` is polled before every pass. Returns (mean float32 or None when no pass
    finished, variance float32 or None, samples per pixel done, seconds of each pass)."""
    scenes = list(scenes)
    sensor_obj = scenes[0].sensors()[sensor] if isinstance(sensor, int) else sensor
    film = sensor_obj.film()
    window = tuple(int(v) for v in film.crop_offset()), tuple(int(v) for v in film.crop_size())
    tiles = film_tiles(*window, budget=tile_budget)
    if margin is None:
        margin = int(film.rfilter().border_size())
    (cx, cy), (cw, ch) = window
    mean = m2 = None
    times = []
    done = 0
    with film_crop(sensor_obj) as set_crop:
        for i, n in enumerate(plan):
            if should_stop():
                break
            t = time.perf_counter()
            for j, (x, y, w, h) in enumerate(tiles):
                if len(tiles) > 1:
                    # the tile and its margin, within the crop window
                    ex, ey = max(cx, x - margin), max(cy, y - margin)
                    ew = min(cx + cw, x + w + margin) - ex
                    eh = min(cy + ch, y + h + margin) - ey
                    set_crop((ex, ey), (ew, eh))
                    inner = (slice(y - ey, y - ey + h), slice(x - ex, x - ex + w))
                else:
                    inner = (slice(None), slice(None))
                arr = None
                for sc in scenes:
                    img = np.asarray(mi.render(sc, sensor=sensor, spp=n,
                                               seed=tile_seed(seed, i, j, len(tiles))))
                    img = img[inner + ((slice(0, 3),) if rgb else ())]
                    # one scene: the pass mean as Mitsuba gives it (float32); a sum of
                    # light scenes in float64, rounded to float32 as a pass mean
                    arr = img if arr is None else np.add(arr, img, dtype=np.float64)
                    del img
                arr = np.asarray(arr, dtype=np.float32)
                if mean is None and len(plan) == 1 and len(tiles) == 1 and not variance:
                    # the one pass of an untiled film is the mean, kept without a copy
                    # where Mitsuba's array can be (a fresh film-sized array costs its
                    # page faults, about 0.1 s a render of page 4's film)
                    mean = arr if arr.flags.writeable and arr.flags.c_contiguous \
                        else np.array(arr, order="C")
                    continue
                if mean is None:
                    mean = np.empty((ch, cw) + arr.shape[2:], dtype=np.float32)
                    if variance:
                        m2 = np.zeros(mean.shape, dtype=np.float32)
                view = mean[y - cy:y - cy + h, x - cx:x - cx + w]
                if done == 0:
                    view[...] = arr
                else:
                    delta = arr.astype(np.float64) - view
                    view += delta * (n / (done + n))
                    if variance:
                        m2[y - cy:y - cy + h, x - cx:x - cx + w] += \
                            np.square(delta) * (n * done / (done + n))
                del arr
                if len(tiles) > 1:
                    # Dr.Jit keeps freed blocks for reuse by size; tiles of other sizes
                    # (the last column and row, the margins) would add up to the film's
                    dr.flush_malloc_cache()
            dr.sync_thread()
            times.append(time.perf_counter() - t)
            done += n
            if progress:
                progress.update(done, i + 1, len(plan))
    if progress and done < sum(plan):
        progress.finish_early()
    if done == 0:
        return None, None, 0, times
    var = None
    if variance:
        k = len(times)
        if k > 1:
            m2 /= (k - 1) * done          # s^2 / N, in place
            var = m2
        else:
            var = np.full(mean.shape, np.nan if done > 1 else 0.0, dtype=np.float32)
    return mean, var, done, times


def render_passes(scene: mi.Scene, spp: int | None = None, seed: int = 0, sensor: int = 0,
                  pass_spp: int | None = None, progress: Progress | None = None,
                  should_stop: Callable[[], bool] = lambda: False) -> RenderResult:
    """Render ``spp`` samples per pixel in passes and return their mean.

    ``should_stop`` is polled before every pass; when it returns True the passes
    finished so far are returned (``result.interrupted`` is then True).
    """
    spp = spp or scene_spp(scene, sensor)
    film = scene.sensors()[sensor].film()
    size = film.crop_size()
    plan = sampler_plan(scene.sensors()[sensor].sampler(), spp, int(size[0]) * int(size[1]),
                        pass_spp)
    t0 = time.perf_counter()
    mean, _, done, times = accumulate([scene], sensor, plan, seed, progress=progress,
                                      should_stop=should_stop)
    names = [f.name for f in film.bitmap().struct_()] if done else []
    image = mean if done else np.zeros((0, 0, 0), np.float32)
    return RenderResult(image, names, done, spp, time.perf_counter() - t0, times)
