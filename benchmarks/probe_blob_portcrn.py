"""The real port (transport.roulette, clean) against the spec's formulas as probe_blob_crn.py
writes them (its port side), with the same draws per ray and segment: page 4's blob, lights
off, bump off, sphere 1 not a mirror (as probe_blob_real.py)."""
import argparse, os
import numpy as np
from codermind_ref.scene import parse_scene
from codermind_ref.world import World
from codermind_ref import camera, quirks as Q, transport
from codermind_ref.transport import fresnel
from codermind_ref.vec import dot

ap = argparse.ArgumentParser()
ap.add_argument("--lens", type=int, default=4)
ap.add_argument("--rect", default="300,250,332,274")
ap.add_argument("--seed", type=int, default=0)
ap.add_argument("--dseed", type=int, default=1)
a = ap.parse_args()
W = os.environ.get("ROOT", os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
scene = parse_scene(f"{W}/scenes/page4.txt")
scene.materials[3].bumplevel = 0.0
for l in scene.lights:
    l.intensity = (0.0, 0.0, 0.0)
scene.materials[1].reflection = 0.0
world = World(scene)
env = world.environment
x0, y0, x1, y1 = map(int, a.rect.split(","))
sx, sy = np.meshgrid(np.arange(2 * x0, 2 * x1) / 2.0, np.arange(2 * y0, 2 * y1) / 2.0)
sx, sy = sx.ravel(), sy.ravel()
o0, d0 = camera.rays(scene, sx, sy)
_, obj0 = world.intersect(o0, d0, np.full(sx.size, 2000.0), Q.CLEAN)
rng = np.random.default_rng(a.seed)
k = a.lens
fx, fy = np.repeat(sx, k), np.repeat(sy, k)
lab = np.repeat(obj0 == 3, k)
o, d = camera.rays(scene, fx, fy, rng.random(fx.size), rng.random(fx.size))
N = o.shape[1]
draws = np.random.default_rng(a.dseed).random((N, 2 + transport.MAX_SEGMENTS))
real = transport.roulette(world, o, d, draws, Q.CLEAN)

val = np.zeros((3, N)); coef = np.ones(N); ids = np.arange(N)
for seg in range(11):
    t, obj = world.intersect(o, d, np.full(ids.size, 2000.0), Q.CLEAN)
    miss = obj < 0
    val[:, ids[miss]] += coef[miss] * env.lookup(d[:, miss])
    go = obj == 3
    if seg == 10:
        break
    ids, o, d, t, coef = ids[go], o[:, go], d[:, go], t[go], coef[go]
    p = o + t * d
    n, _ = world.normal(p, np.full(ids.size, 3))
    inside = dot(n, d) > 0
    nf = np.where(inside, -n, n)
    ci = np.abs(dot(d, nf))
    n1, n2 = np.where(inside, 2.0, 1.0), np.where(inside, 1.0, 2.0)
    R, ct = fresnel(n1, n2, ci)
    rf, tr = 0.9 * R, 0.9 * (1 - R)
    u = draws[ids, 2 + seg]
    uu = np.where(inside, u * np.minimum(rf + tr, 1), u)
    refl = uu <= rf; refr = ~refl & (uu <= rf + tr)
    coef = coef * np.where(refl | refr, 0.9, 0.0)
    eta = n1 / n2
    dref = eta * (d + ci * nf) - ct * nf; dref /= np.sqrt(dot(dref, dref))
    d = np.where(refl, d - 2 * dot(d, nf) * nf, dref)
    o = p
    keep = coef > 0
    ids, o, d, coef = ids[keep], o[:, keep], d[:, keep], coef[keep]
dm = np.abs(val - real).max(0)
print(f"rays {N}: port vs formulas, same draws: rays with |dL| > 1e-6: {(dm > 1e-6).sum()}; blob means "
      f"port {real[:, lab].mean(1).round(6)} formulas {val[:, lab].mean(1).round(6)}")
