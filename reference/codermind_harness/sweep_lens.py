"""Sweep: the ``conic`` camera (both lenses) from zero to huge aperture.

A thin lens must send every ray of a film position through that position's focus point
(``disc``: on the focal plane z = F; ``tutorial``: on the focus sphere of radius F), whatever
the aperture; an aperture of 0 must be the pinhole, and no ray may be NaN. Measured: the
largest distance (float64) between a ray and its focus point, in pixels of the focal plane,
against the aperture.
"""

from __future__ import annotations

import math

import numpy as np

from codermind.variants import set_variant

from ._mitsuba import load_error
from .sweep_result import (Plan, Series, SweepResult, finite_check_counts, finite_counts,
                           first_crossing)

W, H, FOV, FOCUS = 64, 48, 60.0, 100.0
LIMIT_PX = 0.1


def _camera(mi, **params):
    spec = {"type": "conic", "fov": FOV, "film": {"type": "hdrfilm", "width": W, "height": H}}
    spec.update(params)
    return mi.load_dict(spec)


def _rays(mi, camera, s2: np.ndarray, s3: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ray, _ = camera.sample_ray(0.0, 0.5, mi.Point2f(s2.astype(np.float32)),
                               mi.Point2f(s3.astype(np.float32)))
    return (np.asarray(ray.o.numpy(), dtype=np.float64),
            np.asarray(ray.d.numpy(), dtype=np.float64))


def _focus_points(lens: str, s2: np.ndarray) -> np.ndarray:
    """Focus point of each film position (camera space = world: identity to_world)."""
    s = s2.astype(np.float32).astype(np.float64)
    tan_x = math.tan(math.radians(FOV / 2))
    q = np.stack([(1 - 2 * s[0]) * tan_x, (1 - 2 * s[1]) * tan_x * H / W, np.ones(s.shape[1])])
    return q * FOCUS if lens == "disc" else q / np.linalg.norm(q, axis=0) * FOCUS


def _miss(o: np.ndarray, d: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distance from points p to the lines (o, d)."""
    with np.errstate(invalid="ignore", over="ignore"):
        return np.linalg.norm(np.cross((p - o).T, d.T), axis=1) / np.linalg.norm(d, axis=0)


LENSES = ("disc", "tutorial")
REFUSED = (({"aperture": float("inf")}, "aperture"), ({"aperture": float("nan")}, "aperture"),
           ({"aperture": -1.0}, "aperture"),
           ({"aperture": 1.0, "focus_distance": float("inf")}, "focus_distance"),
           ({"aperture": 1.0, "focus_distance": float("nan")}, "focus_distance"))


def _samples(quick: bool) -> tuple[np.ndarray, np.ndarray]:
    """The film and aperture samples every point uses (the same draws in every process)."""
    rng = np.random.default_rng(9)
    n = 1024 if quick else 8192
    return rng.random((2, n)), rng.random((2, n))


def _apertures(quick: bool) -> list[float]:
    return [0.0] + list(10.0 ** np.arange(-6, 31, 3 if quick else 1))


def _point(p: tuple):
    """("aperture", lens, a, quick): the rays at one aperture; ("lens", lens, quick): the
    zero-aperture and far-focus checks of one lens (a list of (what, passed, detail));
    ("refusals",): the messages of the refused parameters."""
    mi = set_variant()
    if p[0] == "refusals":
        return [load_error(mi, {"type": "conic", "fov": FOV, **params}) for params, _ in REFUSED]
    s2, s3 = _samples(p[-1])
    lens = p[1]
    if p[0] == "aperture":
        a = p[2]
        focus = _focus_points(lens, s2)
        pixel = FOCUS * 2 * math.tan(math.radians(FOV / 2)) / W  # a pixel on the focal plane
        camera = _camera(mi, lens=lens, aperture=a, focus_distance=FOCUS)
        o, d = _rays(mi, camera, s2, s3)
        bad = ~(np.isfinite(o).all(axis=0) & np.isfinite(d).all(axis=0))
        miss = _miss(o, d, focus) / pixel
        with np.errstate(invalid="ignore"):
            unit = float(np.nanmax(np.abs(np.linalg.norm(d, axis=0) - 1)))
        return {"nonfinite": float(bad.mean()), "finite": finite_counts(o, d), "unit": unit,
                "miss": float(np.nanmax(np.where(bad, np.nan, miss))) if not bad.all()
                else float("nan")}
    checks = []
    # zero aperture: the pinhole, whatever sample3
    o0, d0 = _rays(mi, _camera(mi, lens=lens, focus_distance=FOCUS), s2, s3)
    o1, d1 = _rays(mi, _camera(mi, lens=lens, focus_distance=FOCUS), s2, np.full_like(s3, 0.5))
    checks.append((f"{lens}: aperture 0 is bit-identical for any aperture sample",
                   np.array_equal(o0, o1) and np.array_equal(d0, d1), ""))
    pinhole = mi.load_dict({"type": "perspective", "fov": FOV,
                            "film": {"type": "hdrfilm", "width": W, "height": H}})
    op, dp = _rays(mi, pinhole, s2, s3)
    ot, dt = _rays(mi, _camera(mi, lens=lens, aperture=1e-30, focus_distance=FOCUS), s2, s3)
    dev = max(np.abs(d0 - dp).max(), np.abs(dt - d0).max())
    checks.append((f"{lens}: aperture 0 and 1e-30 give the built-in perspective's directions "
                   f"(within 1e-6)", dev <= 1e-6,
                   f"max |d - d_perspective| {np.abs(d0 - dp).max():.2g}, "
                   f"identical: {np.array_equal(d0, dp)}; aperture 1e-30 vs 0: "
                   f"{np.abs(dt - d0).max():.2g}"))
    # valid extremes of the other distances: focus at (almost) infinity
    extremes = []
    for params in ({"far_clip": 1e30}, {"far_clip": float("inf")},
                   {"aperture": 1.0, "focus_distance": 1e30},
                   {"aperture": 1e30, "focus_distance": 1e30}):
        extremes += list(_rays(mi, _camera(mi, lens=lens, **params), s2, s3))
    bad, total = finite_counts(*extremes)
    checks.append((f"{lens}: finite rays with far_clip 1e30 or inf (focus at far_clip) "
                   f"and focus_distance 1e30", bad == 0, f"{bad} of {total} values non-finite"))
    return checks


def thin_lens(quick: bool = False) -> Plan:
    """Points: each lens at each aperture, each lens's own checks, the refusals."""
    apertures = _apertures(quick)
    points = [("aperture", lens, a, quick) for lens in LENSES for a in apertures]
    points += [("lens", lens, quick) for lens in LENSES] + [("refusals",)]
    return Plan(points, _point, lambda results: _assemble(quick, apertures, results))


def _assemble(quick: bool, apertures: list[float], results: list) -> SweepResult:
    n = 1024 if quick else 8192
    r = SweepResult("thin_lens", "conic camera: focus and NaN vs aperture",
                    parameter=f"aperture 0 and 1e-6 to 1e30 (focus distance {FOCUS:g}, "
                              f"fov {FOV:g}, {W}x{H} film, {n} rays)",
                    measured="largest distance between a ray and its focus point, in pixels "
                             "of the focal plane; non-finite rays",
                    threshold="", threshold_value=None, xlabel="aperture (world units)",
                    ylabel="focus miss (pixels)", lines=[("y", LIMIT_PX, f"{LIMIT_PX:g} px"),
                                                        ("x", FOCUS, "focus distance")])
    k = len(apertures)
    counts, thresholds, unit_error = [], {}, 0.0
    for i, lens in enumerate(LENSES):
        per = results[i * k:(i + 1) * k]
        misses = [x["miss"] for x in per]
        nonfinite = [x["nonfinite"] for x in per]
        for a, x in zip(apertures, per):
            counts.append(x["finite"])
            unit_error = max(unit_error, x["unit"])
            r.table.append({"lens": lens, "aperture": a, "max_miss_px": x["miss"],
                            "nonfinite_fraction": x["nonfinite"]})
        blur = first_crossing(apertures[1:], misses[1:], LIMIT_PX)
        nan_from = next((a for a, f in zip(apertures, nonfinite) if f > 0), None)
        thresholds[lens] = (blur, nan_from)
        r.series.append(Series(f"{lens}: max miss", apertures[1:], misses[1:]))
        r.series.append(Series(f"{lens}: fraction non-finite", apertures[1:], nonfinite[1:], "s--"))
        for what, passed, detail in results[len(LENSES) * k + i]:
            r.check(what, passed, detail)
    finite_check_counts(r, "finite rays at every aperture up to 1e30", counts)
    r.check("unit ray directions at every aperture", unit_error <= 1e-5,
            f"max ||d| - 1| = {unit_error:.2g}")
    r.check("focus miss <= 0.1 px up to aperture = focus distance (both lenses)",
            all(row["max_miss_px"] <= LIMIT_PX for row in r.table if row["aperture"] <= FOCUS), "")
    for (params, name), message in zip(REFUSED, results[-1]):
        r.check(f"{params} is refused naming '{name}'",
                message is not None and f"'{name}'" in message, message or "loaded")
    r.threshold = "; ".join(
        f"{lens}: focus miss > {LIMIT_PX:g} px from aperture {_g(blur)}, non-finite rays from "
        f"{_g(nan_from)}" for lens, (blur, nan_from) in thresholds.items())
    r.threshold_value = thresholds["disc"][0]
    return r


def _g(value) -> str:
    return "- (never)" if value is None else f"{value:.3g}"
