"""What ``codermind compare`` writes: a scene's JSON record, its heat map (both images, the
FLIP map and the per-sub-sample test's map), the tables, ``compare.json`` and
``compare.txt``."""

from __future__ import annotations

import json
import math
import threading
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from . import metrics
from .case import Case, Options
from .sides import Renders
from .verdict import Tests

# matplotlib and codermind (which starts Mitsuba) are imported where a file is written:
# importing them costs seconds that parsing options and checking scenes do not need.


def z_record(z: metrics.ZTest, th, unit: str) -> dict:
    """compare.json's record of a per-``unit`` z-test (``sub_samples`` or ``pixels``)."""
    return {"pass_rate": z.pass_rate, "channel_pass_rate": z.channel_pass_rate,
            "tests": z.tests, "alpha": th.alpha, "alpha_sidak": z.alpha,
            "z_critical": z.z_critical, f"noiseless_{unit}": z.noiseless,
            "noisy_tests": z.noisy_tests, f"failing_{unit}": int((~z.passed_map).sum()),
            "max_abs_z": z.max_z, "z_mean": z.z_mean, "z_sd": z.z_sd,
            "rtol": th.rtol, "atol": th.atol}


def port_record(case: Case, opt: Options, label: str, r: Renders, t: Tests,
                failures: list[str], flip_limit: float, heatmap: Path) -> dict:
    """One scene's JSON record against the port."""
    th, z, grid, scene = opt.thresholds, t.z, case.grid, case.scene
    mits, port, etest = r.mits, r.port, t.exposure
    return {
        "scene": str(case.path), "label": label, "tutorial_scene": str(case.txt),
        "xml": str(r.xml), "page": scene.page,
        "width": scene.width, "height": scene.height,
        "rect": list(grid.rect), "stride": grid.stride, "pixels": grid.pixels,
        "sub_samples": int(z.passed_map.size), "spp": case.spp, "seed": opt.seed,
        "random": case.random, "exposure": r.exposure, "port_mode": opt.port_mode,
        "quirks": opt.quirks,
        "defines": r.defines,
        "z_test": {**z_record(z, th, "sub_samples"),
                   # t-aware scores (metrics.welch_scores): the gross bound and calibration
                   "gross_alpha": z.gross_alpha, "gross_effect": z.gross_effect,
                   "z_gross": z.z_gross,
                   "gross_channels": z.gross, "gross_sub_samples": z.gross_sub_samples,
                   "max_abs_score": z.max_score, "zero_variance": z.zero_variance,
                   "calibration": z.calibration},
        "pooled": t.pooled, "ties": r.ties, "flip_limit": flip_limit,
        "flip_mean": t.flip_mean, "flip_noise": t.flip_noise, "z_test_noise": t.noise_z,
        "rel_mse": t.rel_mse,
        "rel_mse_noise": t.rel_mse_noise,
        "exposure_test": None if etest is None else {
            "seeds": r.seeds, "mitsuba": mits.probe_exposures, "port": r.port_exposures,
            **asdict(etest)},
        "thresholds": {"pass_rate": th.pass_rate, "flip": th.flip,
                       "exposure_alpha": th.exposure_alpha, "pooled_alpha": th.pooled_alpha,
                       "gross_alpha": th.gross_alpha, "gross_effect": th.gross_effect,
                       "flip_k": th.flip_k, "flip_k0": th.flip_k0,
                       "flip_eps": th.flip_eps},
        "passed": not failures, "failures": failures,
        "seconds": {"port": port.seconds, "mitsuba": mits.seconds,
                    "mitsuba_load": mits.load_seconds,
                    "port_probes": r.port_probe_seconds, "mitsuba_probes": mits.probe_seconds},
        "heatmap": str(heatmap),
    }


def port_heatmap(out: Path, label: str, r: Renders, t: Tests) -> Path:
    """``OUT/LABEL.compare.png`` of a scene against the port."""
    heatmap = out / f"{label}.compare.png"
    write_heatmap(heatmap, r.mits.encoded, r.port.encoded, t.rows, t.flip_map, t.z,
                  r.port.label, f"{label}: pass rate {t.z.pass_rate:.4f}, "
                  f"FLIP {t.flip_mean:.4f}, relMSE {t.rel_mse:.3g}")
    return heatmap


