"""Sweeps of the BSDFs: ``blinnphong`` against its exponent (up to the 1e6 it accepts), and
the tutorial's Fresnel (the ``tutorial`` BSDF and the port's ``transport.fresnel``) at total
internal reflection, normal incidence and eta = 1."""

from __future__ import annotations

import math

import numpy as np

from codermind.variants import set_variant
from codermind_ref.transport import fresnel as port_fresnel

from ._mitsuba import load_error
from .sweep_result import (Plan, Series, SweepResult, finite_check, finite_check_counts,
                           finite_counts, generator, states)

# -- blinnphong ------------------------------------------------------------------------------

PDF_LIMIT = 1e-2


class LobeDomain:
    """A ``mitsuba.chi2`` domain that resolves a lobe of any width around ``axis``: (phi, s)
    with t = 1 - cos(angle to axis) = s / (k (1 - s)), so the lobe (t ~ 1/k) fills the middle of
    s in [0, 2k / (1 + 2k)] whatever k is. Computed without cancellation in float32 (t from
    the perpendicular part). ``density`` converts a solid-angle pdf to this parameter space."""

    def __init__(self, mi, axis, k: float):
        self.mi, self.k = mi, float(k)
        self.frame = mi.Frame3f(mi.Vector3f(*[float(c) for c in axis]))
        self.s_max = 2 * self.k / (1 + 2 * self.k)

    def bounds(self):
        return self.mi.ScalarBoundingBox2f([-math.pi, 0.0], [math.pi, self.s_max])

    def aspect(self):
        return 1.0

    def map_forward(self, p):
        import drjit as dr
        mi = self.mi
        t = dr.minimum(p.y / (self.k * (1.0 - p.y)), 2.0)
        sin_a = dr.safe_sqrt(t * (2.0 - t))
        s, c = dr.sincos(p.x)
        return self.frame.to_world(mi.Vector3f(sin_a * c, sin_a * s, 1.0 - t))

    def map_backward(self, w):
        import drjit as dr
        local = self.frame.to_local(w)
        sin2 = dr.fma(local.x, local.x, local.y * local.y)
        t = dr.select(local.z > 0, sin2 / (1.0 + local.z), 1.0 - local.z)
        return self.mi.Vector2f(dr.atan2(local.y, local.x), self.k * t / (1.0 + self.k * t))

    def density(self, p, pdf):
        import drjit as dr
        jacobian = 1.0 / (self.k * dr.square(1.0 - p.y))       # dt/ds; d omega = dphi dt
        return dr.select(pdf > 0, pdf * jacobian, 0.0)


def _chi2(mi, exponent: float, wi, samples: int, res: int,
          pdf_exponent: float | None = None) -> tuple[str, float]:
    """Chi-square test of the glossy lobe alone (kd = 0) on a domain around the mirror
    direction; returns (problems found by the test besides the p-value, p-value).
    ``pdf_exponent``: test against another exponent's pdf (to show the test's power)."""
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest

    def adapter(e):
        spec = {"type": "blinnphong", "exponent": float(e),
                "diffuse_reflectance": 0.0, "specular_reflectance": 0.8}
        return BSDFAdapter("blinnphong", spec, wi=[float(c) for c in wi])
    sample, pdf = adapter(exponent)
    if pdf_exponent is not None:
        pdf = adapter(pdf_exponent)[1]
    domain = LobeDomain(mi, [-wi[0], -wi[1], wi[2]], (exponent + 1) / 2)

    def pdf_param(w):
        return domain.density(domain.map_backward(w), pdf(w))

    test = ChiSquareTest(domain=domain, sample_func=sample, pdf_func=pdf_param, sample_dim=3,
                         sample_count=samples, res=res, ires=8, seed=3)
    test.run(0.01, quiet=True)
    problems = "" if not test.fail else " ".join(
        line for line in test.messages.splitlines() if "ail" in line or "ncountered" in line)
    return problems, float(test.p_value) if test.p_value is not None else float("nan")


