"""How the cost grows with the work (``codermind chart``): wall time against pixels, samples,
blob sources and mesh triangles, with log-log slopes.

* pixels: page 4's whole frame at 1/s of its resolution, s = ``Config.strides`` (the same
  content at every size): Mitsuba with the film scaled (4 spp, plain render, each scene
  warmed up before its timed render) and the port with stride s (Complexity 1, 2 workers),
  interleaved;
* spp: the page-4 ``mitsuba spp`` and ``port clean`` series of the error chart (Mitsuba's
  load time taken off);
* blob sources: a synthetic blob of N sources in a row (radius 1, 1.2 apart, ``max_error``
  R/200, dielectric, ``path`` depth 10 under a constant sky, 256 x 192 at 16 spp): mesh build
  (scene load) and render;
* triangles: the page-4 ``mitsuba max_error`` series: build and render against the mesh's
  triangle count.
"""

from __future__ import annotations

import os
import re
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

import codermind_ref

from .chart_data import PORT_SEED, SWEEP_SEED, Config, fit_slope, log, scenes_dir
from .sides import parse, twin_of


def _row(experiment, method, x_name, x, runs, extra=None):
    return {"experiment": experiment, "method": method, "x_name": x_name, "x": x,
            "seconds": statistics.median(runs), "runs": list(runs), **(extra or {})}


def pixels(cfg: Config) -> list[dict]:
    """The whole page-4 frame at 1/s of the resolution (the same content at every size):
    Mitsuba with the first film scaled (the camera's FOV is fixed, so the view is the same;
    plain render, 4 spp), the port with every s-th pixel (stride s, Complexity 1)."""
    from codermind.scene import load_scene
    from codermind.tutorial.render import light_scenes, render_linear
    txt, xml = twin_of(scenes_dir() / "page4.xml")
    scene = parse(txt)
    runs: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        os.symlink(xml.parent / "sky", Path(tmp) / "sky")
        loaded = {}
        for s in cfg.strides:
            path = Path(tmp) / f"page4_{s}.xml"
            path.write_text(_scaled_film(xml.read_text(encoding="utf-8"), s), encoding="utf-8")
            loaded[s] = light_scenes(load_scene(path))
            render_linear(loaded[s], 1, 12345)       # warm-up (JIT)
        for rnd in range(cfg.repeats):
            for s in cfg.strides:
                render_linear(loaded[s], 1, 12345)   # the kernel after a scene switch
                t0 = time.perf_counter()
                render_linear(loaded[s], 4, SWEEP_SEED)
                runs.setdefault(("mitsuba", s), []).append(time.perf_counter() - t0)
                rect = (0, 0, scene.width, scene.height)
                t0 = time.perf_counter()
                _port_stride(scene, rect, s)
                runs.setdefault(("port", s), []).append(time.perf_counter() - t0)
                log(f"cost pixels round {rnd + 1}: 1/{s} resolution: mitsuba "
                     f"{runs[('mitsuba', s)][-1]:.2f} s, port {runs[('port', s)][-1]:.2f} s")
    rows = []
    for (m, s), t in runs.items():
        n = -(-scene.width // s) * -(-scene.height // s)
        rows.append(_row("pixels", "mitsuba llvm, 4 spp" if m == "mitsuba" else
                         "port clean, Complexity 1", "tutorial pixels", n, t))
    return rows


def _scaled_film(text: str, s: int) -> str:
    """The XML with its first film's width and height divided by ``s``."""
    m = re.search(r'<film type="hdrfilm">.*?</film>', text, re.S)
    film = re.sub(r'(<integer name="(?:width|height)" value=")(\d+)(")',
                  lambda g: f"{g[1]}{-(-int(g[2]) // s)}{g[3]}", m.group(0))
    return text[:m.start()] + film + text[m.end():]


def _port_stride(scene, rect, stride: int) -> None:
    codermind_ref.render(scene, "clean", PORT_SEED, 1, exposure=1.0, rect=rect, stride=stride, workers=2)


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
    from codermind.variants import set_variant
    mi = set_variant("llvm_ad_rgb")
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
        log(f"cost sources {n}: {tris} triangles, build {statistics.median(builds):.2f} s, "
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
    sizes (the small ones are mostly fixed per-call cost)."""
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
