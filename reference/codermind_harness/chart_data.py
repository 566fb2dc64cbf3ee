"""What a ``codermind chart`` run measures and how it is analysed: the configurations, the
points, log-log fits, Pareto fronts and equal-error ratios. Shared by :mod:`.chart` (the
error-versus-time runs), :mod:`.chart_cost` (cost scaling) and :mod:`.chart_report` (the
files and the table); it imports neither of them."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def scenes_dir() -> Path:
    """The bundled scenes: the repository's scenes/ or the installed copy (codermind.bundled)."""
    from codermind.bundled import scenes_dir as find
    return find()


SCENES = ("page1", "page2", "page3", "page4", "garden")
#: Value used to draw an error of exactly 0 on a log axis (the reference itself).
ZERO_FLOOR = 1e-10
REF_SEED, SWEEP_SEED, PORT_SEED = 1000, 1, 0
THRESHOLD = 1e-3


@dataclass(frozen=True)
class Config:
    """What a run renders (``full`` or ``quick``)."""
    name: str
    crops: dict            #: scene -> rect (x0, y0, x1, y1) tutorial pixels, y up; None: all
    spp: tuple             #: Mitsuba spp sweep of a random scene
    det_spp: tuple         #: spp sweep of a deterministic scene (cost only)
    complexity: tuple      #: port Complexity sweep of a random scene
    max_error: tuple       #: blob max_error sweep (page 4)
    ref_spp: int
    scalar_rect: tuple
    scalar_spp: tuple
    garden_size: tuple = (160, 120)
    repeats: int = 3
    cheap_s: float = 30.0     #: points slower than this (first run) are run once
    strides: tuple = (16, 8, 4, 2, 1)     #: cost vs pixels: 1/s of the resolution
    sources: tuple = (1, 2, 4, 8, 16)
    maximal_spp: int = 64
    ref_max_error: float | None = 0.02     #: the reference's blob (None: the chooser's)
    maximal_divisor: float = 4.0           #: the maximal model's blob max_error divisor


FULL = Config(
    "full", crops={"page4": (272, 220, 368, 292)},
    spp=(1, 2, 4, 8, 16, 32, 64), det_spp=(1, 4, 16, 64), complexity=(1, 2, 4, 8, 16, 32),
    max_error=(0.6, 0.3, 0.15, 0.0865, 0.04), ref_spp=1024,
    scalar_rect=(300, 240, 316, 252), scalar_spp=(1, 2, 4))
QUICK = Config(
    "quick", crops={s: (300, 240, 316, 252) for s in SCENES},
    spp=(1, 2, 4), det_spp=(1, 2), complexity=(1, 2), max_error=(0.6, 0.3), ref_spp=32,
    scalar_rect=(304, 244, 308, 247), scalar_spp=(1,), repeats=1,
    strides=(32, 16), sources=(1, 2), maximal_spp=4,
    ref_max_error=None, maximal_divisor=1.0, garden_size=(32, 24))


@dataclass
class Point:
    scene: str
    method: str
    param: str               #: what the series sweeps (spp, complexity, max_error, model)
    value: float
    spp: int
    seconds: float           #: median wall time (load + render for Mitsuba)
    load_seconds: float
    runs: list = field(default_factory=list)
    rel_mse: float = float("nan")
    flip: float = float("nan")
    triangles: int | None = None
    panel: str = "main"      #: "main" (the scene's crop) or "scalar" (the scalar crop)
    front_rel_mse: bool = False
    front_flip: bool = False


# -- analysis --------------------------------------------------------------------------------

def pareto_front(times, errors) -> np.ndarray:
    """Mask of the points no other point beats in both time and error (<= in both, < in
    one). NaN errors are never on the front."""
    t, e = np.asarray(times, float), np.asarray(errors, float)
    ok = np.isfinite(t) & np.isfinite(e)
    front = np.zeros(t.size, bool)
    for i in np.flatnonzero(ok):
        dominated = ok & (t <= t[i]) & (e <= e[i]) & ((t < t[i]) | (e < e[i]))
        front[i] = not dominated.any()
    return front


def fit_slope(x, y) -> float:
    """Least-squares slope of log y against log x (NaN with fewer than two usable points)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def fit_noise_floor(spp, errors) -> tuple[float, float]:
    """(a, b) of error = a / spp + b, least squares in relative terms (each point weighted by
    1 / error): a is the one-sample noise, b the floor (bias and the reference's noise)."""
    s, e = np.asarray(spp, float), np.asarray(errors, float)
    ok = (s > 0) & (e > 0) & np.isfinite(e)
    if ok.sum() < 2:
        return float("nan"), float("nan")
    s, e = s[ok], e[ok]
    (a, b), *_ = np.linalg.lstsq(np.stack([1 / (s * e), 1 / e], axis=1), np.ones(s.size),
                                 rcond=None)
    return float(a), float(b)


def time_to_reach(times, errors, target: float) -> float | None:
    """Wall time at which a series first reaches ``target`` error, interpolated log-log
    between its points in order of time; None if it never does."""
    pts = sorted((t, e) for t, e in zip(times, errors) if t > 0 and np.isfinite(e))
    prev = None
    for t, e in pts:
        if e <= target:
            if prev is None or prev[1] <= 0 or e <= 0:
                return t
            (t0, e0), (lt, le) = prev, (math.log(t), math.log(max(e, ZERO_FLOOR)))
            f = (math.log(target) - math.log(e0)) / (le - math.log(e0))
            return math.exp(math.log(t0) + f * (lt - math.log(t0)))
        prev = (t, e)
    return None


def equal_error_ratio(port: list[Point], mitsuba: list[Point]) -> list[float]:
    """t_port / t_mitsuba at the port's errors, Mitsuba's log time interpolated in log
    error (only inside Mitsuba's range)."""
    ms = sorted((p.rel_mse, p.seconds) for p in mitsuba if p.rel_mse > 0)
    if len(ms) < 2:
        return []
    le = np.log([e for e, _ in ms])
    lt = np.log([t for _, t in ms])
    out = []
    for p in port:
        if p.rel_mse > 0 and le[0] <= math.log(p.rel_mse) <= le[-1]:
            out.append(p.seconds / math.exp(float(np.interp(math.log(p.rel_mse), le, lt))))
    return out


def log(msg: str) -> None:
    print(f"chart: {msg}", file=sys.stderr, flush=True)
