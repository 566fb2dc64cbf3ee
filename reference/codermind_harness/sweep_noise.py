"""Sweep: the ``perlin`` texture (float32, Dr.Jit) against the noise coordinate magnitude.

At magnitude M the texture is evaluated at random points with coordinates in +-[M, 2M] and
compared with the port's float64 noise (``codermind_ref.perlin``: Perlin's improved noise
with the tutorial's gradient, as the texture's default) at the float64 point (the total error a user sees) and at the point
rounded to float32 (the error of the float32 arithmetic alone).
"""

from __future__ import annotations

import numpy as np

from codermind.variants import set_variant
from codermind_ref.perlin import noise

from .sweep_result import (Plan, Series, SweepResult, finite_check_counts, finite_counts,
                           first_crossing, generator, states)

LIMIT = 1e-2


def _evaluate(mi, texture, points: np.ndarray) -> np.ndarray:
    import drjit as dr
    si = dr.zeros(mi.SurfaceInteraction3f, points.shape[1])
    si.p = mi.Point3f(points.astype(np.float32))
    return np.asarray(texture.eval_1(si).numpy(), dtype=np.float64)


def _draw(rng: np.random.Generator, m: float, n: int) -> np.ndarray:
    """n random points with coordinates in +-[m, 2m]."""
    return m * (1.0 + rng.random((3, n))) * rng.choice([-1.0, 1.0], (3, n))


def _point(p: tuple) -> dict:
    """One point: ("magnitude", M, n, generator state), ("edges",) or ("tile", M)."""
    mi = set_variant()
    texture = mi.load_dict({"type": "perlin"})
    kind = p[0]
    if kind == "magnitude":
        _, m, n, state = p
        pts = _draw(generator(state), m, n)
        value = _evaluate(mi, texture, pts)
        return {"total": np.abs(value - noise(*pts)).max(),
                "arith": np.abs(value - noise(*pts.astype(np.float32).astype(np.float64))).max(),
                "zero": float(np.mean(value == 0.0)), "max_abs": np.abs(value).max(),
                "finite": finite_counts(value)}
    if kind == "edges":
        # Finite positions whose scaled coordinate overflows float32 (frequency 1e10 x |p|
        # 1e30) and the largest floats: must stay finite (0, as every coordinate beyond 2^23).
        far = mi.load_dict({"type": "perlin", "frequency": 1e10})
        huge = np.array([[1e30, -1e30, 3e38, -3e38, 1e20], [1.0, 2.0, 3e38, 0.5, -1e30],
                         [0.25, 1e30, -3e38, 7.0, 2.0]])
        edge = np.concatenate([_evaluate(mi, far, huge), _evaluate(mi, texture, huge)])
        return {"finite": finite_counts(edge),
                "zero": bool(np.all(_evaluate(mi, texture, huge[:, 2:3] * [[1.0], [1.0], [1.0]])
                                    == 0))}
    # picture: a 64 x 64 patch (1 unit = 8 pixels) at magnitude M
    m = p[1]
    y, x = np.mgrid[0:64, 0:64] / 8.0
    pts = np.stack([m + x.ravel(), m + y.ravel(), np.full(x.size, m + 0.37)])
    return {"tile": _evaluate(mi, texture, pts).reshape(64, 64)}


TILES = (1e3, 1e5, 4e6)


def perlin_float32(quick: bool = False) -> Plan:
    """Points: each magnitude (with the generator's state for its random points), the overflow edge
    cases, the three picture tiles."""
    rng = np.random.default_rng(8)
    step, n = (4, 4000) if quick else (8, 20000)
    magnitudes = 10.0 ** (np.arange(0, 8 * step + 1) / step)
    points = [("magnitude", m, n, st) for m, st in
              zip(magnitudes, states(rng, lambda g: _draw(g, 1.0, n), len(magnitudes)))]
    points += [("edges",)] + [("tile", m) for m in TILES]
    return Plan(points, _point, lambda results: _assemble(magnitudes, n, results))


def _assemble(magnitudes: np.ndarray, n: int, results: list[dict]) -> SweepResult:
    per = results[:len(magnitudes)]
    edges, tiles = results[len(magnitudes)], results[len(magnitudes) + 1:]
    total = [x["total"] for x in per]
    arith = [x["arith"] for x in per]
    zeros = [x["zero"] for x in per]
    bad = first_crossing(magnitudes, total, LIMIT)
    vanish = next((float(m) for m, z in zip(magnitudes, zeros) if z == 1.0), None)
    r = SweepResult(
        "perlin_float32", "perlin texture (float32) vs coordinate magnitude",
        parameter=f"noise coordinate magnitude M, 1 to 1e8 ({len(magnitudes)} values, "
                  f"{n} points each)",
        measured="max |texture - float64 Perlin| at the float64 point",
        threshold=(f"error > {LIMIT:g} from M = {bad:.3g}; noise exactly 0 everywhere from "
                   f"M = {vanish:.3g} (2^23 = {2**23:.3g})" if bad and vanish else
                   f"error > {LIMIT:g} from M = {bad}; all zero from {vanish}"),
        threshold_value=bad, xlabel="coordinate magnitude M", ylabel="max abs error",
        lines=[("y", LIMIT, f"{LIMIT:g}"), ("x", 2.0 ** 23, "2^23")])
    r.series = [Series("total (float64 point)", list(magnitudes), total),
                Series("float32 arithmetic (float32 point)", list(magnitudes), arith),
                Series("fraction exactly 0", list(magnitudes), zeros, "s--")]
    r.table = [{"M": float(m), "max_error": float(e), "max_error_float32_point": float(a),
                "fraction_zero": z} for m, e, a, z in zip(magnitudes, total, arith, zeros)]
    finite_check_counts(r, "texture values finite at every magnitude", [x["finite"] for x in per])
    r.check("|noise| <= 1.1 everywhere", max(x["max_abs"] for x in per) <= 1.1,
            f"max |noise| = {max(x['max_abs'] for x in per):.4f}")
    r.check("float32 arithmetic error < 1e-4 below M = 1e4",
            max(a for m, a in zip(magnitudes, arith) if m < 1e4) < 1e-4,
            f"max {max(a for m, a in zip(magnitudes, arith) if m < 1e4):.2g}")
    finite_check_counts(r, "finite where frequency x position overflows float32",
                        [edges["finite"]])
    r.check("0 where every coordinate is beyond 2^23 (float32 integers)", edges["zero"],
            "noise(3e38, 3e38, -3e38)")
    strips = []
    for t in tiles:
        strips += [t["tile"], np.full((64, 4), np.nan)]
    r.image = 0.5 + 0.5 * np.hstack(strips[:-1])
    r.image_title = "noise at 1e3, 1e5, 4e6 (8 units wide)"
    return r