def _pdf64(wi, wo, exponent, p_spec):
    """blinnphong's pdf in float64 (its docstring's formulas)."""
    h = wi[:, None] + wo
    h /= np.linalg.norm(h, axis=0)
    cos_h = h[2]
    lobe = (exponent + 1) / (2 * np.pi) * np.where(cos_h > 0, np.abs(cos_h) ** exponent, 0.0)
    d_over = lobe / (4 * np.maximum(wi @ h, 1e-300))
    return p_spec * d_over + (1 - p_spec) * np.maximum(wo[2], 0) / np.pi


KD, KS = 0.2, 0.8


def _sizes(quick: bool) -> tuple[int, int, int]:
    """(directions sampled per point, chi2 samples, chi2 resolution)."""
    return (1 << 15, 200_000, 31) if quick else (1 << 18, 1_000_000, 51)


def _draw(rng: np.random.Generator, n: int):
    return rng.random(n), rng.random((2, n))


def _blinnphong_point(p: tuple) -> dict:
    """("lobe", exponent, angle, quick, generator state): sample and evaluate n directions,
    chi2; ("power", angle, quick): the chi2 test against a wrong pdf; ("refusals",)."""
    import drjit as dr
    mi = set_variant()
    if p[0] == "refusals":
        return {"messages": [load_error(mi, {"type": "blinnphong", "exponent": bad})
                             for bad in REFUSED]}
    if p[0] == "power":
        _, deg, quick = p
        th = math.radians(deg)
        n, samples, res = _sizes(quick)
        return {"wrong": _chi2(mi, 1e4, [math.sin(th), 0.0, math.cos(th)], samples, res,
                               pdf_exponent=1.05e4)}
    _, e, deg, quick, state = p
    n, samples, res = _sizes(quick)
    u1, u2 = _draw(generator(state), n)
    ctx = mi.BSDFContext()
    bsdf = mi.load_dict({"type": "blinnphong", "exponent": e,
                         "diffuse_reflectance": KD, "specular_reflectance": KS})
    th = math.radians(deg)
    wi = np.array([math.sin(th), 0.0, math.cos(th)])
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*[float(c) for c in wi])
    bs, weight = bsdf.sample(ctx, si, mi.Float(u1), mi.Point2f(u2))
    value, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
    wo, w, pv, v = bs.wo.numpy(), weight.numpy(), bs.pdf.numpy(), value.numpy()
    ok = pv > 0
    glossy = ok & (bs.sampled_component.numpy() == 1)
    consistent = bool(np.allclose(pdf.numpy()[ok], pv[ok], rtol=1e-5) and
                      np.allclose((w * pv)[:, ok], v[:, ok], rtol=1e-4, atol=1e-7))
    wi32 = wi.astype(np.float32).astype(np.float64)      # what the plugin got
    ref = _pdf64(wi32, wo[:, glossy].astype(np.float64), e, KS / (KD + KS))
    err = np.abs(pv[glossy] / ref - 1.0)
    problems, p_value = _chi2(mi, e, wi, samples, res)
    return {"finite": finite_counts(wo, w, pv, v, pdf.numpy()),
            "max_weight": float(w[:, ok].max(initial=0.0)), "consistent": consistent,
            "pdf_err": float(np.quantile(err, 0.99)) if err.size else float("nan"),
            "chi2_problems": problems, "chi2_p_value": p_value,
            "valid_fraction": float(ok.mean())}


REFUSED = (1e6 * 1.001, -1.0, float("inf"), float("nan"))


def blinnphong_exponent(quick: bool = False) -> Plan:
    """Points: each exponent at each incidence (the generator's state for its samples),
    the chi2 test's power, the refused exponents."""
    exponents = [1.0, 1e2, 1e4, 1e6] if quick else [1.0, 10.0, 1e2, 1e3, 1e4, 3e4, 1e5, 3e5, 1e6]
    angles = [30.0] if quick else [30.0, 80.0]
    n = _sizes(quick)[0]
    pairs = [(e, deg) for e in exponents for deg in angles]
    points = [("lobe", e, deg, quick, st) for (e, deg), st in
              zip(pairs, states(np.random.default_rng(6), lambda g: _draw(g, n), len(pairs)))]
    points += [("power", angles[0], quick), ("refusals",)]
    return Plan(points, _blinnphong_point,
                lambda results: _blinnphong_assemble(exponents, angles, pairs, results))


