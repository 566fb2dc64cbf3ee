"""Sweeps of the port's blob intersection (``codermind_ref.blob.hit``, the tutorial's zone
method in float64) against the exact solution (:mod:`codermind_harness.zone_exact`, 50 digits):
grazing rays and the scene's scale.

Error measure: relative error of the hit distance t on rays both hit; a hit where the exact
solution has none (or the reverse) is a disagreement. The scene is the page-4 blob (sources
(160, 290, 320), (400, 290, 480), (250, 140, 400), R = 80) seen from the page-4 eye
(320, 240, 0), and for the analytic grazing family a lone source (a sphere of radius R).
"""

from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np

from codermind_ref import blob as port_blob

from . import zone_exact
from .sweep_result import Plan, Series, SweepResult

CENTERS = np.array([[160.0, 290.0, 320.0], [400.0, 290.0, 480.0], [250.0, 140.0, 400.0]])
RADIUS = 80.0
EYE = np.array([320.0, 240.0, 0.0])
LONE = np.array([[0.0, 0.0, 0.0], [1e6, 0.0, 0.0], [-1e6, 0.0, 0.0]])   # far ones add 0
ERROR_LIMIT = 1e-6
GROWTH_LIMIT = 1e-10


def _port(o: np.ndarray, d: np.ndarray, centers: np.ndarray, radius: float, tmax: float = np.inf):
    with np.errstate(all="ignore"):
        t, hit = port_blob.hit(np.ascontiguousarray(o.T), np.ascontiguousarray(d.T),
                          np.full(o.shape[0], tmax), centers, radius)
    return t, hit


def _compare(t_port, hit_port, reference) -> tuple[np.ndarray, np.ndarray]:
    """(relative errors on common hits, disagreement mask) against Decimal references."""
    ref_hit = np.array([r is not None for r in reference])
    both = hit_port & ref_hit
    with localcontext() as ctx:
        ctx.prec = 50
        err = np.array([float(abs((Decimal(float(t_port[i])) - reference[i]) / reference[i]))
                        for i in np.flatnonzero(both)])
    return err, hit_port != ref_hit


def _random_frames(rng, n):
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    u = np.cross(d, rng.normal(size=(n, 3)))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return d, u


def _sphere_reference(o, d, radius) -> Decimal | None:
    """First root of a lone source: the sphere |p| = R (f(1) = 1 exactly in the tables)."""
    with localcontext() as ctx:
        ctx.prec = 50
        o = [Decimal(float(v)) for v in o]
        d = [Decimal(float(v)) for v in d]
        a = sum(v * v for v in d)
        b = -sum(x * y for x, y in zip(o, d))
        disc = b * b - a * (sum(v * v for v in o) - Decimal(radius) ** 2)
        if disc < 0:
            return None
        return (b - disc.sqrt()) / a


def _normal(p: np.ndarray) -> np.ndarray:
    """Outward unit normals of the piecewise field at points p (n, 3)."""
    grad = np.zeros_like(p)
    for c in CENTERS:
        v = p - c
        x = (v * v).sum(axis=1) / RADIUS ** 2
        depth = np.searchsorted(-port_blob.RATIO[:port_blob.ZONES], -x, side="left")
        grad += (port_blob.SLOPE[depth] * 2 / RADIUS ** 2)[:, None] * v
    return -grad / np.linalg.norm(grad, axis=1, keepdims=True)


def _aimed_rays(rng, n, scale=1.0):
    """Rays from the eye toward random points of the blob's bounding box (+- R)."""
    lo, hi = CENTERS.min(axis=0) - RADIUS, CENTERS.max(axis=0) + RADIUS
    target = lo + rng.random((n, 3)) * (hi - lo)
    d = target - EYE
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.repeat(EYE[None] * scale, n, axis=0), d


def _lone_point(p: tuple) -> dict:
    """("lone", eps, d, u, check): rays at depth eps into a lone source vs its closed form;
    ``check``: also the zone solver against the closed form on 4 rays."""
    _, eps, d, u, check = p
    m = len(d)
    o = (RADIUS * (1 - eps)) * u - 400.0 * d
    t, hit = _port(o, d, LONE, RADIUS)
    ref = [_sphere_reference(o[i], d[i], RADIUS) for i in range(m)]
    err, dis = _compare(t, hit, ref)
    self_check = 0.0
    if check:                       # the zone solver agrees with the closed form
        for i in range(4):
            z = zone_exact.first_hit(o[i], d[i], LONE, RADIUS)
            if ref[i] is not None and z is not None:
                self_check = max(self_check, float(abs((z - ref[i]) / ref[i])))
    return {"err": float(err.max()) if err.size else float("nan"),
            "miss": float(dis.mean()), "self_check": self_check}


def _blob_point(p: tuple) -> dict:
    """("blob", eps, p, normal, tangent): tangent rays eps R below points of the page-4
    blob vs the 50-digit solve."""
    _, eps, p0, normal, tangent = p
    o = p0 - eps * RADIUS * normal - 400.0 * tangent
    t, hit = _port(o, tangent, CENTERS, RADIUS)
    ref = [zone_exact.first_hit(o[i], tangent[i], CENTERS, RADIUS, t_min=0.01)
           for i in range(len(o))]
    err, dis = _compare(t, hit, ref)
    return {"err": float(err.max()) if err.size else float("nan"), "miss": float(dis.mean())}


