"""Real noisebump(tutorial) BSDF sample against the numpy formulas on the same hits and u."""
import os, numpy as np, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
import codermind
from codermind_ref.scene import parse_scene
from codermind_ref import camera
from codermind_ref.transport import fresnel
from codermind_ref.vec import dot
W = os.environ.get("ROOT", os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
scene = parse_scene(f"{W}/scenes/page4.txt")
xml = open(f"{W}/scenes/page4.xml").read()
i = xml.index('id="material3"'); j = xml.index('bumplevel', i)
xml = xml[:j] + xml[j:].replace('value="0.1"', 'value="0"', 1)
import tempfile
tmp = os.path.join(tempfile.gettempdir(), f"bc_{os.getpid()}.xml")
open(tmp, "w").write(xml)
mi.file_resolver().append(f"{W}/scenes")
ms = mi.load_file(tmp)
os.remove(tmp)
blob = [s for s in ms.shapes() if s.is_mesh()][0]
bsdf = blob.bsdf()
rng = np.random.default_rng(3)
sx, sy = np.meshgrid(np.arange(600, 664) / 2.0, np.arange(500, 548) / 2.0)
fx, fy = np.repeat(sx.ravel(), 8), np.repeat(sy.ravel(), 8)
o, d = camera.rays(scene, fx, fy, rng.random(fx.size), rng.random(fx.size))
F = lambda a: mi.Float(a.astype(np.float32))
ray = mi.Ray3f(mi.Point3f(*map(F, o)), mi.Vector3f(*map(F, d)))
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
    inside = dot(nm, dd) > 0
    nf = np.where(inside, -nm, nm)
    ci = np.abs(dot(dd, nf))
    n1, n2 = np.where(inside, 2.0, 1.0), np.where(inside, 1.0, 2.0)
    R, ct = fresnel(n1, n2, ci)
    rf, tr = 0.9 * R, 0.9 * (1 - R)
    uu = np.where(inside, u * np.minimum(rf + tr, 1), u)
    refl = uu < rf; refr = ~refl & (uu < rf + tr)
    eta = n1 / n2
    dr_ = eta * (dd + ci * nf) - ct * nf; dr_ /= np.linalg.norm(dr_, axis=0)
    wo_mine = np.where(refl, dd - 2 * dot(dd, nf) * nf, dr_)
    w_mine = np.where(refl | refr, 0.9, 0.0)
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