@dataclass
class MapPanel:
    """What the heat map's last panel shows (as :class:`metrics.ZTest` gives it)."""
    z_map: np.ndarray
    passed_map: np.ndarray
    z_critical: float


def write_heatmap(path: Path, mits: np.ndarray, port: np.ndarray, rows: slice,
                  flip_map: np.ndarray, z: metrics.ZTest, port_label: str, title: str,
                  zlabel: str = "|z| per sub-sample", left_label: str = "Mitsuba") -> None:
    """One PNG: both images, the FLIP map and the |z| map (failing sub-samples in red);
    ``left_label``: the first image's title."""
    import matplotlib           # heavy
    from codermind.imageio import atomic_path
    with _DRAWING:      # scenes compared in threads on a cluster share matplotlib's caches
        _heatmap(matplotlib, atomic_path, path, mits, port, rows, flip_map, z,
                 port_label, title, zlabel, left_label)


_DRAWING = threading.Lock()


def _heatmap(matplotlib, atomic_path, path, mits, port, rows, flip_map, z, port_label,
             title, zlabel="|z| per sub-sample", left_label="Mitsuba") -> None:
    h, w = mits.shape[:2]
    panel = min(max(w / 100, 2.5), 5.0)          # inches: small grids enlarged, large shrunk
    # a Figure without pyplot: the caller's backend and current figure stay (notebooks)
    from matplotlib.figure import Figure
    fig = Figure(figsize=(2 * panel + 1.5, 2 * panel * h / w + 1.2), dpi=100,
                 constrained_layout=True)
    axes = fig.subplots(2, 2)
    axes[0, 0].imshow(mits, interpolation="nearest")
    axes[0, 0].set_title(left_label, fontsize=9)
    axes[0, 1].imshow(port, interpolation="nearest")
    axes[0, 1].set_title(port_label, fontsize=9)
    full_flip = np.full((h, w), np.nan)
    full_flip[rows] = flip_map
    im = axes[1, 0].imshow(full_flip, cmap="magma", vmin=0.0, vmax=1.0, interpolation="nearest")
    axes[1, 0].set_title("FLIP" + (" (strip rows blank)" if flip_map.shape[0] < h else ""),
                         fontsize=9)
    fig.colorbar(im, ax=axes[1, 0], shrink=0.8)
    zmap = np.minimum(z.z_map, 2 * z.z_critical)
    im = axes[1, 1].imshow(zmap, cmap="viridis", vmin=0.0, vmax=z.z_critical,
                           interpolation="nearest")
    fails = np.ma.masked_where(z.passed_map, np.ones(z.passed_map.shape))
    axes[1, 1].imshow(fails, cmap=matplotlib.colors.ListedColormap(["red"]), vmin=0, vmax=1,
                      interpolation="nearest")
    axes[1, 1].set_title(f"{zlabel} (red: fails, > {z.z_critical:.3g})",
                         fontsize=9)
    fig.colorbar(im, ax=axes[1, 1], shrink=0.8)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title, fontsize=10)
    with atomic_path(path, ".png") as tmp:
        fig.savefig(tmp, format="png")


def format_table(records: list[dict]) -> str:
    """Fixed-width tables: the image tests, one row per scene (``E test``: the exposure
    test's verdict), then the exposure test, one row per page-4 scene; scenes compared with a
    reference image (``--reference``) in a table of their own, and so are ordinary Mitsuba
    scenes (``ordinary``: against OTHER or a reference image, :mod:`.scene_compare`)."""
    ordinary = [r for r in records if r.get("ordinary")]
    records = [r for r in records if not r.get("ordinary")]
    refs = [r for r in records if r.get("reference")]
    records = [r for r in records if not r.get("reference")]
    parts = ([_port_table(records)] if records else []) + ([_reference_table(refs)] if refs else [])
    parts += [_scene_table(ordinary)] if ordinary else []
    return "\n\n".join(parts)


