"""Limits checked before work starts: a request the machine cannot hold is refused in one line
with its estimate (``codermind: error: ... needs about 9.6 GiB, more than the 6.2 GiB
allowed ...``); one that will take long gets a one-line warning with the estimated time.

Memory: the estimate of each command is compared with the allowed memory: 80 % of the
machine's total (``/proc/meminfo``), or ``--max-memory GiB`` (else ``CODERMIND_MAX_MEMORY``)
where that is set (it may exceed the total, for a machine with swap).

* ``render`` renders a film of more than ``codermind.passes.TILE_BUDGET`` pixels tile by tile,
  so it needs ``BASE`` + ``RENDER_PER_PIXEL`` per film pixel (the float32 mean, its copy in
  the EXR writer, the PNG's bytes) + ``RENDER_PER_TILE_PIXEL`` per pixel of the largest tile
  (Mitsuba's film and image block, the developed tensor, the tile's arrays; the whole film
  when it is not tiled) + ``RENDER_VARIANCE_PER_PIXEL`` per film pixel with ``--variance``
  (the sum of squares and its EXR copy) + the pass list. Measured as the peak RSS of
  ``/usr/bin/time -f "%M KB" codermind render scenes/user/lens.xml -D resx=N -D resy=N --spp 1``
  (llvm_ad_rgb, 2 cores): N = 1000, 2000 (untiled), 3000, 4000, 5000: 265, 423, 416 to
  442, 698, 799 to 817 MiB, about 25 bytes per film pixel between 3000 and 5000; a
  converted page-4-like scene of 3000 x 2000 sub-samples (``--spp 2 --exposure 2``): 463
  MiB, 634 MiB with ``--variance``. The estimate exceeds each of these by 18 to 56 %.
* ``reference``: 150 bytes per sub-sample (sums, squares, outputs; measured about 146 on
  1000 to 3000 pixels a side) + 120 per tile of the port + 100 MiB per extra worker.

Time: estimated from a measured rate: a warning above 10 minutes, a refusal above a year.
Workers: at most 4 per core (``--workers``).
"""

from __future__ import annotations

import argparse
import math
import os
import sys

from codermind.errors import CodermindError

from .args import _integer

GIB = float(1 << 30)
ENV = "CODERMIND_MAX_MEMORY"
#: Fraction of the total memory allowed by default.
DEFAULT_FRACTION = 0.8
#: Memory every render starts with (Python, Mitsuba, Dr.Jit's LLVM), bytes.
BASE = 250 << 20
#: ``render``: bytes per film pixel (mean, EXR copy, PNG bytes; measured about 25).
RENDER_PER_PIXEL = 28
#: ``render``: bytes per pixel of the largest tile (Mitsuba's film, block and tensor).
RENDER_PER_TILE_PIXEL = 40
#: ``render --variance``: bytes per film pixel of the variance (sum of squares, EXR copy).
RENDER_VARIANCE_PER_PIXEL = 32
#: ``reference``: bytes per sub-sample (sums, squares, outputs; measured about 146).
REFERENCE_PER_SAMPLE = 150
#: A Python list entry (pass plans) and a tile tuple of the port, bytes.
PER_PASS, PER_TILE = 8, 120
#: Rays per second, for the time warning only: Mitsuba's llvm render on 2 cores of this
#: machine (about 1e6 to 3e6 samples/s), the port (about 1e6 rays/s per worker).
RENDER_RATE, REFERENCE_RATE = 2e6, 1e6
#: Warn above this estimated time, seconds.
LONG = 600.0
#: Refuse above this estimated time (a year), seconds: a request that size is a typo.
NEVER = 365.25 * 86400
#: ``--workers`` above this many per core is refused.
WORKERS_PER_CORE = 4


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def total_memory() -> int:
    """The machine's total memory in bytes (``/proc/meminfo``, else ``os.sysconf``)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return 8 << 30


def memory_limit(option: float | None = None) -> tuple[float, str]:
    """(bytes allowed, where the limit comes from): ``--max-memory`` (``option``, GiB), else
    ``CODERMIND_MAX_MEMORY``, else 80 % of the machine's total."""
    if option is not None:
        return option * GIB, f"--max-memory {option:g}"
    text = os.environ.get(ENV)
    if text:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not 0 < value < math.inf:
            raise CodermindError(f"{ENV}={text!r}: expected a number of GiB > 0")
        return value * GIB, f"{ENV}={text}"
    total = total_memory()
    return DEFAULT_FRACTION * total, (f"{DEFAULT_FRACTION:.0%} of this machine's "
                                       f"{total / GIB:.1f} GiB; --max-memory GiB allows more")


