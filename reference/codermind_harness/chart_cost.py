"""How the cost grows with the work (``codermind chart``): wall time against pixels, samples,
blob sources and mesh triangles, with log-log slopes.

* pixels: page 4, centred crops of growing size; Mitsuba at 4 spp (render only, the scene
  loaded and warmed up once per crop) and the port at Complexity 1 (2 workers), interleaved;
* spp: the page-4 ``mitsuba spp`` and ``port clean`` series of the error chart (Mitsuba's
  load time taken off);
* blob sources: a synthetic blob of N sources in a row (radius 1, 1.2 apart, ``max_error``
  R/200, dielectric, ``path`` depth 10 under a constant sky, 256 x 192 at 16 spp): mesh build
  (scene load) and render;
* triangles: the page-4 ``mitsuba max_error`` series: build and render against the mesh's
  triangle count.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from .chart import (Config, MitsubaRunner, ROOT, SWEEP_SEED, _log, _port, _set_variant,
                    fit_slope)
from .sides import parse, twin_of


def _row(experiment, method, x_name, x, runs, extra=None):
    return {"experiment": experiment, "method": method, "x_name": x_name, "x": x,
            "seconds": statistics.median(runs), "runs": list(runs), **(extra or {})}


def pixels(cfg: Config) -> list[dict]:
    txt, xml = twin_of(ROOT / "scenes" / "page4.xml")
    scene = parse(txt)
    runner = MitsubaRunner(xml, scene.width, scene.height, scene.page)
    cx, cy = scene.width // 2, scene.height // 2
    rects = [(cx - w // 2, cy - h // 2, cx - w // 2 + w, cy - h // 2 + h) for w, h in cfg.pixel_sizes]
    runs = {(m, r): [] for r in rects for m in ("mitsuba", "port")}
    for rnd in range(cfg.repeats):
        for r in rects:
            secs = runner.render(r, {}, 4, SWEEP_SEED)[2]
            runs[("mitsuba", r)].append(secs)
            runs[("port", r)].append(_port(scene, r, 1, 1.0)[1])
            _log(f"cost pixels round {rnd + 1}: {r[2] - r[0]}x{r[3] - r[1]}: mitsuba "
                 f"{secs:.2f} s, port {runs[('port', r)][-1]:.2f} s")
    rows = []
    for (m, r), t in runs.items():
        n = (r[2] - r[0]) * (r[3] - r[1])
        rows.append(_row("pixels", "mitsuba llvm, 4 spp" if m == "mitsuba" else
                         "port clean, Complexity 1", "tutorial pixels", n, t))
    return rows


def from_scene(page4: dict) -> list[dict]:
    rows = []
    for p in page4["points"]:
        if p.method == "mitsuba spp":
            rows.append(_row("spp", "mitsuba llvm", "spp", p.spp,
                             [t - p.load_seconds for t in p.runs]))
        elif p.method == "port clean":
            rows.append(_row("spp", "port clean", "spp (Complexity)", p.spp, p.runs))
        elif p.method == "mitsuba max_error" and p.triangles:
            rows.append(_row("triangles", "blob build (load)", "triangles", p.triangles,
                             [p.load_seconds], {"max_error": p.value}))
            rows.append(_row("triangles", f"render, {p.spp} spp", "triangles", p.triangles,
                             [t - p.load_seconds for t in p.runs], {"max_error": p.value}))
    return rows


def blob_sources(cfg: Config) -> list[dict]:
    mi = _set_variant("llvm_ad_rgb")
    rows = []
    for n in cfg.sources:
        builds, renders, tris = [], [], None
        for rnd in range(cfg.repeats):
            t0 = time.perf_counter()
            scene = mi.load_dict(_blob_scene(n))
            builds.append(time.perf_counter() - t0)
            tris = int(scene.shapes()[0].face_count())
            if rnd == 0:
                mi.render(scene, spp=1, seed=7)          # warm-up (JIT)
            t0 = time.perf_counter()
            img = mi.render(scene, spp=16, seed=SWEEP_SEED)
            np.asarray(img)
            renders.append(time.perf_counter() - t0)
        _log(f"cost sources {n}: {tris} triangles, build {statistics.median(builds):.2f} s, "
             f"render {statistics.median(renders):.2f} s")
        rows.append(_row("sources", "blob build (load)", "sources", n, builds,
                         {"triangles": tris}))
        rows.append(_row("sources", "render, 16 spp", "sources", n, renders,
                         {"triangles": tris}))
    return rows


def _blob_scene(n: int) -> dict:
    centres = {f"center{i}": [1.2 * i - 0.6 * (n - 1), 0.0, 0.0] for i in range(n)}
    span = 1.2 * (n - 1) + 3.0
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 11},
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": _look_at(span * 1.6),
                   "film": {"type": "hdrfilm", "width": 256, "height": 192},
                   "sampler": {"type": "independent"}},
        "sky": {"type": "constant"},
        "blob": {"type": "blob", "radius": 1.0, "max_error": 0.005, **centres,
                 "bsdf": {"type": "dielectric"}},
    }


def _look_at(distance: float):
    import mitsuba as mi
    return mi.ScalarTransform4f().look_at(origin=[0, 0.3 * distance, -distance],
                                         target=[0, 0, 0], up=[0, 1, 0])


def slopes(rows: list[dict]) -> dict:
    """Fitted log-log slope per (experiment, method); pixels over the larger half of the
    sizes (the small ones are fixed per-call cost)."""
    out = {}
    for key in sorted({(r["experiment"], r["method"]) for r in rows}):
        pts = sorted((r["x"], r["seconds"]) for r in rows if (r["experiment"], r["method"]) == key)
        if key[0] == "pixels":
            pts = pts[len(pts) // 2:]
        out[" / ".join(key)] = fit_slope([x for x, _ in pts], [t for _, t in pts])
    return out


def run(cfg: Config, page4: dict | None) -> tuple[list[dict], dict]:
    rows = pixels(cfg) + blob_sources(cfg) + (from_scene(page4) if page4 else [])
    return rows, slopes(rows)
