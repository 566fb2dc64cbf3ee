"""The render driver: rays for every sub-sample, transport, exposure, tone mapping, bytes.

``render(scene, mode="strict", seed=0, ...) -> RenderResult``; see :func:`render`.
Work is split into tiles of image rows (and, at high Complexity, of repeats) whose layout
depends only on the image, so results are identical for any worker count; tiles run in
forked worker processes when ``workers > 1`` (by default for renders of more than 200 000
rays, one per available core, at most 8), or wherever a caller's ``tile_map`` sends them: a
tile's result depends only on the job and the tile, and the sums are taken in tile order.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import camera, rng, tonemap
from .quirks import Quirks, resolve
from .scene import Scene
from .transport import roulette, whitted
from .world import World

TILE_RAYS = 1 << 16
PROBES = 16


def tile_shape(per_row: int, complexity: int) -> tuple[int, int]:
    """(rows, repeats) of a tile of at most about TILE_RAYS rays: whole repeats of several
    rows where a row's repeats fit, else part of one row's repeats."""
    reps = max(1, min(complexity, TILE_RAYS // per_row))
    rows = max(1, TILE_RAYS // (per_row * reps)) if reps == complexity else 1
    return rows, reps


@dataclass
class RenderResult:
    """What :func:`render` returns. Image arrays cover the rendered grid (``xs`` by ``ys``,
    tutorial pixel coordinates, y up); h = len(ys), w = len(xs).

    * ``rgb8_tga`` uint8 (h, w, 3) RGB, row i = tutorial row ys[i]: the TGA's stored order
      (bottom row first); ``rgb8`` is the display-order view (row 0 = top);
    * ``tonemapped`` float64 (h, w, 3), display order: the mean of the 4 tone-mapped
      sub-samples before sRGB (page 1: the colour itself); ``encoded``: after sRGB, before the
      x255 byte conversion (page 1: the colour);
    * ``linear`` float32, display order, (2h, 2w, 3) for pages 2 and 4 (sub-sample
      (x + a/2, y + b/2) at column 2i + a, row 2h - 1 - (2j + b) for x = xs[i], y = ys[j]),
      (h, w, 3) for page 1: radiance per sub-sample, the mean of its Complexity rays, before
      exposure; rows y < 10 hold rendered radiance although the bytes show the strip;
    * ``variance`` like ``linear``: the variance of that mean (sample variance / Complexity);
      NaN on page 4 at Complexity 1; 0 on pages 1 and 2, which are deterministic;
    * ``exposure`` the E applied (page 4: auto or given; page 2: 1 or given; page 1: None).
    """
    scene: Scene
    quirks: Quirks
    seed: int
    complexity: int
    exposure: float | None
    xs: np.ndarray
    ys: np.ndarray
    rgb8_tga: np.ndarray
    tonemapped: np.ndarray
    encoded: np.ndarray
    linear: np.ndarray
    variance: np.ndarray
    seconds: float = 0.0
    warnings: list[str] = field(default_factory=list)

    @property
    def rgb8(self) -> np.ndarray:
        return self.rgb8_tga[::-1]

    @property
    def mode(self) -> str:
        return self.quirks.name


def render(scene: Scene, mode: str | Quirks = "strict", seed: int = 0,
           complexity: int | None = None, *, exposure: float | None = None,
           rect: tuple[int, int, int, int] | None = None, stride: int = 1,
           workers: int | None = None,
           progress: Callable[[int, int], None] | None = None,
           tile_map: Callable | None = None, ties: str = "first",
           start_method: str = "fork") -> RenderResult:
    """Render ``scene`` as its page's program does.

    mode: "strict" (every quirk), "clean" (the quirks of :mod:`codermind_ref.quirks` removed)
    or a :class:`~codermind_ref.quirks.Quirks`. seed: page-4 random streams
    (:mod:`codermind_ref.rng`). complexity: rays per sub-sample (page 4; default the scene's).
    exposure: a fixed E instead of the page-4 auto exposure (or of page 2's 1), so that two
    renderers can be tone-mapped identically. rect: (x0, y0, x1, y1), a half-open pixel
    rectangle in tutorial coordinates (y up), stride: render every stride-th pixel of it --
    pixel values equal the full frame's. workers: processes (default: one per available core,
    at most 8, for renders of more than 200 000 rays; the result does not depend on it).
    progress(done, total) is called as tiles finish. Pages 1 and 2 ignore complexity, page 1
    also exposure. tile_map(job, tiles): runs ``job.trace(tile)`` for every tile elsewhere (the
    job pickles; e.g. on other machines) and yields the results in tile order; it replaces the
    worker processes (``workers`` is then ignored) and the image does not depend on it.
    ties: "first" (the original) or "last", which sphere wins at exactly equal distances
    (:class:`~codermind_ref.world.World`). start_method: how the worker processes start;
    "fork" (the job is inherited), or "forkserver" in a host process with threads that hold
    locks (fork copies only the calling thread, so such a lock stays locked in the child).
    """
    t0 = time.perf_counter()
    quirks = resolve(mode)
    if not 0 <= int(seed) < 2 ** 63:
        raise ValueError(f"seed must be in [0, 2^63), got {seed}")
    c = int(complexity or scene.complexity) if scene.page == 4 else 1
    if c < 1:
        raise ValueError(f"complexity must be >= 1, got {c}")
    x0, y0, x1, y1 = rect or (0, 0, scene.width, scene.height)
    if not (0 <= x0 < x1 <= scene.width and 0 <= y0 < y1 <= scene.height) or stride < 1:
        raise ValueError(f"rect {rect} / stride {stride} outside the {scene.width}x"
                         f"{scene.height} image")
    xs, ys = np.arange(x0, x1, stride), np.arange(y0, y1, stride)
    world = World(scene, np.float32 if scene.page < 4 else np.float64, ties)
    warnings = list(scene.warnings)
    if scene.page == 4 and exposure is None:
        lum = probe_luminance(scene, world, quirks, seed)
        e = tonemap.exposure_from_probes(lum, scene.tonemap.midpoint)
        warnings += _exposure_warnings(scene, lum, e)
    elif scene.page == 4:
        e = float(exposure)
    else:
        e = (1.0 if exposure is None else float(exposure)) if scene.page == 2 else None

    job = _Job(scene, world, quirks, int(seed), c, xs, ys)
    tiles = job.tiles()
    sums = np.zeros((ys.size, xs.size) + job.sample_shape + (3,))
    squares = np.zeros_like(sums) if c > 1 else None
    n_workers = workers or (min(8, len(os.sched_getaffinity(0))) if job.rays > 200_000 else 1)
    results = tile_map(job, tiles) if tile_map else _run(job, tiles, n_workers, start_method)
    for done, (tile, (s, q)) in enumerate(zip(tiles, results), start=1):
        rows = slice(tile[0], tile[1])
        sums[rows] += s
        if squares is not None:
            squares[rows] += q
        if progress:
            progress(done, len(tiles))
    # in place, in the order of (squares - sums^2 / c) / (c - 1) / c and sums / c: the same
    # bits as the plain expressions, without their film-sized temporaries
    if scene.page == 4 and c > 1:
        square_sums = np.multiply(sums, sums)
        square_sums /= c
        var = np.subtract(squares, square_sums, out=squares)
        del square_sums
        np.maximum(var, 0.0, out=var)
        var /= c - 1
        var /= c
    else:
        var = np.full(sums.shape, np.nan if scene.page == 4 else 0.0, dtype=np.float32)
    sums /= c
    mean = sums
    warnings += _radiance_warnings(scene, mean, xs, ys)
    return _finish(scene, quirks, int(seed), c, e, xs, ys, mean, var, time.perf_counter() - t0,
                   warnings)


def _radiance_warnings(scene: Scene, mean: np.ndarray, xs: np.ndarray, ys: np.ndarray
                       ) -> list[str]:
    """A NaN radiance becomes byte 0, a plausible black pixel: never without a word."""
    bad = ~np.isfinite(mean).all(axis=-1)
    if not bad.any():
        return []
    j, i = np.argwhere(bad)[0][:2]
    return [f"{scene.path}: {int(bad.sum())} of {bad.size} samples have non-finite radiance "
            f"(from inf or nan values in the scene; first at pixel {xs[i]}, {ys[j]}): NaN shows "
            f"as black (byte 0), +inf as the brightest byte"]


def probe_luminance(scene: Scene, world: World, quirks: Quirks, seed: int) -> np.ndarray:
    """facts.md F6: luminance of 16x16 single-ray probes at (i s, j s), s = max(W, H)/16 (cell
    corners, past the image top when W > H), pinhole (no lens jitter), traced with the normal
    path code."""
    step = max(scene.width, scene.height) / PROBES
    j, i = np.meshgrid(np.arange(PROBES), np.arange(PROBES), indexing="ij")
    o, d = camera.rays(scene, (i * step).ravel().astype(float), (j * step).ravel().astype(float),
                       probe=True)
    colour = roulette(world, o, d, rng.probe_draws(seed, PROBES).reshape(-1, rng.DRAWS), quirks)
    return tonemap.luminance(colour)


def auto_exposure(scene: Scene, world: World, quirks: Quirks, seed: int) -> float:
    """The page-4 auto exposure E (facts.md F6; -1 when every probe is black)."""
    return tonemap.exposure_from_probes(probe_luminance(scene, world, quirks, seed),
                                        scene.tonemap.midpoint)


def _exposure_warnings(scene: Scene, lum: np.ndarray, e: float) -> list[str]:
    """What a user must know when the auto exposure is not a plain positive number."""
    where = f"{scene.path}:{scene.line_of('Scene')}"
    if not np.isfinite(lum).all():
        return [f"{where}: auto exposure: {int((~np.isfinite(lum)).sum())} of {lum.size} probe "
                f"rays have non-finite luminance (from inf or nan values in the scene), so "
                f"E = {e:g}; give a fixed exposure"]
    if e == -1.0:
        return [f"{where}: auto exposure: all {lum.size} probe rays are black, so E = -1 as in "
                f"the original: anything lit that the probes missed is tone-mapped from negative "
                f"values (wrong, wrapped bytes); give a fixed exposure"]
    return []


class _Job:
    """Everything a tile needs (inherited by forked workers, pickled for a ``tile_map``)."""

    def __init__(self, scene, world, quirks, seed, complexity, xs, ys):
        self.scene, self.world, self.quirks, self.seed = scene, world, quirks, seed
        self.complexity, self.xs, self.ys = complexity, xs, ys
        self.sample_shape = () if scene.page == 1 else (2, 2)
        per_pixel = 1 if scene.page == 1 else 4
        self.rays = xs.size * ys.size * per_pixel * complexity

    def tiles(self) -> list[tuple[int, int, int, int]]:
        """(row start, row end, repeat start, repeat end) over indices into ys / repeats."""
        rows, reps = tile_shape(self.xs.size * (1 if self.scene.page == 1 else 4),
                                self.complexity)
        return [(r, min(r + rows, self.ys.size), c, min(c + reps, self.complexity))
                for r in range(0, self.ys.size, rows) for c in range(0, self.complexity, reps)]

    def trace(self, tile) -> tuple[np.ndarray, np.ndarray | None]:
        r0, r1, c0, c1 = tile
        scene, xs, ys = self.scene, self.xs, self.ys[r0:r1]
        if scene.page == 1:
            fy, fx = np.meshgrid(ys.astype(float), xs.astype(float), indexing="ij")
            o, d = camera.rays(scene, fx.ravel(), fy.ravel(), dtype=np.float32)
            colour = whitted(self.world, o, d, self.quirks)
            return colour.T.reshape(ys.size, xs.size, 3), None
        half = np.array([0.0, 0.5])
        if scene.page == 2:   # axes (row, x, a, b)
            fx = np.broadcast_to(xs[None, :, None, None] + half[None, None, :, None],
                                 (ys.size, xs.size, 2, 2))
            fy = np.broadcast_to(ys[:, None, None, None] + half[None, None, None, :], fx.shape)
            o, d = camera.rays(scene, fx.ravel(), fy.ravel(), dtype=np.float32)
            colour = whitted(self.world, o, d, self.quirks)
            return np.moveaxis(colour.reshape((3,) + fx.shape), 0, -1), None
        reps = c1 - c0       # axes (row, repeat, x, a, b)
        shape = (ys.size, reps, xs.size, 2, 2)
        fx = np.broadcast_to(xs[None, None, :, None, None] + half[:, None], shape)
        fy = np.broadcast_to(ys[:, None, None, None, None] + half, shape)
        draws = np.stack([rng.row_draws(self.seed, int(y), c0, c1, scene.width)[:, xs]
                          for y in ys]).reshape(-1, rng.DRAWS)
        o, d = camera.rays(scene, fx.ravel(), fy.ravel(), draws[:, 0], draws[:, 1])
        colour = roulette(self.world, o, d, draws, self.quirks)
        colour = np.moveaxis(colour.reshape((3,) + shape), 0, -1)
        return colour.sum(axis=1), (colour * colour).sum(axis=1) if self.complexity > 1 else None


_CURRENT: _Job | None = None


def _set_current(job: _Job) -> None:
    global _CURRENT
    _CURRENT = job


def _trace_current(tile):
    return _CURRENT.trace(tile)


def _run(job: _Job, tiles, workers: int, start_method: str):
    # without fork, or in a daemonic process (e.g. a cluster's worker), which may not have
    # children, one process does it all
    if (workers <= 1 or len(tiles) < 2 or multiprocessing.current_process().daemon
            or "fork" not in multiprocessing.get_all_start_methods()):
        yield from map(job.trace, tiles)
        return
    context = multiprocessing.get_context(start_method)
    with context.Pool(workers, initializer=_set_current, initargs=(job,)) as pool:
        yield from pool.imap(_trace_current, tiles)


#: Sub-samples per band of rows in which :func:`_finish` applies the tone curve.
_BAND_SAMPLES = 1 << 20


def _finish(scene, quirks, seed, c, e, xs, ys, mean, var, seconds, warnings) -> RenderResult:
    h, w = ys.size, xs.size
    if scene.page < 4:   # float32 like the original (the sums of float32 values are exact)
        mean = mean.astype(np.float32)
    if scene.page == 1:
        encoded = tonemapped = mean
        linear, variance = mean[::-1], var[::-1]
    else:
        tonemapped = np.zeros((h, w, 3), dtype=mean.dtype)
        band = max(1, _BAND_SAMPLES // (4 * w))
        for r in range(0, h, band):     # in bands of rows: the curve's temporaries stay small
            rows = slice(r, r + band)
            per_sample = (tonemap.curve(e * mean[rows], scene.tonemap) if scene.page == 4
                          else 1.0 - np.exp(mean[rows] * -e))
            for a in (0, 1):      # the original's loop order: x offset outer, y offset inner
                for b in (0, 1):
                    tonemapped[rows] += 0.25 * per_sample[:, :, a, b]
        encoded = tonemap.srgb(tonemapped)
        # (y, x, a, b, ch) -> (y, b, x, a, ch): tutorial sub-sample rows/cols, then flip
        linear = mean.transpose(0, 3, 1, 2, 4).reshape(2 * h, 2 * w, 3)[::-1]
        variance = var.transpose(0, 3, 1, 2, 4).reshape(2 * h, 2 * w, 3)[::-1]
    rgb8 = tonemap.to_bytes(encoded)
    if scene.page >= 2:
        low = ys < 10
        if low.any():
            rgb8[low] = tonemap.strip(ys[low], xs)[:, :, None]
    return RenderResult(scene, quirks, seed, c, e, xs, ys, rgb8, tonemapped[::-1].copy(),
                        encoded[::-1].copy(), np.ascontiguousarray(linear, np.float32),
                        np.ascontiguousarray(variance, np.float32), seconds, warnings)