def _blinnphong_assemble(exponents, angles, pairs, results) -> SweepResult:
    kd, ks = KD, KS
    lobes, power, refusals = results[:len(pairs)], results[-2], results[-1]
    rows, pdf_err, weight_max, chi_p = [], {a: [] for a in angles}, [], {a: [] for a in angles}
    consistent = True
    worst = {}
    for (e, deg), x in zip(pairs, lobes):
        worst[e] = max(worst.get(e, 0.0), x["max_weight"])
        consistent &= x["consistent"]
        pdf_err[deg].append(x["pdf_err"])
        chi_p[deg].append(x["chi2_p_value"])
        rows.append({"exponent": e, "angle": deg, "chi2_problems": x["chi2_problems"],
                     "chi2_p_value": x["chi2_p_value"], "pdf_rel_error_q99": x["pdf_err"],
                     "max_weight": worst[e], "valid_fraction": x["valid_fraction"]})
    weight_max = [worst[e] for e in exponents]
    level = 1 - 0.99 ** (1 / len(rows))            # 1 % over all tests (Sidak)
    for row in rows:
        row["chi2_passed"] = not row["chi2_problems"] and row["chi2_p_value"] >= level
    chi_fail = next((r["exponent"] for r in rows if not r["chi2_passed"]), None)
    pdf_bad = next((r["exponent"] for r in rows if not r["pdf_rel_error_q99"] <= PDF_LIMIT), None)
    r = SweepResult(
        "blinnphong_exponent", "blinnphong sampling vs exponent",
        parameter=f"exponent 1 to 1e6 at incidence {', '.join(f'{a:g}' for a in angles)} deg",
        measured="chi2 of the lobe (a domain that resolves it), 99th percentile relative error "
                 "of the float32 pdf of sampled directions vs float64, max sample weight",
        threshold=(f"chi2 fails from exponent {chi_fail:g}" if chi_fail else
                   "chi2 passes up to 1e6") + "; " +
                  (f"pdf error > {PDF_LIMIT:g} from exponent {pdf_bad:g}" if pdf_bad else
                   f"pdf error <= {PDF_LIMIT:g} up to 1e6"),
        threshold_value=chi_fail or pdf_bad, xlabel="exponent",
        ylabel="rel. pdf error (q99) / chi2 p-value", lines=[("y", PDF_LIMIT, f"{PDF_LIMIT:g}"),
                                                            ("y", level, "chi2 level")])
    for deg in angles:
        r.series.append(Series(f"pdf error, {deg:g} deg", exponents, pdf_err[deg]))
        r.series.append(Series(f"chi2 p-value, {deg:g} deg", exponents, chi_p[deg], "s--"))
    r.table = rows
    wrong = power["wrong"]
    r.check("the chi2 test has power: sampling exponent 1e4 against the pdf of 1.05e4 fails",
            wrong[0] or wrong[1] < level, f"p-value {wrong[1]:.2g}")
    finite_check_counts(r, "sample(), eval_pdf() outputs finite for every exponent",
                        [x["finite"] for x in lobes])
    r.check("sample weight <= diffuse + specular (1) for every exponent",
            max(weight_max) <= kd + ks + 1e-5, f"max weight {max(weight_max):.6f}")
    r.check("eval == weight * pdf and pdf() == sampled pdf", consistent, "rtol 1e-4 / 1e-5")
    r.check("chi2 (1 %, Sidak-corrected) passes for every exponent and angle",
            all(row["chi2_passed"] for row in rows),
            f"smallest p-value {min(row['chi2_p_value'] for row in rows):.3g} (level "
            f"{level:.2g}); " + "; ".join(row["chi2_problems"] for row in rows
                                          if row["chi2_problems"]))
    for bad, message in zip(REFUSED, refusals["messages"]):
        r.check(f"exponent {bad:g} is refused naming 'exponent'",
                message is not None and "'exponent'" in message, message or "loaded")
    return r