def _scene_table(records: list[dict]) -> str:
    """Ordinary scenes: the per-pixel z-test, the pooled tests (tiles / objects / image),
    FLIP and its limit, relative MSE and the noise's share of it."""
    head = ("scene", "against", "pixels", "spp", "pass rate", "fail", "max|z|", "z sd",
            "pooled", "FLIP", "FLIP limit", "relMSE", "noise", "seconds", "verdict")
    rows = []
    for r in records:
        z = r["z_test"]
        other = Path(r["against"] or r["reference"]).name
        rows.append((r["label"], other, str(r["pixels"]), str(r["spp"]),
                     f"{z['pass_rate']:.5f}", str(z["failing_pixels"]),
                     _num(z["max_abs_z"], ".3g"), _num(z["z_sd"], ".3f"), _pooled(r),
                     f"{r['flip_mean']:.5f}", f"{r['flip_limit']:.5f}", f"{r['rel_mse']:.3g}",
                     f"{r['rel_mse_noise']:.3g}", f"{r['seconds']['total']:.1f}",
                     "pass" if r["passed"] else "FAIL"))
    return _fixed(head, rows)


def _reference_table(records: list[dict]) -> str:
    head = ("scene", "reference", "page", "pixels", "spp", "exposure", "method", "identical",
            "within 1/tol", "max|t|", "t crit", "mean z", "FLIP", "FLIP noise", "mitsuba s",
            "verdict")
    rows = []
    for r in records:
        b, bt, mt = r["bytes"], r["blur_test"], r["mean_test"]
        worst = None if mt is None else max(mt["z"], key=abs)
        rows.append((r["label"], Path(r["reference"]).name, str(r["page"]), str(r["pixels"]),
                     str(r["spp"]), "-" if r["exposure"] is None else f"{r['exposure']:.4g}",
                     r["method"], "-" if b is None else f"{b['identical']:.5f}",
                     f"{b['within_one']:.5f}" if b else
                     f"{r['float_test']['pass_rate']:.5f}" if r["float_test"] else "-",
                     "-" if bt is None else _num(bt["max_abs_z"], ".3g"),
                     "-" if bt is None else f"{bt['z_critical']:.3g}",
                     "-" if worst is None else _num(worst, ".3g"),
                     f"{r['flip_mean']:.5f}", _num(r["flip_noise"], ".5f"),
                     f"{r['seconds']['mitsuba']:.1f}", "pass" if r["passed"] else "FAIL"))
    return _fixed(head, rows)


def _port_table(records: list[dict]) -> str:
    head = ("scene", "page", "pixels", "spp", "exposure", "pass rate", "fail", "max|z|",
            "z sd", "pooled", "FLIP", "FLIP noise", "relMSE", "noise", "E test", "port s",
            "mitsuba s", "verdict")
    rows = []
    for r in records:
        z = r["z_test"]
        e = r.get("exposure_test")
        rows.append((r["label"], str(r["page"]), str(r["pixels"]), str(r["spp"]),
                     "-" if r["exposure"] is None else f"{r['exposure']:.4g}",
                     f"{z['pass_rate']:.5f}", str(z["failing_sub_samples"]),
                     _num(z["max_abs_z"], ".3g"), _num(z["z_sd"], ".3f"), _pooled(r),
                     f"{r['flip_mean']:.5f}",
                     _num(r["flip_noise"], ".5f"), f"{r['rel_mse']:.3g}", f"{r['rel_mse_noise']:.3g}",
                     "-" if e is None else "pass" if e["passed"] else "FAIL",
                     f"{r['seconds']['port']:.1f}", f"{r['seconds']['mitsuba']:.1f}",
                     "pass" if r["passed"] else "FAIL"))
    text = _fixed(head, rows)
    tested = [r for r in records if r.get("exposure_test")]
    if tested:
        e0 = tested[0]["exposure_test"]
        head = ("scene", "seeds", "mitsuba E", "sd", "port E", "sd", "diff %", "t", "df", "p",
                "spread p", "E test")
        rows = []
        for r in tested:
            e = r["exposure_test"]
            rows.append((r["label"], f"{e['seeds'][0]}-{e['seeds'][-1]}",
                         f"{e['mean'][0]:.4f}", f"{e['sd'][0]:.4f}", f"{e['mean'][1]:.4f}",
                         f"{e['sd'][1]:.4f}", f"{100 * e['rel_diff']:+.2f}",
                         _num(e["t"], ".2f"), _num(e["df"], ".1f"), _num(e["p"], ".2g"),
                         _num(e.get("p_spread"), ".2g"), "pass" if e["passed"] else "FAIL"))
        text += (f"\n\nexposure test: each side's auto exposure over {len(e0['seeds'])} seeds, "
                 f"Welch's t-test, alpha {e0['alpha']:g} (two-sided; spread p: one side's E "
                 f"constant, the other's not, exact, with Welch each at alpha / 2)\n"
                 + _fixed(head, rows))
    calib = _calibration_table(records)
    if calib:
        text += ("\n\ncalibration: each test's scores (normal under the null: sd 1, p-values "
                 "uniform); p histogram: counts in 10 bins of the two-sided p-value from 0 to "
                 "1\n" + calib)
    return text


