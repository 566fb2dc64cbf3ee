"""Stability sweeps: drive each method into the regime where it fails and measure where.

Every sweep is a function ``sweep(quick: bool)`` registered in :data:`SWEEPS` (its module is
imported only when the sweep runs). It returns a :class:`Plan`, the sweep split into its
points: a list of point inputs, a module-level function computing one point (picklable inputs
and results, no shared state: on a remote runner each point is one task), and ``assemble``, which
turns the points' results, in order, into the :class:`SweepResult` on the client (or into a
further :class:`Plan`, a second round of points that depend on the first). A sweep function
may also return its ``SweepResult`` directly (computed where it is called: on the client).

A result holds the swept parameter's values, the measured quantity (as curves for the figure),
the threshold found (a number and a sentence) and the sweep's *never-happen* checks: NaN or Inf
in an output, a crash, a silent wrong answer where an error was due. :func:`run` runs sweeps
(a sweep that raises becomes a failed check, the others still run); :func:`write_report`
writes ``stability.md``, ``stability.json`` and one ``NAME.png`` per sweep.

Random inputs are drawn on the client when the plan is made, in the order the sweep always
drew them (or a point gets the generator's state to draw its own share), so a point's result
depends only on its inputs and the results are the same wherever the points ran.
"""

from __future__ import annotations

import importlib
import json
import math
import time
import traceback
from dataclasses import asdict
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .runner import LOCAL, Runner
# the sweeps' API, also importable from here
from .sweep_result import (Check, Plan, Series, SweepResult, finite_check,  # noqa: F401
                           finite_check_counts, finite_counts, first_crossing, generator,
                           states)

#: name -> (module, function, one-line description), in report order.
SWEEPS: dict[str, tuple[str, str, str]] = {
    "perlin_float32": ("sweep_noise", "perlin_float32",
                       "perlin texture (float32) vs noise coordinate magnitude"),
    "blinnphong_exponent": ("sweep_bsdf", "blinnphong_exponent",
                            "blinnphong sampling and evaluation vs exponent up to 1e6"),
    "fresnel": ("sweep_bsdf", "fresnel",
                "tutorial BSDF and port Fresnel at total internal reflection and eta = 1"),
    "thin_lens": ("sweep_lens", "thin_lens", "conic camera at zero and huge aperture"),
    "blob_neck": ("sweep_blob", "blob_neck",
                  "blob mesher vs neck thickness: topology, watertightness"),
    "zone_grazing": ("sweep_zone", "zone_grazing", "port blob zone method vs grazing rays"),
    "zone_scale": ("sweep_zone", "zone_scale", "port blob zone method vs scene scale"),
    "tone_curve": ("sweep_tone", "tone_curve",
                   "port tone curve at zero, huge and non-finite radiance"),
    "auto_exposure": ("sweep_tone", "auto_exposure", "port auto exposure on black images"),
}


def _timed(point: Callable, p) -> tuple[Any, float]:
    """One point and the seconds it took (where it ran)."""
    t0 = time.perf_counter()
    return point(p), time.perf_counter() - t0


def _crashed(name: str, e: BaseException) -> SweepResult:
    result = SweepResult(name, SWEEPS[name][2], "-", "-", "crashed", None)
    tb = traceback.format_exception(type(e), e, e.__traceback__)
    result.check("the sweep runs without an exception", False, f"{type(e).__name__}: {e}")
    result.notes.append("".join(tb[-3:]).strip())
    return result


def _start(name: str, quick: bool):
    """The sweep's first Plan (or its SweepResult) and the client seconds it took."""
    module, function, _ = SWEEPS[name]
    t0 = time.perf_counter()
    sweep = getattr(importlib.import_module(f"codermind_harness.{module}"), function)
    return sweep(quick), time.perf_counter() - t0


