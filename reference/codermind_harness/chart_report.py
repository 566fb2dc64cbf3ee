"""``codermind chart`` outputs: per-scene ``error_vs_time_<scene>.png/.csv``,
``cost_scaling.png/.csv``, ``chart.json`` and the printed table (atomic writes)."""

from __future__ import annotations

import csv
import io
import json
import math
import os
from dataclasses import asdict
from pathlib import Path

import numpy as np

from .chart_data import (THRESHOLD, ZERO_FLOOR, Point, equal_error_ratio, fit_noise_floor,
                    time_to_reach)

POINT_COLUMNS = ("scene", "method", "param", "value", "spp", "seconds", "load_seconds", "runs",
                 "rel_mse", "flip", "triangles", "panel", "front_rel_mse", "front_flip")
COST_COLUMNS = ("experiment", "method", "x_name", "x", "seconds", "runs", "triangles",
                "max_error", "slope")
MARKERS = {"mitsuba spp": "o", "mitsuba max_error": "s", "port clean": "^", "chooser pick": "*",
           "maximal model": "P", "scalar_rgb": "v", "llvm_ad_rgb (scalar crop)": "o"}


def _write_bytes(path: Path, data: bytes) -> None:
    from codermind.imageio import atomic_path
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def _csv(rows: list[dict], columns) -> bytes:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (" ".join(f"{t:.4f}" for t in v) if isinstance(v, list) else
                        ("" if v is None else v)) for k, v in r.items()})
    return buf.getvalue().encode()


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _figure(panels: int, figsize: tuple[float, float]):
    """A figure and its row of axes, made without pyplot: its global backend and current
    figure stay the caller's (a notebook keeps showing its own plots)."""
    from matplotlib.figure import Figure      # heavy
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(1, panels)


def scene_figure(result: dict, load: str) -> bytes:
    pts: list[Point] = result["points"]
    scalar = [p for p in pts if p.panel == "scalar"]
    panels = [("rel_mse", "relative MSE (linear)", "main"), ("flip", "mean FLIP", "main")]
    if scalar:
        panels.append(("rel_mse", "relative MSE (linear), scalar crop", "scalar"))
    fig, axes = _figure(len(panels), (5.2 * len(panels), 4.4))
    for ax, (metric, label, panel) in zip(np.atleast_1d(axes), panels):
        sub = [p for p in pts if p.panel == panel]
        positive = [getattr(p, metric) for p in sub if getattr(p, metric) > 0]
        # an error of exactly 0 (the reference itself) is drawn at the axis floor
        floor = min(positive) / 10 if positive else ZERO_FLOOR
        if len(positive) < len(sub):
            ax.axhline(floor, color="k", lw=0.5)
            ax.text(0.98, 0.035, "bottom line: error 0 (the reference itself)", ha="right",
                    transform=ax.transAxes, fontsize=7)
        for method in dict.fromkeys(p.method for p in sub):
            ser = sorted((p for p in sub if p.method == method), key=lambda p: p.seconds)
            y = [max(getattr(p, metric), floor) for p in ser]
            ax.plot([p.seconds for p in ser], y, marker=MARKERS.get(method, "o"),
                    ms=9 if method == "chooser pick" else 5, label=method,
                    ls="-" if len(ser) > 1 else "none")
        if panel == "main":
            front = sorted((p for p in sub if getattr(p, f"front_{metric}")),
                           key=lambda p: p.seconds)
            ax.plot([p.seconds for p in front],
                    [max(getattr(p, metric), floor) for p in front], color="k", lw=2.5,
                    alpha=0.25, marker="o", mfc="none", ms=13, label="Pareto front")
        if metric == "rel_mse" and result.get("reference_noise_rel_mse"):
            ax.axhline(result["reference_noise_rel_mse"], color="grey", ls=":",
                       label="reference noise floor")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time, s")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    crop = result["crop"]
    where = (f"{crop[2]}x{crop[3]} px (-D resx, resy)" if result["scene"] == "garden" else
             f"crop {crop[2] - crop[0]}x{crop[3] - crop[1]} px at ({crop[0]}, {crop[1]})")
    fig.suptitle(f"{result['scene']}: {where}; reference: {result['reference']}; {load}",
                 fontsize=8)
    fig.tight_layout()
    return _png(fig)


def cost_figure(rows: list[dict], slopes: dict, load: str) -> bytes:
    exps = list(dict.fromkeys(r["experiment"] for r in rows))
    fig, axes = _figure(len(exps), (4.6 * len(exps), 4.2))
    for ax, exp in zip(np.atleast_1d(axes), exps):
        sub = [r for r in rows if r["experiment"] == exp]
        for method in dict.fromkeys(r["method"] for r in sub):
            ser = sorted((r for r in sub if r["method"] == method), key=lambda r: r["x"])
            s = slopes.get(f"{exp} / {method}", float("nan"))
            ax.plot([r["x"] for r in ser], [r["seconds"] for r in ser], marker="o",
                    label=f"{method} (slope {s:.2f})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(sub[0]["x_name"])
        from matplotlib.ticker import NullFormatter
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_ylabel("wall time, s")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"cost scaling (log-log slopes fitted); {load}", fontsize=8)
    fig.tight_layout()
    return _png(fig)