# -- Fresnel ---------------------------------------------------------------------------------

#: (density, side) pairs: front means n1 = 1, n2 = density; inside the reverse.
CASES = [(1.5, "front"), (1.5, "inside"), (2.0, "inside"), (1.0, "front"), (1.0, "inside"),
         (0.5, "front")]


def _plugin_reflectance(mi, density: float, cos_i: np.ndarray, inside: bool):
    """R of the ``tutorial`` BSDF (reflection = refraction = 1) as its sampling probability
    of the mirror event, and the refracted direction (sample1 close to 1)."""
    import drjit as dr
    bsdf = mi.load_dict({"type": "tutorial", "reflection": 1.0, "refraction": 1.0,
                         "density": float(density)})
    n = cos_i.size
    z = -cos_i if inside else cos_i
    sin_i = np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0))
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(sin_i.astype(np.float32), np.zeros(n, np.float32), z.astype(np.float32))
    si.n = mi.Normal3f(0.0, 0.0, 1.0)
    si.sh_frame = mi.Frame3f(si.n)
    ctx = mi.BSDFContext()
    bs, weight = bsdf.sample(ctx, si, mi.Float(np.zeros(n)), mi.Point2f(0.5, 0.5))
    pdf, kind = bs.pdf.numpy(), bs.sampled_type.numpy()
    reflect = kind == int(mi.BSDFFlags.DeltaReflection)
    r = np.where(reflect, pdf, 1.0 - pdf)
    bs2, weight2 = bsdf.sample(ctx, si, mi.Float(np.full(n, 1 - 2.0 ** -24)), mi.Point2f(0.5, 0.5))
    return (r.astype(np.float64), bs2.wo.numpy(), bs2.pdf.numpy(), weight2.numpy(),
            bs2.sampled_type.numpy() == int(mi.BSDFFlags.DeltaTransmission), weight.numpy())


def _scalar_outputs(density: float) -> list[float]:
    """The tutorial BSDF in scalar_rgb (one call per direction, Python floats) at normal,
    grazing and exactly tangent incidence, both sides: every sample and eval value."""
    mi = set_variant("scalar_rgb")
    bsdf = mi.load_dict({"type": "tutorial", "reflection": 1.0, "refraction": 1.0,
                         "density": density, "diffuse": 0.5, "specular": 1.0, "power": 10.0})
    values = []
    for wi in ((0, 0, 1), (0, 0, -1), (1, 0, 0), (1, 0, -0.0), (0.99999, 0, 0.0044721),
               (0.99999, 0, -0.0044721), (0.0447, 0, 0.999), (0.0447, 0, -0.999)):
        si = mi.SurfaceInteraction3f()
        si.wi = _unit(mi, wi)
        si.n = mi.Normal3f(0, 0, 1)
        si.sh_frame = mi.Frame3f(si.n)
        for u in (0.0, 0.5, 1 - 2.0 ** -24):
            bs, w = bsdf.sample(mi.BSDFContext(), si, u, mi.Point2f(0.5, 0.5))
            values += [float(bs.pdf), *map(float, bs.wo), *map(float, w)]
        values += [float(c) for c in bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(0, 0, 1))]
    set_variant("llvm_ad_rgb")
    return values


def _unit(mi, v):
    x = np.asarray(v, dtype=np.float64)
    return mi.Vector3f(*(float(c) for c in x / np.linalg.norm(x)))


def _cos_i(quick: bool) -> np.ndarray:
    m = 2001 if quick else 20001
    return np.unique(np.concatenate([np.linspace(0.0, 1.0, m), np.geomspace(1e-9, 1e-2, 200),
                                     1.0 - np.geomspace(1e-9, 1e-2, 200), [0.999, 0.01]]))


