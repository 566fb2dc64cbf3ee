"""Page 4's glass blob, lights off, bump off, sphere 1 not a mirror (as probe_blob_real.py):
the real `tutorialpath` integrator against a per-segment replica of it and the spec's formulas.

1. integrator.sample with an independent sampler of seed S -> L per ray;
2. the replica: the same loop unrolled in Python (scene.ray_intersect, the real BSDF's
   eval_sample through dr.dispatch, sampler.next_1d / next_2d in the integrator's order, with
   a sampler of the same seed) -> L per ray and per-segment records (hit, u, event, wo);
3. the spec 2.7 formulas in float64 on the replica's float32 hits with the same u: event and
   direction per segment.
If (1) == (2) ray by ray, the integrator's loop (depth count, sampler state, escape, limit) is
the replica; (2) against (3) is the BSDF over whole paths."""
import os, sys
import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
import codermind
from codermind.integrators.tutorialpath import _eval_sample
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import probe_blob_common as C

ap = C.arg_parser(4)
ap.add_argument("--sseed", type=int, default=7)
ap.add_argument("--max-depth", type=int, default=11)
ap.add_argument("--save", default="")
a = ap.parse_args()
world, o, d, lab = C.crop_setup(a)
N = o.shape[1]
ms = C.load_mitsuba(C.page4_xml(bump=0, lights=False, mirror=False),
                    blob0_max_error=a.me, max_depth=a.max_depth)
integ = ms.integrator()
A = C.arr
ray0 = C.mi_ray(o, d, differential=True)

# 1. the real integrator
sampler = mi.load_dict({"type": "independent"})
sampler.seed(a.sseed, N)
L_int = A(integ.sample(ms, sampler, ray0, None, True)[0]).astype(np.float64)

# 2. the replica, recording every segment
sampler = mi.load_dict({"type": "independent"})
sampler.seed(a.sseed, N)
ctx = mi.BSDFContext()
ray = mi.Ray3f(ray0)
beta = np.ones((3, N)); L = np.zeros((3, N)); alive = np.ones(N, bool)
rec = []
for depth in range(a.max_depth):
    si = ms.ray_intersect(ray, ray_flags=mi.RayFlags.All, coherent=(depth == 0))
    valid = A(si.is_valid()).astype(bool)
    emitted = A(si.emitter(ms).eval(si, mi.Bool(alive)))
    L += np.where(alive, beta * emitted, 0.0)
    act = alive & valid & (depth + 1 < a.max_depth)
    bsdf = si.bsdf(ray)
    u = sampler.next_1d()
    u2 = sampler.next_2d()
    _, bs, w = dr.dispatch(bsdf, _eval_sample, ctx, si, [], u, u2, active=mi.Bool(act))
    wo = si.to_world(bs.wo)
    r = dict(alive=alive.copy(), valid=valid, mesh=A(si.is_valid() & si.shape.is_mesh()).astype(bool),
             d=A(ray.d).astype(np.float64), o=A(ray.o).astype(np.float64),
             p=A(si.p).astype(np.float64), n=A(si.n).astype(np.float64),
             ns=A(si.sh_frame.n).astype(np.float64), t=A(si.t).astype(np.float64),
             u=A(u).astype(np.float64), wo=A(wo).astype(np.float64),
             w=A(w)[0].astype(np.float64), typ=A(bs.sampled_type))
    rec.append(r)
    beta = beta * A(w)
    act = act & (np.abs(beta).max(0) != 0)
    ray = si.spawn_ray(wo)
    alive = act
L_rep = L
dl = np.abs(L_rep - L_int).max()
print(f"rays {N} (blob-labelled {lab.sum()}), max_error {a.me}, max_depth {a.max_depth}, sampler seed {a.sseed}")
print(f"1 vs 2: integrator vs replica, max |dL| {dl:.3g}; blob means int {L_int[:, lab].mean(1).round(6)} rep {L_rep[:, lab].mean(1).round(6)}")

# 3. the spec's formulas in float64 on the replica's hits, same u
print("seg  on_blob  inside  TIR   reflect  refract  end   | event mismatch  dir err max  p99.9")
for s, r in enumerate(rec[:-1]):
    on = r["alive"] & r["mesh"]
    dd = r["d"] / np.linalg.norm(r["d"], axis=0)
    g = C.glass(dd, r["ns"], r["u"])
    inside, R, ci, refl, refr, wo_m = g.inside, g.R, g.ci, g.refl, g.refr, g.wo
    ev_m = np.where(refl, 0, np.where(refr, 1, 2))
    real_refl = (r["w"] > 0) & (r["typ"] == int(mi.BSDFFlags.DeltaReflection))
    real_refr = (r["w"] > 0) & (r["typ"] == int(mi.BSDFFlags.DeltaTransmission))
    ev_r = np.where(real_refl, 0, np.where(real_refr, 1, 2))
    both = on & (ev_m < 2) & (ev_r < 2) & (ev_m == ev_r)
    err = np.linalg.norm(r["wo"] - wo_m, axis=0)
    tir = on & (R == 1.0)
    print(f"{s:3d} {on.sum():8d} {inside[on].mean():6.3f} {tir.sum()/max(on.sum(),1):6.3f} "
          f"{(ev_r[on]==0).mean():7.4f} {(ev_r[on]==1).mean():7.4f} {(ev_r[on]==2).mean():6.4f} | "
          f"{(ev_m != ev_r)[on].sum():6d} {err[both].max() if both.any() else 0:.2e} "
          f"{np.percentile(err[both], 99.9) if both.any() else 0:.2e}")
    r.update(inside=inside, R=R, ci=ci, ev_m=ev_m, ev_r=ev_r)
if a.save:
    np.savez_compressed(a.save, L_int=L_int, L_rep=L_rep, lab=lab, o=o, d=d,
                        **{f"{key}{s}": r[key] for s, r in enumerate(rec) for key in
                           ("alive", "valid", "mesh", "d", "o", "p", "n", "ns", "t", "u", "wo", "w", "typ")})

# 4. the spec's formulas in float64 along whole paths (probe_blob_crn.py's Mitsuba side: own
#    directions, Mitsuba's hits and spawn_ray), with the sampler's u of each segment
val, _, _ = C.trace_mitsuba(ms, world.environment, mi.Ray3f(ray0),
                            lambda s, ids, d, n, p: C.glass(d, n, rec[s]["u"]), a.max_depth)
dm = np.abs(val - L_int).max(0)
print(f"4 vs 1: float64 formulas on Mitsuba's hits with the sampler's u: rays with |dL| > 1e-4: "
      f"{(dm > 1e-4).sum()} of {N}; blob means model {val[:, lab].mean(1).round(6)} "
      f"int {L_int[:, lab].mean(1).round(6)} diff {(100 * (val[:, lab].mean(1) / L_int[:, lab].mean(1) - 1)).round(4)} %")