def run(names: list[str] | None = None, quick: bool = False,
        progress: Callable[[str], None] | None = None,
        runner: Runner = LOCAL) -> list[SweepResult]:
    """Run the named sweeps (default: all) in registry order, their points as units of
    ``runner``: here one sweep after another, with a ``progress`` line each; on a remote
    runner every sweep's points at once (under the runner's own progress line)."""
    names = list(SWEEPS) if not names else [n for n in SWEEPS if n in names]
    if runner.remote:
        return _run_remote(runner, names, quick)
    results = []
    for i, name in enumerate(names, start=1):
        if progress:
            progress(f"[{i}/{len(names)}] {name}: {SWEEPS[name][2]} ...")
        result = run_one(name, quick)
        if progress:
            state = "ok" if result.passed else "FAILED: " + "; ".join(
                c.what for c in result.checks if not c.passed)
            progress(f"[{i}/{len(names)}] {name}: {result.seconds:.1f} s, {state}")
        results.append(result)
    return results


def run_one(name: str, quick: bool = False) -> SweepResult:
    """One sweep, its points one after another here; a crash becomes a failed never-happen
    check."""
    from codermind.errors import CodermindError    # heavy: importing codermind starts Mitsuba
    t0 = time.perf_counter()
    try:
        result, _ = _start(name, quick)
        while isinstance(result, Plan):
            result = result.assemble([result.point(p) for p in result.points])
    except CodermindError:  # the environment (e.g. no usable LLVM), not the method
        raise
    except Exception as e:  # a crash is a failed never-happen check, not the end of the run
        result = _crashed(name, e)
    result.seconds = time.perf_counter() - t0
    return result


def _run_remote(runner: Runner, names: list[str], quick: bool) -> list[SweepResult]:
    """Every sweep's points submitted at once (one task each), each sweep assembled here in
    registry order as its points come back. ``seconds``: the client's time for the plans and
    assembly plus the points' times on the workers."""
    from codermind.errors import CodermindError
    state: dict[str, list] = {}         # name -> [plan or result or exception, futures, s]
    for name in names:
        try:
            plan, seconds = _start(name, quick)
        except CodermindError:
            raise
        except Exception as e:          # noqa: BLE001  (a crash of the sweep's plan)
            plan, seconds = e, 0.0
        futures = (runner.submit_all(_timed, [(plan.point, p) for p in plan.points])
                   if isinstance(plan, Plan) else [])
        state[name] = [plan, futures, seconds]
    results = []
    for name in names:
        plan, futures, seconds = state[name]
        try:
            if isinstance(plan, Exception):
                raise plan
            while isinstance(plan, Plan):
                timed = list(runner.results(futures))
                seconds += sum(s for _, s in timed)
                t0 = time.perf_counter()
                plan = plan.assemble([r for r, _ in timed])
                seconds += time.perf_counter() - t0
                if isinstance(plan, Plan):
                    futures = runner.submit_all(_timed, [(plan.point, p) for p in plan.points])
            result = plan
        except CodermindError:
            raise
        except Exception as e:          # noqa: BLE001  (a crashed point or assembly)
            result = _crashed(name, e)
        result.seconds = seconds
        results.append(result)
    return results


# -- report --------------------------------------------------------------------------------

def _fmt(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.3g}"


def _cell(text: str, limit: int = 300) -> str:
    """Text fit for one markdown table cell: one line, pipes escaped, bounded length."""
    text = " ".join(str(text).split()).replace("|", "\\|")
    return text if len(text) <= limit else text[:limit - 3] + "..."


def markdown_table(results: list[SweepResult]) -> str:
    lines = ["| sweep | swept | measured | threshold | never-happen checks |",
             "| --- | --- | --- | --- | --- |"]
    for r in results:
        failed = [c for c in r.checks if not c.passed]
        state = (f"{len(r.checks)} pass" if not failed else
                 f"**{len(failed)} of {len(r.checks)} FAIL**: " + "; ".join(
                     f"{c.what} ({c.detail})" for c in failed))
        lines.append(f"| `{r.name}` | {_cell(r.parameter)} | {_cell(r.measured)} | "
                     f"{_cell(r.threshold, 600)} | {_cell(state, 600)} |")
    return "\n".join(lines) + "\n"


