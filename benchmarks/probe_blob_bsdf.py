"""Real noisebump(tutorial) BSDF sample against the numpy formulas on the same hits and u."""
import os, sys, numpy as np, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
import codermind
from codermind_ref.vec import dot
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import probe_blob_common as C
scene = C.port_scene()
ms = C.load_mitsuba(C.page4_xml(bump=0))
blob = [s for s in ms.shapes() if s.is_mesh()][0]
bsdf = blob.bsdf()
rng = np.random.default_rng(3)
o, d, _ = C.crop_rays(scene, "300,250,332,274", 8, rng)
F = C.mi_float
ray = C.mi_ray(o, d)
ctx = mi.BSDFContext()
for seg in range(4):
    si = ms.ray_intersect(ray)
    on = np.array(si.is_valid() & si.shape.is_mesh())
    dd = np.array(ray.d).astype(np.float64)
    u = rng.random(on.size)
    bs, w = bsdf.sample(ctx, si, F(u), mi.Point2f(0.5), mi.Bool(on))
    wo_real = np.array(si.to_world(bs.wo)).astype(np.float64)
    w_real = np.array(w)[0] if np.array(w).shape[0] == 3 else np.array(w)[:, 0]
    nm = np.array(si.sh_frame.n).astype(np.float64)
    g = C.glass(dd, nm, u)
    inside, nf, ci, R, refl = g.inside, g.nf, g.ci, g.R, g.refl
    wo_mine, w_mine = g.wo, g.w
    ok = on & (w_mine > 0) & (w_real > 0)
    err = np.linalg.norm(wo_real - wo_mine, axis=0)
    print(f"seg {seg}: blob hits {on.sum()}, inside {inside[on].mean():.3f}, weight>0 real {(w_real[on]>0).mean():.4f} mine {(w_mine[on]>0).mean():.4f}, "
          f"event mismatch {((w_real>0)!=(w_mine>0))[on].mean():.5f}, dir err max {err[ok].max():.2e} p99.9 {np.percentile(err[ok], 99.9):.2e}, "
          f"reflect frac real? mine {refl[ok].mean():.3f}; dirs >1e-3 off {(err[ok]>1e-3).mean():.5f}")
    bad = ok & (err > 1e-3)
    if bad.any():
        k = np.flatnonzero(bad)[:3]
        for q in k:
            print("   ", "inside", inside[q], "ci", ci[q], "refl", refl[q], "R", R[q], "real", wo_real[:, q].round(4), "mine", wo_mine[:, q].round(4), "gn.d", float(dot(np.array(si.n)[:, q:q+1], dd[:, q:q+1])))
    keep = on & (w_real > 0)
    ray = si.spawn_ray(si.to_world(bs.wo))
    ray = mi.Ray3f(ray.o, ray.d)
    # keep only continuing lanes by pushing dead ones far away
    o2 = np.array(ray.o); o2[:, ~keep] = 1e7
    ray = mi.Ray3f(mi.Point3f(*map(mi.Float, o2)), ray.d)
