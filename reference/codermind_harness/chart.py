"""``codermind chart``: error against a converged reference versus wall time, per bundled
tutorial scene and method, with the Pareto front; and how the cost grows with the work.

Methods (each a series of points, one point per setting):

* ``mitsuba spp``: the converted XML (llvm_ad_rgb, the chooser's depth and blob, lights
  summed as the tutorial does) over a sweep of samples per sub-sample;
* ``mitsuba max_error``: the same at the chooser's spp over a sweep of the blob's
  ``max_error`` (page 4), on the blob's mesh (``blob_tessellate`` true: the default
  analytic blob has no mesh);
* ``port clean``: ``codermind_ref.render`` in clean mode over a sweep of Complexity (2
  workers; pages 1-2 have no Complexity: one point);
* ``chooser pick`` / ``maximal model``: the XML as ``codermind convert`` made it (the model
  chooser's depth, spp, blob) and the maximal model (depth 10, 64 spp, blob max_error / 4);
* ``scalar_rgb`` / ``llvm_ad_rgb (scalar crop)``: both variants over a few spp on a small
  crop (scalar_rgb runs the Python plugins once per ray), on their own panel.

The reference (see :func:`reference`): a scene in which nothing is random (pages 1-3) is
exact at one ray per sub-sample, and the independent port in clean mode at Complexity 1 is
the reference. Page 4 is random: the reference is Mitsuba's full model (depth 10, lights
summed) with a finer blob (``max_error`` 0.02, a quarter of the chooser's) at ``ref_spp``
samples (16 x the sweep's largest) and another seed; the port's curve is the cross-check (a
bias between the sides would flatten it above the reference's noise floor, which is
reported: the mean of var_ref / (ref^2 + 0.01)).

Timings: each point's wall time is the median over ``repeats`` runs (points whose first
run took over ``cheap_s`` seconds run once); the methods run interleaved in each repeat
round, in a rotated order. Mitsuba points are load (parse + blob mesh) + render, after an
untimed 1-spp render whenever the scene is rendered after another one (JIT compilation,
cached by Dr.Jit across runs, is not counted); port points are the render.
"""

from __future__ import annotations

import functools
import os
import re
import statistics
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

import codermind_ref
from codermind.variants import set_variant

from . import chart_cost, chart_report
from .bundle import Bundle
from .chart_data import (FULL, PORT_SEED, QUICK, REF_SEED, SCENES, SWEEP_SEED, THRESHOLD,
                         Config, Point, log, pareto_front, scenes_dir)
from .metrics import flip, rel_mse
from .runner import LOCAL, Runner
from .sides import Grid, HarnessError, encode_mitsuba, load_mitsuba, parse, port_exposure, twin_of


# -- rendering -------------------------------------------------------------------------------