def _calibration_table(records: list[dict]) -> str:
    """One row per scene and test with scores: the per-sub-sample z-test's t-aware scores,
    the pooled families' Z, the port against itself."""
    head = ("scene", "test", "n", "mean", "sd", "robust sd", "max|score|", "gross bound",
            "p histogram")
    rows = []
    for r in records:
        z = r["z_test"]
        tests = [("z-test", z.get("calibration"), z.get("max_abs_score"), z.get("z_gross"))]
        tests += [(f"pooled {k}", v.get("calibration"), v.get("max_abs_z"), None)
                  for k, v in (r.get("pooled") or {}).items()]
        noise = r.get("z_test_noise") or {}
        tests.append(("port vs port", noise.get("calibration"), noise.get("max_abs_score"),
                      noise.get("z_gross")))
        for name, c, worst, bound in tests:
            if not c:
                continue
            rows.append((r["label"], name, str(c["n"]), f"{c['mean']:+.3f}",
                         _num(c["sd"], ".3f"), f"{c['sd_robust']:.3f}", _num(worst, ".3g"),
                         _num(bound, ".3g"), " ".join(str(x) for x in c["p_hist"])))
    return _fixed(head, rows) if rows else ""


def _pooled(r: dict) -> str:
    """The pooled tests' verdict and largest |Z| (tiles / objects)."""
    p = r.get("pooled")
    if not p:
        return "-"
    cell = "/".join(_num(v["max_abs_z"], ".2g") for v in p.values())
    return cell + ("" if all(v["passed"] for v in p.values()) else " FAIL")


def _fixed(head, rows) -> str:
    widths = [max(len(x) for x in col) for col in zip(head, *rows)]
    line = lambda cells: "  ".join(c.rjust(w) if i else c.ljust(w)   # noqa: E731
                                   for i, (c, w) in enumerate(zip(cells, widths)))
    return "\n".join([line(head), line(["-" * w for w in widths])] + [line(r) for r in rows])


def _num(x: float | None, fmt: str) -> str:
    return "-" if x is None else "inf" if math.isinf(x) else format(x, fmt)


def write_json(path: Path, payload) -> None:
    from codermind.imageio import atomic_path
    with atomic_path(path, ".json") as tmp:
        tmp.write_text(json.dumps(payload, indent=2, default=_jsonable) + "\n", encoding="utf-8")


def _jsonable(x):
    if isinstance(x, Path):
        return str(x)
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"not JSON serializable: {type(x).__name__}")


def options_json(opt: Options) -> dict:
    d = asdict(opt)
    d["out_dir"] = str(opt.out_dir)
    return d


def write_outputs(out: Path, opt: Options, records: list[dict], seconds: float) -> str:
    """``compare.json`` (the options and every record) and ``compare.txt`` (the tables, which
    are returned) in ``out``."""
    from codermind.imageio import atomic_path
    table = format_table(records)
    write_json(out / "compare.json", {"options": options_json(opt), "scenes": records,
                                      "seconds": seconds})
    with atomic_path(out / "compare.txt", ".txt") as tmp:
        tmp.write_text(table + "\n", encoding="utf-8")
    return table
