"""Page 4's blob with both lights off (bump off), on the port's exact surface and on
Mitsuba's mesh, with common random numbers: the same roulette draw per ray and segment on both
sides (reflect with 0.9 R, refract with --refraction x (1 - R), else the path ends), so that
the difference is the geometry's alone. Spheres end the path (0) on both sides; a miss adds
the cube map. The deterministic special case (Refraction 0) is probe_blob_det.py."""
import argparse, os
import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
import codermind
from codermind_ref.scene import parse_scene
from codermind_ref.world import World
from codermind_ref import camera, quirks as Q
from codermind_ref.transport import fresnel
from codermind_ref.vec import dot
from codermind_ref.materials import bump

ap = argparse.ArgumentParser()
ap.add_argument("--me", type=float, default=0.086487)
ap.add_argument("--lens", type=int, default=0, help="lens draws per sub-sample (0: pinhole)")
ap.add_argument("--rect", default="300,250,332,274")
ap.add_argument("--seed", type=int, default=0)
ap.add_argument("--density", type=float, default=2.0)
ap.add_argument("--refraction", type=float, default=0.9)
ap.add_argument("--useed", type=int, default=1000)
ap.add_argument("--reps", type=int, default=1)
ap.add_argument("--rays", type=int, default=11)
ap.add_argument("--mitsuba-only", action="store_true")
ap.add_argument("--bump", type=float, default=0.0,
                help="Bumplevel on both geometries: the port's numpy bump (spec 2.9) of the "
                     "flipped normal at each side's own hit point")