def _fresnel_point(p: tuple) -> dict:
    """("case", density, side, quick): the port and the plugin at every incidence;
    ("scalar",): the scalar_rgb variant's outputs (or its exception)."""
    if p[0] == "scalar":
        try:
            return {"values": _scalar_outputs(1.5) + _scalar_outputs(1.0)}
        except Exception as e:              # noqa: BLE001  (a failed check, not a crash)
            return {"error": f"{type(e).__name__}: {e}"}
    mi = set_variant()
    _, density, side, quick = p
    cos_i = _cos_i(quick)
    inside = side == "inside"
    n1, n2 = (density, 1.0) if inside else (1.0, density)
    r_port, cos_t = port_fresnel(np.full(cos_i.size, n1), np.full(cos_i.size, n2), cos_i)
    r_plug, wo_t, pdf_t, w_t, is_t, w_r = _plugin_reflectance(mi, density, cos_i, inside)
    out = {"finite": finite_counts(r_port, cos_t, r_plug, wo_t, pdf_t, w_t, w_r),
           "r_min": np.concatenate([r_port, r_plug]).min(),
           "r_max": np.concatenate([r_port, r_plug]).max(),
           "n1": n1, "n2": n2}
    # the port at the plugin's float32 input, away from the cuts (where float32 and
    # float64 may take different branches); near the TIR cut R'(cos_i) ~ 1 / cos_t <= 100
    # amplifies float32 rounding, hence the tolerance
    c32 = np.abs(np.float32(cos_i)).astype(np.float64)
    r_at32 = port_fresnel(np.full(cos_i.size, n1), np.full(cos_i.size, n2), c32)[0]
    sin2_t = (n1 / n2) ** 2 * (1 - cos_i ** 2)
    away = (np.abs(sin2_t - 0.9999) > 1e-5) & (np.abs(cos_i - 0.999) > 1e-6)
    out["diff"] = float(np.abs(r_plug - r_at32)[away].max())
    # a refraction the roulette can pick must go to the other side, unit length
    picked = is_t & (pdf_t > 0)
    out["transmission_ok"] = True
    if picked.any():
        z = wo_t[2, picked]
        out["transmission_ok"] = bool(
            np.all(np.sign(z) == (1.0 if inside else -1.0)) and
            np.allclose(np.linalg.norm(wo_t[:, picked], axis=0), 1, atol=1e-5))
    # reflect + refract probabilities add to 1: no "diffuse" end of the path
    out["energy_ok"] = bool(np.all((pdf_t > 0) & (np.abs(w_t).max(axis=0) > 0)))
    # the jump at the TIR cut sin^2 t = 0.9999, where R is set to 1
    if n1 > n2 or density == 1.0:
        c_cut = math.sqrt(max(1 - 0.9999 * (n2 / n1) ** 2, 0.0))
        below = port_fresnel(np.array([n1]), np.array([n2]), np.array([c_cut * (1 + 1e-9)]))[0]
        out["jump"] = (c_cut, 1.0 - float(below[0]))
    deg = np.degrees(np.arccos(cos_i))
    keep = np.unique(np.linspace(0, cos_i.size - 1, 400).astype(int))
    out["curve"] = (list(deg[keep]), list(r_port[keep]), list(deg[keep][::8]),
                    list(r_plug[keep][::8]))
    out["R_normal"], out["R_grazing"] = float(r_port[-1]), float(r_port[0])
    if density == 1.0:
        one = np.flatnonzero(r_port == 1.0)
        out["one_max"] = float(cos_i[one].max()) if one.size else None
        zero_zone = (1 - cos_i ** 2) <= 0.9999
        out["zero_zone"] = (np.abs(r_port[zero_zone]).max(), np.abs(r_plug[zero_zone]).max())
    return out


def fresnel(quick: bool = False) -> Plan:
    """Points: each (density, side) case, the scalar variant."""
    points = [("case", density, side, quick) for density, side in CASES] + [("scalar",)]
    return Plan(points, _fresnel_point, _fresnel_assemble)