def duration(seconds: float) -> str:
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("hours", 3600),
                       ("minutes", 60)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def check(what: str, need: float, seconds: float | None = None,
          max_memory: float | None = None) -> None:
    """Refuse ``what`` if ``need`` bytes exceed the allowed memory (``max_memory`` GiB, see
    :func:`memory_limit`); warn if ``seconds`` is long."""
    limit, source = memory_limit(max_memory)
    if need > limit:
        raise CodermindError(f"{what} needs about {need / GIB:.3g} GiB, more than the "
                             f"{limit / GIB:.3g} GiB allowed ({source}); nothing was started")
    if seconds is not None and seconds > NEVER:
        raise CodermindError(f"{what} would take about {duration(seconds)} (estimated at "
                             f"{'this' if seconds < 1e12 else 'any'} machine's pace); "
                             "nothing was started")
    if seconds is not None and seconds > LONG:
        print(f"codermind: warning: {what} will take about {duration(seconds)} "
              "(estimated; Ctrl-C stops it)",
              file=sys.stderr, flush=True)


def worker_count(text: str) -> int:
    """``--workers``: an integer in [1, 4 x cores] (argparse type)."""
    value = _integer(text)
    cap = WORKERS_PER_CORE * cores()
    if not 1 <= value <= cap:
        raise argparse.ArgumentTypeError(f"must be in [1, {cap}] ({WORKERS_PER_CORE} per "
                                         f"core of this machine's {cores()}), got {value}")
    return value


def check_render(scene_path, width: int, height: int, spp: int, runs: int = 1,
                 pass_spp: int | None = None, max_memory: float | None = None,
                 variance: bool = False) -> None:
    """``codermind render``: a film of ``width`` x ``height`` pixels, ``spp`` samples,
    ``runs`` renders (one per light when a tutorial scene sums its lights), ``variance``
    also estimated."""
    from codermind.passes import LANE_BUDGET, tile_size
    pixels = max(int(width), 1) * max(int(height), 1)
    per = min(spp, pass_spp or max(1, LANE_BUDGET // pixels))
    passes = math.ceil(spp / per)
    tw, th = tile_size((max(int(width), 1), max(int(height), 1)))
    tile = tw * th
    need = (BASE + RENDER_PER_PIXEL * pixels + RENDER_PER_TILE_PIXEL * tile
            + (RENDER_VARIANCE_PER_PIXEL * pixels if variance else 0) + PER_PASS * passes)
    seconds = pixels * spp * runs / RENDER_RATE
    check(f"{scene_path}: rendering {width}x{height} pixels at {spp} spp", need, seconds,
          max_memory)


def check_reference(scene_path, scene, complexity: int | None = None,
                    workers: int | None = None, max_memory: float | None = None) -> None:
    """``codermind reference`` (and the port's side of ``compare``)."""
    from codermind_ref.driver import tile_shape
    per_pixel = 1 if scene.page == 1 else 4
    c = int(complexity or scene.complexity) if scene.page == 4 else 1
    samples = scene.width * scene.height * per_pixel
    rows, reps = tile_shape(scene.width * per_pixel, c)
    tiles = math.ceil(scene.height / rows) * math.ceil(c / reps)
    n = workers or 1
    need = BASE + REFERENCE_PER_SAMPLE * samples + PER_TILE * tiles + (n - 1) * (100 << 20)
    seconds = samples * c / (REFERENCE_RATE * min(n, cores()))
    check(f"{scene_path}: {scene.width}x{scene.height} pixels at complexity {c}", need, seconds,
          max_memory)


def add_max_memory(p: argparse.ArgumentParser) -> None:
    """The ``--max-memory GiB`` option of the commands whose requests are checked here."""
    from .args import positive_float
    p.add_argument("--max-memory", type=positive_float, metavar="GIB",
                   help=f"memory the request may need, GiB (default: ${ENV}, else 80 %% of "
                        "this machine's total); more than the total is allowed, for swap")