class MitsubaRunner:
    """Loaded scenes (one per crop and ``-D`` overrides); a scene is warmed up (one untimed
    1-spp render) whenever it is rendered after another one. It pickles as its XML's
    :class:`Bundle` and unpickles as the one runner of that bundle in the receiving process
    (a chart point on a worker keeps that process's loaded scenes)."""

    def __init__(self, xml: Path, width: int, height: int, page: int):
        self.xml, self.width, self.height, self.page = xml, width, height, page
        self.cache: dict = {}
        self.last = None
        self.warmups: list[float] = []      #: seconds of the untimed warm-up renders
        self._bundle: Bundle | None = None

    def __reduce__(self):
        if self._bundle is None:
            self._bundle = Bundle.of(self.xml)
        return _runner_of, (self._bundle, self.width, self.height, self.page)

    def get(self, rect, defines: dict, variant: str = "llvm_ad_rgb"):
        from codermind.tutorial.render import light_scenes     # heavy: Mitsuba
        key = (tuple(rect), tuple(sorted(defines.items())), variant)
        if key not in self.cache:
            set_variant(variant)
            grid = Grid.of(self.width, self.height, self.page, rect=rect)
            t0 = time.perf_counter()
            scene, settings = load_mitsuba(self.xml, grid, {k: str(v) for k, v in defines.items()})
            load = time.perf_counter() - t0
            scenes = light_scenes(scene) if settings.lights == "sum" else [scene]
            tris = sum(int(s.face_count()) for s in scene.shapes() if s.is_mesh()) or None
            self.cache[key] = (grid, scenes, settings, load, tris)
        return key, self.cache[key]

    def render(self, rect, defines: dict, spp: int, seed: int, variant: str = "llvm_ad_rgb",
               variance: bool = False, label: str | None = None):
        from codermind.passes import Progress      # heavy: Mitsuba
        from codermind.tutorial.render import render_linear
        key, (grid, scenes, settings, load, tris) = self.get(rect, defines, variant)
        set_variant(variant)
        if key != self.last and variant != "scalar_rgb":
            # the first render of a scene after another one pays ~1 s again (the kernel is
            # compiled or looked up again): an untimed 1-spp render, its time kept apart
            t0 = time.perf_counter()
            render_linear(scenes, 1, 12345)
            self.warmups.append(time.perf_counter() - t0)
        self.last = key
        bar = Progress(spp, label=f"chart: {label}") if label else None
        t0 = time.perf_counter()
        mean, var, _, _ = render_linear(scenes, spp, seed, variance=variance, progress=bar)
        seconds = time.perf_counter() - t0
        lin = grid.take(mean.astype(np.float64))
        v = grid.take(var.astype(np.float64)) if var is not None else None
        return lin, v, seconds, load, tris, settings

    def drop(self, variant: str) -> None:
        for key in [k for k in self.cache if k[2] == variant]:
            del self.cache[key]


#: Per process: the runner of each bundle (:meth:`MitsubaRunner.__reduce__`).
_RUNNERS: dict[str, MitsubaRunner] = {}


def _runner_of(bundle: Bundle, width: int, height: int, page: int) -> MitsubaRunner:
    runner = _RUNNERS.get(bundle.digest)
    if runner is None:
        runner = _RUNNERS[bundle.digest] = MitsubaRunner(bundle.materialize(), width, height,
                                                         page)
    return runner


def _mitsuba_point(runner: MitsubaRunner, rect, defines: dict, spp: int,
                   variant: str = "llvm_ad_rgb"):
    """A Mitsuba point: (linear, seconds with the load, load seconds, triangles)."""
    lin, _, secs, load, tris, _ = runner.render(rect, defines, spp, SWEEP_SEED, variant)
    return lin, load + secs, load, tris


def _port_point(scene, rect, complexity: int, exposure):
    """A port point: (linear, seconds, 0, None)."""
    lin, secs = _port(scene, rect, complexity, exposure)
    return lin, secs, 0.0, None


def _port(scene, rect, complexity: int, exposure):
    t0 = time.perf_counter()
    r = codermind_ref.render(scene, "clean", PORT_SEED, complexity, exposure=exposure,
                             rect=rect, workers=2)
    return r.linear.astype(np.float64), time.perf_counter() - t0


@dataclass
class Job:
    method: str
    param: str
    value: float
    spp: int
    run: Callable            #: () -> (linear, seconds, load_seconds, triangles)
    panel: str = "main"
    linear: np.ndarray | None = None
    runs: list = field(default_factory=list)
    load: float = 0.0
    tris: int | None = None


def _interleave(jobs: list[Job], cfg: Config, label: str, runner: Runner) -> None:
    """Run every job once, then the cheap ones again, round-robin, rotating the order; each
    round's jobs are units of ``runner``, one point each."""
    for rnd in range(cfg.repeats):
        todo = [j for j in jobs if rnd == 0 or j.runs[0] < cfg.cheap_s]
        todo = todo[rnd % max(len(todo), 1):] + todo[:rnd % max(len(todo), 1)]
        outs = runner.run_calls([j.run for j in todo])
        for k, (job, out) in enumerate(zip(todo, outs)):
            lin, secs, load, tris = out
            job.runs.append(secs)
            job.load, job.tris = load, tris
            if job.linear is None:
                job.linear = lin
            log(f"{label} round {rnd + 1}/{cfg.repeats} [{k + 1}/{len(todo)}] {job.method} "
                 f"{job.param}={job.value:g}: {secs:.2f} s")