def summary(result: dict) -> dict:
    """Per method: best error and its time, front membership, time to reach THRESHOLD."""
    pts: list[Point] = result["points"]
    out = {}
    for method in dict.fromkeys(p.method for p in pts):
        ser = [p for p in pts if p.method == method]
        best = min(ser, key=lambda p: (p.rel_mse, p.seconds))
        out[method] = {
            "best_rel_mse": best.rel_mse, "best_flip": min(p.flip for p in ser),
            "seconds_at_best": best.seconds, "panel": ser[0].panel,
            "on_front": any(p.front_rel_mse for p in ser),
            **{f"seconds_to_rel_mse_{t:g}": time_to_reach(
                [p.seconds for p in ser], [p.rel_mse for p in ser], t)
               for t in (10 * THRESHOLD, THRESHOLD)}}
        if method in ("mitsuba spp", "port clean") and len(ser) > 2:
            # rel MSE = a / spp + b; time = load + c spp from the largest point: the time to
            # reach THRESHOLD from the noise term alone (None when b is above it)
            a, b = fit_noise_floor([p.spp for p in ser], [p.rel_mse for p in ser])
            big = max(ser, key=lambda p: p.spp)
            c = (big.seconds - big.load_seconds) / big.spp
            need = a / (THRESHOLD - b) if b < THRESHOLD else None
            out[method].update({"fit_a": a, "fit_b": b, "seconds_per_spp": c,
                                f"extrapolated_seconds_to_rel_mse_{THRESHOLD:g}":
                                    None if need is None else big.load_seconds + c * need})
    port = [p for p in pts if p.method == "port clean"]
    mit = [p for p in pts if p.method == "mitsuba spp"]
    ratios = equal_error_ratio(port, mit)
    extra = {"port_over_mitsuba_at_equal_rel_mse": ratios,
             "port_over_mitsuba_median": float(np.median(ratios)) if ratios else None}
    # render time only (the load is the same work in both variants)
    sc = {p.spp: p.seconds - p.load_seconds for p in pts if p.method == "scalar_rgb"}
    ll = {p.spp: p.seconds - p.load_seconds for p in pts
          if p.method == "llvm_ad_rgb (scalar crop)"}
    if sc:
        extra["scalar_over_llvm_by_spp"] = {s: sc[s] / ll[s] for s in sc if s in ll}
    return {"methods": out, **extra}


def table(results: list[dict]) -> str:
    lines = [f"{'scene':7} {'method':27} {'best relMSE':>11} {'FLIP':>7} {'time s':>8} "
             f"{'front':>5} {'t@1e-2 s':>9} {'t@1e-3 s':>9}"]
    for res in results:
        for method, s in res["summary"]["methods"].items():
            t2, t = (s[f"seconds_to_rel_mse_{x:g}"] for x in (10 * THRESHOLD, THRESHOLD))
            lines.append(f"{res['scene']:7} {method:27} {s['best_rel_mse']:11.3g} "
                         f"{s['best_flip']:7.4f} {s['seconds_at_best']:8.2f} "
                         f"{('yes' if s['on_front'] else 'no') if s['panel'] == 'main' else '-':>5} "
                         f"{'-' if t2 is None else f'{t2:.2f}':>9} "
                         f"{'-' if t is None else f'{t:.2f}':>9}")
    return "\n".join(lines) + "\n"


def _clean(x):
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return _clean(x.item())
    return x


def write(outdir: Path, results: list[dict], cost_rows: list[dict], slopes: dict,
          meta: dict) -> list[Path]:
    outdir.mkdir(parents=True, exist_ok=True)
    load = meta["load_text"]
    paths = []
    for res in results:
        rows = [asdict(p) for p in res["points"]]
        for stem, data in ((f"error_vs_time_{res['scene']}.csv", _csv(rows, POINT_COLUMNS)),
                           (f"error_vs_time_{res['scene']}.png", scene_figure(res, load))):
            _write_bytes(outdir / stem, data)
            paths.append(outdir / stem)
    if cost_rows:
        for r in cost_rows:
            r["slope"] = slopes.get(f"{r['experiment']} / {r['method']}")
        _write_bytes(outdir / "cost_scaling.csv", _csv(cost_rows, COST_COLUMNS))
        _write_bytes(outdir / "cost_scaling.png", cost_figure(cost_rows, slopes, load))
        paths += [outdir / "cost_scaling.csv", outdir / "cost_scaling.png"]
    doc = {**meta, "scenes": [{**{k: v for k, v in r.items() if k != "points"},
                               "points": [asdict(p) for p in r["points"]]} for r in results],
           "cost_scaling": cost_rows, "cost_slopes": slopes}
    _write_bytes(outdir / "chart.json", (json.dumps(_clean(doc), indent=1) + "\n").encode())
    paths.append(outdir / "chart.json")
    return paths


def load_text(before, after) -> str:
    return (f"load average {before[0]:.1f} -> {after[0]:.1f} on {os.cpu_count()} cores")