def _camera_point(p: tuple) -> dict:
    """("camera", d): camera rays from the eye: the port's t and hit, the exact hits'
    relative error (NaN where either misses) and the hit/miss disagreements."""
    d = p[1]
    o = np.repeat(EYE[None], d.shape[0], axis=0)
    t, hit = _port(o, d, CENTERS, RADIUS)
    ref = [zone_exact.first_hit(o[i], d[i], CENTERS, RADIUS, t_min=0.01) for i in range(len(d))]
    rel = np.array([float(abs((Decimal(float(t[i])) - ref[i]) / ref[i])) if hit[i] and
                    ref[i] is not None else np.nan for i in range(len(d))])
    return {"t": t, "hit": hit, "rel": rel,
            "disagree": hit != np.array([x is not None for x in ref])}


def _grazing_point(p: tuple) -> dict:
    return {"lone": _lone_point, "blob": _blob_point, "camera": _camera_point}[p[0]](p)


#: camera rays per task of the zone_grazing picture
CAMERA_RAYS = 400


def zone_grazing(quick: bool = False) -> Plan:
    """Points: each depth on the lone source, each depth on the page-4 blob, the picture's
    camera rays in groups of :data:`CAMERA_RAYS`. The rays are drawn here, in the order the
    sweep always drew them."""
    rng = np.random.default_rng(10)
    depths = 10.0 ** -np.arange(1, 17, 3 if quick else 1)
    m = 16 if quick else 64
    # family A: a lone source, rays whose closest approach is R (1 - eps) (chord depth eps R)
    d, u = _random_frames(rng, m)
    points = [("lone", eps, d, u, eps in depths[:2]) for eps in depths]
    # family B: the page-4 blob, tangent rays eps R below random surface points
    m_b = 24 if quick else 96
    o0, d0 = _aimed_rays(rng, 4 * m_b)
    t0, hit0 = _port(o0, d0, CENTERS, RADIUS)
    keep = np.flatnonzero(hit0)[:m_b]
    p = o0[keep] + t0[keep, None] * d0[keep]
    normal = _normal(p)
    tangent = np.cross(normal, rng.normal(size=normal.shape))
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    points += [("blob", eps, p, normal, tangent) for eps in depths]
    # picture: relative error per camera ray over the page-4 blob
    w, h = (40, 30) if quick else (96, 72)
    xs, ys = np.meshgrid(np.linspace(60, 560, w), np.linspace(440, 40, h))
    target = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, 400.0)], axis=1)
    cam = target - EYE
    cam /= np.linalg.norm(cam, axis=1, keepdims=True)
    points += [("camera", cam[i:i + CAMERA_RAYS]) for i in range(0, len(cam), CAMERA_RAYS)]
    k = len(depths)
    return Plan(points, _grazing_point, lambda res: _grazing(
        depths, m, len(keep), w, h, res[:k], res[k:2 * k], res[2 * k:]))


def _grazing(depths, m, m_b, w, h, lone, blob, camera) -> SweepResult:
    err_a, miss_a = [x["err"] for x in lone], [x["miss"] for x in lone]
    self_check = 0.0
    for x in lone:
        self_check = max(self_check, x["self_check"])
    err_b, miss_b = [x["err"] for x in blob], [x["miss"] for x in blob]
    grow_a = next((e for e, x in zip(depths, err_a) if not x <= GROWTH_LIMIT), None)
    grow_b = next((e for e, x in zip(depths, err_b) if not x <= GROWTH_LIMIT), None)
    bad_a = next((e for e, x, y in zip(depths, err_a, miss_a) if not x <= ERROR_LIMIT or y > 0), None)
    bad_b = next((e for e, x, y in zip(depths, err_b, miss_b) if not x <= ERROR_LIMIT or y > 0), None)
    r = SweepResult(
        "zone_grazing", "port zone method vs grazing rays",
        parameter=f"chord depth eps (ray passes eps R inside the surface), 1e-1 to 1e-16; "
                  f"{m} rays at a lone source, {m_b} tangent rays at the page-4 blob",
        measured="max relative error of the hit distance vs a 50-digit solve; fraction of "
                 "hit/miss disagreements",
        threshold=f"relative error grows as the chord shrinks: > {GROWTH_LIMIT:g} from depth "
                  f"{_g(grow_a)} (lone source) / {_g(grow_b)} (page-4 blob); error > "
                  f"{ERROR_LIMIT:g} or a hit/miss disagreement from depth {_g(bad_a)} / "
                  f"{_g(bad_b)}",
        threshold_value=bad_a, xlabel="chord depth eps (fraction of R)",
        ylabel="max rel. error / disagreement fraction", lines=[("y", ERROR_LIMIT, "")])
    r.series = [Series("lone source: max rel. error", list(depths), err_a),
                Series("lone source: disagreements", list(depths), miss_a, "s--"),
                Series("page-4 blob: max rel. error", list(depths), err_b),
                Series("page-4 blob: disagreements", list(depths), miss_b, "s--")]
    r.table = [{"eps": float(e), "lone_max_rel_error": a, "lone_disagreement": b,
                "blob_max_rel_error": c, "blob_disagreement": dd}
               for e, a, b, c, dd in zip(depths, err_a, miss_a, err_b, miss_b)]
    r.check("the 50-digit zone solver equals the closed form on a lone source (1e-30)",
            self_check <= 1e-30, f"{self_check:.2g}")
    t = np.concatenate([x["t"] for x in camera])
    hit = np.concatenate([x["hit"] for x in camera])
    rel = np.concatenate([x["rel"] for x in camera])
    disagree = np.concatenate([x["disagree"] for x in camera])
    r.check("hit distances finite wherever the port reports a hit", np.isfinite(t[hit]).all(),
            f"{int(hit.sum())} camera-ray hits")
    img = np.where(np.isfinite(rel), np.log10(np.maximum(rel, 1e-17)), np.nan)
    r.check("camera rays over the page-4 blob: port and exact agree on every hit/miss",
            not disagree.any(), f"{int(disagree.sum())} of {len(t)} disagree")
    r.check("camera rays over the page-4 blob: relative error <= 1e-12",
            np.nanmax(rel) <= 1e-12, f"max {np.nanmax(rel):.2g}")
    r.image = np.where(disagree, 0.0, img).reshape(h, w)
    r.image_title = (f"log10 rel. error per camera ray (max {np.nanmax(rel):.1g}); "
                     f"{int(disagree.sum())} disagreements")
    return r