def reference(mits: MitsubaRunner, scene, rect, cfg: Config, det: bool):
    """(linear, variance or None, description, seconds) of the converged reference."""
    t0 = time.perf_counter()
    if det:
        lin, _ = _port(scene, rect, 1, None if scene.page == 1 else 1.0)
        return lin, None, "port clean, Complexity 1 (nothing random: exact)", \
            time.perf_counter() - t0
    defines = {} if cfg.ref_max_error is None else {"blob0_max_error": cfg.ref_max_error}
    lin, var, *_ = mits.render(rect, defines, cfg.ref_spp, REF_SEED, variance=True,
                               label="reference")
    blob = "the chooser's" if cfg.ref_max_error is None else f"{cfg.ref_max_error}"
    return lin, var, (f"Mitsuba full model, blob max_error {blob}, {cfg.ref_spp} spp, "
                      f"seed {REF_SEED}"), time.perf_counter() - t0


def chart_scene(name: str, cfg: Config, runner: Runner = LOCAL) -> dict:
    """Every method's points on one bundled scene, with errors against the reference; the
    points are units of ``runner``."""
    from codermind.tutorial.model import choose     # heavy: Mitsuba
    from codermind.tutorial.render import read_settings
    if name == "garden":
        return chart_garden(cfg)
    txt, xml = twin_of(scenes_dir() / f"{name}.xml")
    scene = parse(txt)
    settings = read_settings(xml)
    w, h = scene.width, scene.height
    rect = cfg.crops.get(name) or (0, 0, w, h)
    Grid.of(w, h, scene.page, rect=rect)
    det = not choose(scene, exposure=1.0, max_depth=11, spp=1).stochastic
    exposure = port_exposure(scene, PORT_SEED)
    mits = MitsubaRunner(xml, w, h, scene.page)
    chosen = _xml_defaults(xml)
    log(f"{name}: {'deterministic' if det else 'random'}, crop {rect}, exposure {exposure}")
    ref_lin, ref_var, ref_desc, ref_s = reference(mits, scene, rect, cfg, det)
    log(f"{name}: reference ({ref_desc}) in {ref_s:.1f} s")

    def mitsuba(defines, spp):
        return functools.partial(_mitsuba_point, mits, rect, defines, spp)

    def port(c):
        return functools.partial(_port_point, scene, rect, c, exposure)

    base = {k: v for k, v in chosen.items() if k in ("blob0_max_error",)}
    jobs = [Job("mitsuba spp", "spp", s, s, mitsuba(base, s))
            for s in (cfg.det_spp if det else cfg.spp)]
    if "blob0_max_error" in chosen:
        # the mesh's error and cost against max_error (the default analytic blob has no mesh)
        mesh = {"blob_tessellate": "true"} if "$blob_tessellate" in Path(xml).read_text() else {}
        jobs += [Job("mitsuba max_error", "max_error", e, int(chosen["spp"]),
                     mitsuba({"blob0_max_error": e, **mesh}, int(chosen["spp"])))
                 for e in cfg.max_error]
    cs = cfg.complexity if (scene.page == 4 and not det) else (
        (1, 4)[:len(cfg.det_spp)] if scene.page == 4 else (1,))
    jobs += [Job("port clean", "complexity", c, c, port(c)) for c in cs]
    jobs.append(Job("chooser pick", "model", 0, int(chosen["spp"]),
                    mitsuba(base, int(chosen["spp"]))))
    maximal = {k: float(v) / cfg.maximal_divisor for k, v in base.items()}
    jobs.append(Job("maximal model", "model", 1, cfg.maximal_spp,
                    mitsuba(maximal, cfg.maximal_spp)))
    _interleave(jobs, cfg, name, runner)

    points = [_point(name, j, ref_lin, settings, exposure, rect) for j in jobs]
    points += _scalar_points(name, mits, cfg, ref_lin, rect, settings, exposure, runner)
    for metric in ("rel_mse", "flip"):
        main = [p for p in points if p.panel == "main"]
        for p, on in zip(main, pareto_front([p.seconds for p in main],
                                            [getattr(p, metric) for p in main])):
            setattr(p, f"front_{metric}", bool(on))
    floor = None
    if ref_var is not None:
        floor = float(np.mean(ref_var / (np.square(ref_lin) + 0.01)))
    return {"scene": name, "xml": f"scenes/{xml.name}", "crop": list(rect),
            "deterministic": det, "exposure": exposure, "reference": ref_desc,
            "reference_seconds": ref_s, "reference_noise_rel_mse": floor,
            "warmup_seconds_median": statistics.median(mits.warmups) if mits.warmups else None,
            "chosen_model": chosen, "points": points}