def markdown_report(results: list[SweepResult], command: str) -> str:
    out = [f"# Stability sweeps\n\nGenerated by `{command}`.\n", markdown_table(results)]
    for r in results:
        out.append(f"\n## `{r.name}`: {r.title}\n\n![{r.name}]({r.name}.png)\n")
        for c in r.checks:
            out.append(f"- [{'x' if c.passed else ' '}] {c.what}: {c.detail}")
        for note in r.notes:
            out.append(f"- note: {note}")
        out.append(f"- time: {r.seconds:.1f} s")
    return "\n".join(out) + "\n"


def _jsonable(value):
    if isinstance(value, float):
        return float(f"{value:.6g}") if math.isfinite(value) else str(value)
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return _jsonable(value.item())
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value


def to_json(results: list[SweepResult]) -> str:
    records = []
    for r in results:
        d = asdict(r)
        d.pop("image")
        d.pop("series")                 # the curves are in the PNGs; the table has the numbers
        d["passed"] = r.passed
        records.append(d)
    return json.dumps(_jsonable(records), indent=1)


def plot(result: SweepResult, path: Path) -> None:
    """The sweep's figure: its curves (and image, if any), written atomically as PNG."""
    from matplotlib.figure import Figure      # without pyplot: the caller's backend stays

    panels = 2 if result.image is not None else 1
    fig = Figure(figsize=(5.2 * panels, 3.6), dpi=80)
    axes = fig.subplots(1, panels, squeeze=False)
    ax = axes[0, 0]
    for s in result.series:
        x, y = np.asarray(s.x, float), np.asarray(s.y, float)
        if result.ylog:
            y = np.where(y > 0, y, np.nan)
        ax.plot(x, y, s.style, label=s.label, markersize=3, color=s.color)
    for axis, value, label in result.lines:
        (ax.axvline if axis == "x" else ax.axhline)(value, color="grey", ls="--", lw=0.8)
        if label:
            ax.annotate(label, xy=(value, 0.02) if axis == "x" else (0.02, value),
                        xycoords=("data", "axes fraction") if axis == "x" else
                        ("axes fraction", "data"), fontsize=7, color="grey",
                        rotation=90 if axis == "x" else 0)
    if result.xlog:
        ax.set_xscale("log")
    if result.ylog:
        ax.set_yscale("log")
    ax.set_xlabel(result.xlabel)
    ax.set_ylabel(result.ylabel)
    ax.set_title(result.title, fontsize=9)
    if result.series:
        ax.legend(fontsize=7)
    ax.grid(True, which="both", lw=0.3)
    if result.image is not None:
        ax2 = axes[0, 1]
        img = np.asarray(result.image, dtype=float)
        shown = ax2.imshow(np.clip(img, 0, 1) if img.ndim == 3 else img,
                           cmap=None if img.ndim == 3 else "viridis", interpolation="nearest")
        if img.ndim == 2:
            fig.colorbar(shown, ax=ax2, shrink=0.8)
        ax2.set_title(result.image_title, fontsize=9)
        ax2.set_xticks([])
        ax2.set_yticks([])
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp")
    with np.errstate(over="ignore"):       # log axes reaching 1e308
        fig.savefig(tmp, format="png")
    tmp.replace(path)


def write_report(results: list[SweepResult], outdir: Path, command: str) -> dict[str, Path]:
    """stability.md, stability.json and NAME.png per sweep in ``outdir`` (atomic writes)."""
    outdir.mkdir(parents=True, exist_ok=True)
    paths = {}
    for r in results:
        paths[r.name] = outdir / f"{r.name}.png"
        plot(r, paths[r.name])
    for name, text in (("stability.md", markdown_report(results, command)),
                       ("stability.json", to_json(results))):
        path = outdir / name
        tmp = path.with_name(f".{name}.tmp")
        tmp.write_text(text)
        tmp.replace(path)
        paths[name] = path
    return paths