def _scale_point(p: tuple) -> dict:
    """(scale, o1, d): the page-4 blob and eye scaled by s vs the 50-digit solve."""
    s, o1, d = p
    m = len(d)
    o = o1 * s
    t, hit = _port(o, d, CENTERS * s, RADIUS * s)
    ref = [zone_exact.first_hit(o[i], d[i], CENTERS * s, RADIUS * s) for i in range(m)]
    err, dis = _compare(t, hit, ref)
    ref_hits = sum(x is not None for x in ref)
    return {"scale": float(s), "reference_hits": ref_hits,
            "port_hits": int(hit.sum()), "agreement": 1.0 - float(dis.mean()),
            "max_rel_error": float(err.max()) if err.size else float("nan"),
            "nonfinite_t": int((~np.isfinite(t[hit])).sum())}


def zone_scale(quick: bool = False) -> Plan:
    """Points: each scale (the rays drawn here)."""
    rng = np.random.default_rng(11)
    exponents = np.union1d(np.arange(-12, 161, 8 if quick else 2), [0])
    scales = 10.0 ** exponents
    m = 24 if quick else 96
    o1, d = _aimed_rays(rng, m)
    return Plan([(s, o1, d) for s in scales], _scale_point,
                lambda rows: _scale(scales, m, rows))


def _scale(scales, m, rows) -> SweepResult:
    agree = [row["agreement"] for row in rows]
    errors = [row["max_rel_error"] for row in rows]
    good = [s for s, a, e in zip(scales, agree, errors) if a == 1.0 and e <= ERROR_LIMIT]
    lo_fail = max((s for s, a, e in zip(scales, agree, errors)
                   if (a < 1.0 or not e <= ERROR_LIMIT) and s < 1), default=None)
    hi_fail = min((s for s, a, e in zip(scales, agree, errors)
                   if (a < 1.0 or not e <= ERROR_LIMIT) and s > 1), default=None)
    r = SweepResult(
        "zone_scale", "port zone method vs scene scale",
        parameter=f"scale s of the page-4 blob and eye, 1e-12 to 1e160 ({m} rays each)",
        measured="hit/miss agreement with a 50-digit solve (no epsilon), max relative error",
        threshold=(f"exact hits and error <= {ERROR_LIMIT:g} for s in [{min(good):.0e}, "
                   f"{max(good):.0e}]; fails at s = {_g(lo_fail)} and below (the tutorial's "
                   f"absolute epsilon 0.01 rejects the hits) and at s = {_g(hi_fail)} and above "
                   f"(float64 overflow of squared distances)") if good else "fails everywhere",
        threshold_value=hi_fail, xlabel="scale s", ylabel="agreement / max rel. error",
        lines=[("y", ERROR_LIMIT, "")])
    r.series = [Series("hit/miss agreement", list(scales), agree, "s-"),
                Series("max rel. error of t", list(scales), errors)]
    r.table = rows
    r.check("hit distances finite wherever the port reports a hit",
            all(row["nonfinite_t"] == 0 for row in rows), "")
    r.check("no false hits (a hit where the exact field has none)",
            all(row["port_hits"] <= row["reference_hits"] for row in rows),
            "; ".join(f"s {row['scale']:.0e}: {row['port_hits']} > {row['reference_hits']}"
                      for row in rows if row["port_hits"] > row["reference_hits"]))
    r.check("exact at the tutorial's own scale (s = 1)", 1.0 in good, "")
    return r


def _g(value) -> str:
    return "- (never)" if value is None else f"{value:.0e}"