def chart_garden(cfg: Config) -> dict:
    """``scenes/garden.xml`` (no tutorial twin): Mitsuba's spp sweep only, at a reduced
    resolution (``-D resx/resy``), against Mitsuba at ``ref_spp`` with another seed."""
    from codermind.passes import Progress          # heavy: Mitsuba
    from codermind.scene import load_scene
    from codermind.tutorial.image import srgb_encode
    from codermind.tutorial.render import render_linear
    set_variant("llvm_ad_rgb")
    xml = scenes_dir() / "garden.xml"
    w, h = cfg.garden_size
    t0 = time.perf_counter()
    scene = load_scene(xml, resx=str(w), resy=str(h))
    load = time.perf_counter() - t0
    render_linear(scene, 1, 12345)                     # warm-up: JIT compilation
    t0 = time.perf_counter()
    ref, ref_var, _, _ = render_linear(scene, cfg.ref_spp, REF_SEED, variance=True,
                                       progress=Progress(cfg.ref_spp, label="chart: reference"))
    ref_s = time.perf_counter() - t0
    ref, ref_var = ref.astype(np.float64), ref_var.astype(np.float64)
    desc = f"Mitsuba (path, max_depth 8) {cfg.ref_spp} spp, seed {REF_SEED}"
    log(f"garden: {w}x{h}, reference ({desc}) in {ref_s:.1f} s")

    def run(s):
        def go():
            t = time.perf_counter()
            lin = render_linear(scene, s, SWEEP_SEED)[0]
            return lin.astype(np.float64), load + time.perf_counter() - t, load, None
        return go
    jobs = [Job("mitsuba spp", "spp", s, s, run(s)) for s in cfg.spp]
    _interleave(jobs, cfg, "garden", LOCAL)     # here: its loaded scene does not pickle
    enc = lambda x: np.clip(srgb_encode(np.clip(x, 0.0, 1.0)), 0.0, 1.0)   # noqa: E731
    points = []
    for j in jobs:
        p = Point("garden", j.method, j.param, j.value, j.spp, statistics.median(j.runs),
                  j.load, list(j.runs))
        p.rel_mse, p.flip = rel_mse(j.linear, ref), flip(enc(ref), enc(j.linear))[0]
        points.append(p)
    for metric in ("rel_mse", "flip"):
        for p, on in zip(points, pareto_front([p.seconds for p in points],
                                              [getattr(p, metric) for p in points])):
            setattr(p, f"front_{metric}", bool(on))
    return {"scene": "garden", "xml": "scenes/garden.xml", "crop": [0, 0, w, h],
            "deterministic": False, "exposure": None, "reference": desc,
            "reference_seconds": ref_s,
            "reference_noise_rel_mse": float(np.mean(ref_var / (np.square(ref) + 0.01))),
            "chosen_model": {}, "points": points}


def _point(name, job: Job, ref_lin, settings, exposure, rect, ref_rect=None) -> Point:
    ref = ref_lin if ref_rect is None else _sub(ref_lin, ref_rect, rect, settings)
    p = Point(name, job.method, job.param, job.value, job.spp,
              statistics.median(job.runs), job.load, list(job.runs), triangles=job.tris,
              panel=job.panel)
    p.rel_mse = rel_mse(job.linear, ref)
    p.flip = flip(encode_mitsuba(ref, settings, exposure),
                  encode_mitsuba(job.linear, settings, exposure))[0]
    return p


