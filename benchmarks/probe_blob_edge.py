"""Per-ray comparison at the page-4 blob's edge: port (exact zone surface, gradient normal)
against Mitsuba (mesh, interpolated exact normals). Pinhole, bump off, first hit only."""
import argparse, os, sys
import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
import codermind  # registers plugins
from codermind_ref.world import World
from codermind_ref import camera, quirks as Q
from codermind_ref.vec import dot
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import probe_blob_common as C

ap = argparse.ArgumentParser()
ap.add_argument("--me", type=float, default=0.086487)
ap.add_argument("--normals", default="exact")
ap.add_argument("--step", type=float, default=0.25)
ap.add_argument("--rect", default="300,250,332,274")
ap.add_argument("--dump", default="")
a = ap.parse_args()
x0, y0, x1, y1 = map(float, a.rect.split(","))
scene = C.port_scene(bump=0.0, dispersion=0.0)
world = World(scene)
fx, fy = np.meshgrid(np.arange(x0, x1, a.step), np.arange(y0, y1, a.step))
fx, fy = fx.ravel(), fy.ravel()
o, d = camera.rays(scene, fx, fy)
t, obj = world.intersect(o, d, np.full(fx.size, 2000.0), Q.CLEAN)
p = o + t * d
n, _ = world.normal(p, np.maximum(obj, 0))
g = C.glass(d, n)
inside, cos_i, R, refl = g.inside, g.ci, g.R, g.mirror
env = world.environment

ms = C.load_mitsuba(C.page4_xml(bump=0, normals=a.normals), blob0_max_error=a.me)
ray = C.mi_ray(o, d)
si = ms.ray_intersect(ray)
mesh = si.is_valid() & si.shape.is_mesh()
tm = np.array(si.t); hm = np.array(mesh)
pm, nm, ng = C.arr(si.p), C.arr(si.sh_frame.n), C.arr(si.n)
# Mitsuba's side test (noisebump: unbumped shading normal), cos_i in the shading frame
gm = C.glass(d, nm)
inside_m, cos_m, Rm, refl_m = gm.inside, gm.ci, gm.R, gm.mirror
# Mitsuba's own Fresnel (the tutorial BSDF's _fresnel) on the same cos_i, as a check
bsdf = [s for s in ms.shapes() if s.is_mesh()][0].bsdf().nested
rm_b, _, _ = bsdf._fresnel(mi.Float(cos_m.astype(np.float32)), mi.Bool(inside_m))
rm_b = np.array(rm_b)

hp = obj == 3
both = hp & hm
only_p, only_m = hp & ~hm, hm & ~hp
print(f"max_error {a.me} normals {a.normals}: rays {fx.size}, blob port {hp.sum()}, mesh {hm.sum()}, "
      f"both {both.sum()}, port-only {only_p.sum()}, mesh-only {only_m.sum()}")
print(f"  BSDF _fresnel vs numpy formula on Mitsuba cos_i: max |dR| {np.abs(rm_b - Rm)[both].max():.2e}")
b = both
dt = tm[b] - t[b]
ang = np.degrees(np.arccos(np.clip(dot(n[:, b], nm[:, b]), -1, 1)))
print(f"  t: port-minus-mesh mean {-dt.mean():.4f} sd {dt.std():.4f} max |dt| {np.abs(dt).max():.3f}")
print(f"  shading-normal angle (deg): mean {ang.mean():.3f} p99 {np.percentile(ang, 99):.3f} max {ang.max():.3f}")
ga = np.degrees(np.arccos(np.clip(np.abs(dot(ng[:, b], nm[:, b])), -1, 1)))
print(f"  mesh geometric vs shading normal (deg): mean {ga.mean():.3f} max {ga.max():.3f}")
print(f"  inside flag: port {inside[b].mean():.4f} mesh {inside_m[b].mean():.4f} differ {(inside[b]!=inside_m[b]).mean():.4f}")
print(f"  cos_i mean: port {cos_i[b].mean():.5f} mesh {cos_m[b].mean():.5f}")
print(f"  R mean: port {R[b].mean():.5f} mesh {Rm[b].mean():.5f} ratio {Rm[b].mean()/R[b].mean():.5f}")
Ep, Em = env.lookup(refl[:, b]), env.lookup(refl_m[:, b])
Qp, Qm = (R[b] * Ep).mean(axis=1), (Rm[b] * Em).mean(axis=1)
print(f"  R*env(refl) mean RGB: port {Qp.round(4)} mesh {Qm.round(4)} ratio {(Qm/Qp).round(4)}")
print(f"  env(refl) mean: port {Ep.mean(axis=1).round(4)} mesh {Em.mean(axis=1).round(4)}")
# by cos_i bins (port's)
edges = [0, 0.05, 0.1, 0.2, 0.3, 0.5, 1.01]
for lo, hi in zip(edges[:-1], edges[1:]):
    s = (cos_i[b] >= lo) & (cos_i[b] < hi)
    if s.sum():
        print(f"   cos_i [{lo:.2f},{hi:.2f}): n {s.sum():6d} R port {R[b][s].mean():.4f} mesh {Rm[b][s].mean():.4f} "
              f"cos mesh-port {(cos_m[b][s]-cos_i[b][s]).mean():+.5f}  inside p/m {inside[b][s].mean():.3f}/{inside_m[b][s].mean():.3f}")
if a.dump:
    np.savez(a.dump, fx=fx, fy=fy, t=t, obj=obj, n=n, tm=tm, hm=hm, nm=nm, ng=ng, R=R, Rm=Rm,
             cos_i=cos_i, cos_m=cos_m, inside=inside, inside_m=inside_m)
# second segment: the reflected ray from each side's hit
t2, obj2 = world.intersect(p[:, b], refl[:, b], np.full(b.sum(), 2000.0), Q.CLEAN)
wo = C.mi_vector(refl_m)
ray2 = si.spawn_ray(wo)
si2 = ms.ray_intersect(ray2)
h2 = np.array(si2.is_valid())[b]
hb2 = np.array(si2.is_valid() & si2.shape.is_mesh())[b]
gi = dot(ng[:, b], refl_m[:, b]) * np.sign(dot(ng[:, b], -d[:, b]))  # refl vs geometric, facing side
print(f"  reflected ray hits anything: port {(obj2>=0).mean():.4f} mesh {h2.mean():.4f}; hits blob: port {(obj2==3).mean():.4f} mesh {hb2.mean():.4f}")
print(f"  mesh reflected dir below the facet (geometric): {(gi<0).mean():.4f}")
g = cos_i[b] < 0.2
print(f"  cos_i<0.2 (n {g.sum()}): hits blob again port {(obj2[g]==3).mean():.4f} mesh {hb2[g].mean():.4f}; below facet {(gi[g]<0).mean():.4f}")
