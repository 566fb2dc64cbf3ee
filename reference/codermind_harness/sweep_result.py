"""What a stability sweep returns (:mod:`.stability`): a :class:`SweepResult` with its
curves and never-happen checks, or a :class:`Plan` of points computed one per unit of a
runner; and the helpers the sweeps share (finite checks, first crossings, the random
generator states a plan hands to its points). The sweep modules import this, never
:mod:`.stability`, which imports them by name when a sweep runs."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np


@dataclass
class Check:
    """A never-happen assertion: ``what`` must hold; ``detail`` says what was seen."""
    what: str
    passed: bool
    detail: str = ""


@dataclass
class Series:
    """One curve of the figure."""
    label: str
    x: list[float]
    y: list[float]
    style: str = "o-"
    color: str | None = None        # matplotlib colour; None: the next of the cycle


@dataclass
class SweepResult:
    name: str
    title: str
    parameter: str                  # what is swept (with its range)
    measured: str                   # what is measured
    threshold: str                  # the threshold found, in words, with its number
    threshold_value: float | None   # the number (None: nothing failed in the range)
    checks: list[Check] = field(default_factory=list)
    series: list[Series] = field(default_factory=list)
    xlabel: str = ""
    ylabel: str = ""
    xlog: bool = True
    ylog: bool = True
    lines: list[tuple[str, float, str]] = field(default_factory=list)  # ("x"|"y", value, label)
    image: np.ndarray | None = None           # optional picture (H, W) or (H, W, 3)
    image_title: str = ""
    table: list[dict] = field(default_factory=list)   # per-value rows for the JSON
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def check(self, what: str, passed, detail: str = "") -> bool:
        self.checks.append(Check(what, bool(passed), detail))
        return bool(passed)


def finite_check(result: SweepResult, what: str, *arrays) -> bool:
    """Record a check that every value of ``arrays`` is finite."""
    return finite_check_counts(result, what, [finite_counts(*arrays)])


def first_crossing(xs, ys, limit: float) -> float | None:
    """The first x whose y exceeds ``limit`` (None if none does); NaN counts as exceeding."""
    for x, y in zip(xs, ys):
        if not (y <= limit):
            return float(x)
    return None


def finite_counts(*arrays) -> tuple[int, int]:
    """(non-finite values, values) of ``arrays``: what a point returns for a later
    :func:`finite_check_counts` instead of the arrays themselves."""
    bad = sum(int(np.size(a) - np.isfinite(np.asarray(a, dtype=np.float64)).sum()) for a in arrays)
    return bad, sum(int(np.size(a)) for a in arrays)


def finite_check_counts(result: SweepResult, what: str, counts) -> bool:
    """:func:`finite_check` from points' :func:`finite_counts` (summed)."""
    bad = sum(c[0] for c in counts)
    total = sum(c[1] for c in counts)
    return result.check(what, bad == 0, f"{bad} of {total} values non-finite")


@dataclass
class Plan:
    """A sweep as points: ``point(p)`` for each ``p`` of ``points`` (one task each on a
    remote runner: ``point`` a module-level function, ``p`` and its result picklable), then
    ``assemble(results)`` on the client, the results in the order of ``points``; it returns
    the :class:`SweepResult`, or a further Plan (points that depend on these results)."""
    points: list
    point: Callable[[Any], Any]
    assemble: Callable[[list], Any]


def states(rng: np.random.Generator, draw: Callable[[np.random.Generator], Any],
           count: int) -> list[dict]:
    """The generator's state before each of ``count`` successive ``draw(rng)`` (the draws are
    made here and dropped): a point given its state makes its own draw with :func:`generator`,
    the numbers the sweep drew when it ran in one piece."""
    out = []
    for _ in range(count):
        out.append(rng.bit_generator.state)
        draw(rng)
    return out


def generator(state: dict) -> np.random.Generator:
    """A generator in ``state`` (from :func:`states`)."""
    bits = getattr(np.random, state["bit_generator"])()
    bits.state = state
    return np.random.Generator(bits)