def _sub(ref_lin, outer, inner, settings) -> np.ndarray:
    """The sub-samples of rectangle ``inner`` cut from a display-order film of ``outer``."""
    k = 1 if settings.page == 1 else 2
    x0 = k * (inner[0] - outer[0])
    y0 = k * (outer[3] - inner[3])
    return ref_lin[y0:y0 + k * (inner[3] - inner[1]), x0:x0 + k * (inner[2] - inner[0])]


def _scalar_points(name, mits: MitsubaRunner, cfg, ref_lin, rect, settings, exposure,
                   runner: Runner) -> list[Point]:
    """scalar_rgb and llvm_ad_rgb on the small scalar crop (page 4 only: the slow one)."""
    if name != "page4":
        return []
    r = cfg.scalar_rect
    x0, y0, x1, y1 = rect
    if not (x0 <= r[0] < r[2] <= x1 and y0 <= r[1] < r[3] <= y1):
        raise HarnessError(f"scalar crop {r} must lie inside the scene crop {rect}")
    jobs = []
    for variant in ("llvm_ad_rgb", "scalar_rgb"):
        label = variant if variant == "scalar_rgb" else "llvm_ad_rgb (scalar crop)"
        for s in cfg.scalar_spp:
            jobs.append(Job(label, "spp", s, s,
                            functools.partial(_mitsuba_point, mits, r, {}, s, variant),
                            panel="scalar"))
    # two rounds, both variants in each (the variant switch re-registers the plugins)
    _interleave(jobs, Config(**{**asdict(cfg), "repeats": min(cfg.repeats, 2),
                                "cheap_s": 1e9}), f"{name} scalar", runner)
    mits.drop("scalar_rgb")
    set_variant("llvm_ad_rgb")
    return [_point(name, j, ref_lin, settings, exposure, r, ref_rect=rect) for j in jobs]


def _xml_defaults(xml: Path) -> dict:
    """The ``<default>`` values the converter baked into the XML (the chooser's model)."""
    text = xml.read_text(encoding="utf-8")
    out = {}
    for m in re.finditer(r'<default name="(\w+)" value="([^"]*)"', text):
        if m[1] in ("spp", "max_depth") or m[1].endswith("_max_error"):
            out[m[1]] = float(m[2]) if "max_error" in m[1] else int(m[2])
    return out


def run(outdir: Path, only=None, quick: bool = False, cost: bool = True,
        runner: Runner = LOCAL) -> tuple[list, str]:
    """Chart ``only`` (default: every bundled scene), write the outputs; returns (paths,
    table). The points are units of ``runner`` (on a Dask worker a port point renders in
    its task's process: a worker is daemonic, the port forks no pool there); the
    cost-scaling experiments run here."""
    cfg = QUICK if quick else FULL
    names = list(only or SCENES)
    Path(outdir).mkdir(parents=True, exist_ok=True)      # fail before the work, not after
    before, t0 = os.getloadavg(), time.perf_counter()
    set_variant("llvm_ad_rgb")
    results = []
    for name in names:
        res = chart_scene(name, cfg, runner)
        res["summary"] = chart_report.summary(res)
        results.append(res)
    rows, slopes = ([], {})
    if cost:
        page4 = next((r for r in results if r["scene"] == "page4"), None)
        rows, slopes = chart_cost.run(cfg, page4)
    after = os.getloadavg()
    meta = {"config": cfg.name, "seconds": time.perf_counter() - t0,
            "load_average_before": list(before), "load_average_after": list(after),
            "load_text": chart_report.load_text(before, after), "cpus": os.cpu_count(),
            "threshold_rel_mse": THRESHOLD, "cluster": runner.address}
    paths = chart_report.write(Path(outdir), results, rows, slopes, meta)
    return paths, chart_report.table(results)