a = ap.parse_args()
W = os.environ.get("ROOT", os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
scene = parse_scene(f"{W}/scenes/page4.txt")
scene.materials[3].bumplevel = 0.0
world = World(scene)
env = world.environment
x0, y0, x1, y1 = map(int, a.rect.split(","))
sx, sy = np.meshgrid(np.arange(2 * x0, 2 * x1) / 2.0, np.arange(2 * y0, 2 * y1) / 2.0)
sx, sy = sx.ravel(), sy.ravel()
o0, d0 = camera.rays(scene, sx, sy)          # lens-centre (pinhole) rays: the labels
t0, obj0 = world.intersect(o0, d0, np.full(sx.size, 2000.0), Q.CLEAN)
label = obj0 == 3
if a.lens:
    rng = np.random.default_rng(a.seed)
    k = a.lens
    fx, fy = np.repeat(sx, k), np.repeat(sy, k)
    u1, u2 = rng.random(fx.size), rng.random(fx.size)
    o, d = camera.rays(scene, fx, fy, u1, u2)
    lab = np.repeat(label, k)
else:
    o, d, lab, k = o0, d0, label, 1
N = o.shape[1]

def shade(inside, cos_i, u):
    """Common random numbers: the same u per ray and segment on both sides. Returns the weight
    (0 ends the path), whether it reflects, cos_t and n1/n2."""
    n1, n2 = np.where(inside, a.density, 1.0), np.where(inside, 1.0, a.density)
    R, cos_t = fresnel(n1, n2, cos_i)
    rf, tr = 0.9 * R, a.refraction * (1.0 - R)
    u = np.where(inside, u * np.minimum(rf + tr, 1.0), u)
    refl = u < rf
    refr = ~refl & (u < rf + tr)
    w = np.where(refl, 0.9, np.where(refr, a.refraction, 0.0))
    return w, refl, cos_t, n1 / n2

def newdir(d, nf, cos_i, refl, cos_t, eta):
    dr_ = eta * (d + cos_i * nf) - cos_t * nf
    dr_ = dr_ / np.sqrt(dot(dr_, dr_))
    return np.where(refl, d - 2 * dot(d, nf) * nf, dr_)

U = np.random.default_rng(a.useed).random((11, N))

def port(o, d):
    val = np.zeros((3, N)); coef = np.ones(N); ids = np.arange(N)
    segs = np.zeros(N, int); nin = np.zeros(N, int)
    for seg in range(a.rays):
        t, obj = world.intersect(o, d, np.full(ids.size, 2000.0), Q.CLEAN)
        miss = obj < 0
        val[:, ids[miss]] += coef[miss] * env.lookup(d[:, miss])
        segs[ids[miss]] = seg
        go = obj == 3
        if seg == a.rays - 1:
            break
        ids, o, d, t, coef = ids[go], o[:, go], d[:, go], t[go], coef[go]
        p = o + t * d
        n, _ = world.normal(p, np.full(ids.size, 3))
        inside = dot(n, d) > 0
        nf = np.where(inside, -n, n)
        if a.bump:
            nf = bump(nf, p, np.full(ids.size, a.bump))
        nin[ids] += inside
        ci = np.abs(dot(d, nf))
        w, refl, ct, eta = shade(inside, ci, U[seg, ids])
        coef = coef * w
        o, d = p, newdir(d, nf, ci, refl, ct, eta)
        keep = coef > 0
        ids, o, d, coef = ids[keep], o[:, keep], d[:, keep], coef[keep]
    return val, segs, nin

def mitsuba(ms, o, d):
    val = np.zeros((3, N)); coef = np.ones(N)
    segs = np.zeros(N, int); nin = np.zeros(N, int)
    ray = mi.Ray3f(mi.Point3f(*[mi.Float(v.astype(np.float32)) for v in o]),
                   mi.Vector3f(*[mi.Float(v.astype(np.float32)) for v in d]))
    alive = np.ones(N, bool)
    for seg in range(a.rays):
        si = ms.ray_intersect(ray)
        valid = np.array(si.is_valid()); mesh = np.array(si.is_valid() & si.shape.is_mesh())
        dd = np.array(ray.d)
        miss = alive & ~valid
        val[:, miss] += coef[miss] * env.lookup(dd[:, miss].astype(np.float64))
        segs[miss] = seg
        alive = alive & mesh
        if seg == a.rays - 1 or not alive.any():
            break
        nm = np.array(si.sh_frame.n).astype(np.float64)
        inside = dot(nm, dd) > 0           # noisebump's side test: unbumped shading normal
        nf = np.where(inside, -nm, nm)
        if a.bump:
            nf = bump(nf, np.array(si.p).astype(np.float64), np.full(N, a.bump))
        nin += inside & alive
        ci = np.abs(dot(dd, nf))
        w, refl, ct, eta = shade(inside, ci, U[seg])
        coef = np.where(alive, coef * w, 0.0)
        alive = alive & (coef > 0)
        wo = newdir(dd, nf, ci, refl, ct, eta)
        ray = si.spawn_ray(mi.Vector3f(*[mi.Float(v.astype(np.float32)) for v in wo]))
    return val, segs, nin

xml = open(f"{W}/scenes/page4.xml").read()
i = xml.index('id="material3"'); j = xml.index('bumplevel', i)
xml = xml[:j] + xml[j:].replace('value="0.1"', 'value="0"', 1)
tmp = os.path.join(__import__("tempfile").gettempdir(), f"det_{os.getpid()}.xml")
open(tmp, "w").write(xml)
mi.file_resolver().append(f"{W}/scenes")
ms = mi.load_file(tmp, blob0_max_error=a.me)
os.remove(tmp)
acc = []
for r in range(a.reps):
    U = np.random.default_rng(a.useed + r).random((11, N))
    vm, sm, im = mitsuba(ms, o, d)
    acc.append(vm[:, lab].mean(1))
acc = np.array(acc)
print(f"mine(mitsuba) rays {a.rays} reps {a.reps}: blob-labelled mean {acc.mean(0).round(5)} rel SE % {(100*acc.std(0, ddof=1)/np.sqrt(a.reps)/acc.mean(0)).round(3)}")
if not a.mitsuba_only:
    vp, sp, ip = port(o, d)
    vm, sm, im = mitsuba(ms, o, d)
    def rep(name, s):
        mp, mm = vp[:, s].mean(1), vm[:, s].mean(1)
        print(f"  {name:28s} n {s.sum():7d} port {mp.round(5)} mesh {mm.round(5)} "
              f"diff {(100*(mm/mp-1)).round(3)} %")
    print(f"bump {a.bump} max_error {a.me} lens {a.lens} density {a.density} refraction {a.refraction} (CRN seed {a.seed}): rays {N}")
    rep("blob-labelled", lab)
    rep("sky-labelled", ~lab)
    rep("all", np.ones(N, bool))
    for nm_, s in (("port escapes at seg 1", lab & (sp == 1)), ("port seg >= 2", lab & (sp >= 2)),
                   ("port never escapes", lab & (sp == 0)), ("port inside>=1", lab & (ip > 0)),
                   ("mesh inside>=1", lab & (im > 0))):
        rep(nm_, s)
    # contribution to the blob difference by the port's segment count at escape
    tot = (vm[:, lab] - vp[:, lab]).sum(1)
    for sg in range(0, 11):
        s = lab & (sp == sg)
        if s.sum():
            c = (vm[:, s] - vp[:, s]).sum(1)
            print(f"   port escape seg {sg:2d}: n {s.sum():7d} share of blob diff {(c/tot).round(3)}  mesh segs same {np.mean(sm[s]==sg):.3f}")