def _fresnel_assemble(results: list[dict]) -> SweepResult:
    r = SweepResult("fresnel", "tutorial Fresnel (plugin float32, port float64)",
                    parameter="incidence cos(theta_i) in [0, 1] (0 = grazing), density 0.5, 1, "
                              "1.5, 2, from outside and inside",
                    measured="reflectance R (plugin: its mirror-event probability), jumps at the "
                             "formula's cuts, plugin - port",
                    threshold="", threshold_value=None, xlabel="incidence angle (deg); lines: port",
                    ylabel="R", xlog=False, ylog=False)
    worst_diff, jumps = 0.0, {}
    transmission_ok, energy_ok = True, True
    eta1_grazing = None
    for (density, side), x in zip(CASES, results):
        worst_diff = max(worst_diff, x["diff"])
        transmission_ok &= x["transmission_ok"]
        energy_ok &= x["energy_ok"]
        if "jump" in x:
            jumps[(density, side)] = x["jump"]
        label = f"density {density:g} {side}"
        deg, port, deg8, plug8 = x["curve"]
        color = f"C{len(r.series) // 2}"
        r.series.append(Series(label, deg, port, "-", color))
        r.series.append(Series("plugin (x)" if len(r.series) == 1 else "_plugin",
                               deg8, plug8, "x", color))
        r.table.append({"density": density, "side": side, "n1": x["n1"], "n2": x["n2"],
                        "R_normal": x["R_normal"], "R_grazing": x["R_grazing"],
                        "max_abs_plugin_minus_port": x["diff"]})
        if density == 1.0:
            if x["one_max"] is not None:
                eta1_grazing = max(eta1_grazing or 0.0, x["one_max"])
            port0, plug0 = x["zero_zone"]
            r.check(f"eta = 1 ({side}): R = 0 wherever sin^2 theta <= 0.9999 (port and plugin)",
                    port0 <= 1e-12 and plug0 <= 1e-6,
                    f"max R port {port0:.2g}, plugin {plug0:.2g}")
    cases = results[:len(CASES)]
    finite_check_counts(r, "R, cos_t, sampled directions and weights finite (grazing and "
                           "normal incidence included)", [x["finite"] for x in cases])
    lo = np.min([x["r_min"] for x in cases])        # NaN propagates, as over all values
    hi = np.max([x["r_max"] for x in cases])
    r.check("0 <= R <= 1", lo >= 0 and hi <= 1, f"range [{lo:.3g}, {hi:.3g}]")
    r.check("plugin R = port R away from the cuts (within 1e-4)", worst_diff <= 1e-4,
            f"max difference {worst_diff:.2g}")
    r.check("refracted directions cross the surface, unit length", transmission_ok, "")
    r.check("reflect + refract probabilities sum to 1 (Reflection = Refraction = 1)", energy_ok, "")
    scalar = results[len(CASES)]
    if "values" in scalar:
        finite_check(r, "scalar_rgb: no exception, finite at normal, grazing and tangent "
                        "incidence", scalar["values"])
    else:
        r.check("scalar_rgb: no exception at normal, grazing and tangent incidence", False,
                scalar["error"])
    jump_text = ", ".join(f"{d:g} {s}: {j:.3f} at cos {c:.4f}" for (d, s), (c, j) in jumps.items()
                          if d != 1.0)
    r.threshold = (f"R jumps to 1 at the TIR cut sin^2 theta_t = 0.9999 ({jump_text}); "
                   f"eta = 1 gives R = 1 for cos theta_i < {eta1_grazing:.4f} "
                   f"(the TIR cut fires at grazing incidence)")
    r.threshold_value = eta1_grazing
    for (d, s), (c, j) in jumps.items():
        if d != 1.0:
            r.lines.append(("x", math.degrees(math.acos(c)), ""))
    r.notes.append("Density 1 gives R = 0 except near grazing (facts.md F8.4): the formula gives "
                   "R = 1 within 0.57 deg of grazing (sin^2 theta_t = sin^2 theta_i > 0.9999), "
                   "and both implementations follow the formula.")
    r.notes.append(f"TIR jumps (1 - R just before the cut): {jump_text}")
    return r
