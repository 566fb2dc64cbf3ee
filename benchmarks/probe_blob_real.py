"""The two real implementations on the same camera rays: port transport.roulette (clean) and
Mitsuba's tutorialpath integrator.sample, lights off, bump off; K independent repetitions."""
import argparse, os
import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
import codermind
from codermind_ref.scene import parse_scene
from codermind_ref.world import World
from codermind_ref import camera, quirks as Q, transport

ap = argparse.ArgumentParser()
ap.add_argument("--me", type=float, default=0.086487)
ap.add_argument("--lens", type=int, default=16)
ap.add_argument("--reps", type=int, default=8)
ap.add_argument("--refraction", type=float, default=0.9)
ap.add_argument("--lights", type=int, default=0)
ap.add_argument("--bump", type=float, default=0.0)
ap.add_argument("--rect", default="300,250,332,274")
ap.add_argument("--seed", type=int, default=0)
ap.add_argument("--max-depth", type=int, default=11)  # both sides: K rays (port: MAX_SEGMENTS = K - 1)
ap.add_argument("--no-mirror", action="store_true")
ap.add_argument("--mirror-bump", type=float, default=0.1)
ap.add_argument("--port-reps", type=int, default=-1)
ap.add_argument("--float32-means", action="store_true", help="also print the old float32 reduction")
a = ap.parse_args()
transport.MAX_SEGMENTS = a.max_depth - 1
W = os.environ.get("ROOT", os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
scene = parse_scene(f"{W}/scenes/page4.txt")
scene.materials[3].bumplevel = a.bump
scene.materials[3].refraction = a.refraction
if not a.lights:
    for l in scene.lights:
        l.intensity = (0.0, 0.0, 0.0)
if a.no_mirror:
    scene.materials[1].reflection = 0.0
scene.materials[1].bumplevel = a.mirror_bump
world = World(scene)
x0, y0, x1, y1 = map(int, a.rect.split(","))
sx, sy = np.meshgrid(np.arange(2 * x0, 2 * x1) / 2.0, np.arange(2 * y0, 2 * y1) / 2.0)
sx, sy = sx.ravel(), sy.ravel()
o0, d0 = camera.rays(scene, sx, sy)
_, obj0 = world.intersect(o0, d0, np.full(sx.size, 2000.0), Q.CLEAN)
rng = np.random.default_rng(a.seed)
k = max(a.lens, 1)
fx, fy = np.repeat(sx, k), np.repeat(sy, k)
lab = np.repeat(obj0 == 3, k)
if a.lens:
    o, d = camera.rays(scene, fx, fy, rng.random(fx.size), rng.random(fx.size))
else:
    o, d = camera.rays(scene, fx, fy)
N = o.shape[1]

xml = open(f"{W}/scenes/page4.xml").read()
i = xml.index('id="material3"'); j = xml.index('bumplevel', i)
xml = xml[:j] + xml[j:].replace('value="0.1"', f'value="{a.bump}"', 1)
j = xml.index('name="refraction"', i)
xml = xml[:j] + xml[j:].replace('value="0.9"', f'value="{a.refraction}"', 1)
if not a.lights:
    xml = xml.replace('name="intensity" value="5, 5, 5"', 'name="intensity" value="0, 0, 0"')
    xml = xml.replace('name="intensity" value="0.6, 0.7, 1"', 'name="intensity" value="0, 0, 0"')
i = xml.index('id="material1"'); j = xml.index('bumplevel', i)
xml = xml[:j] + xml[j:].replace('value="0.1"', f'value="{a.mirror_bump}"', 1)
if a.no_mirror:
    j = xml.index('name="reflection"', i)
    xml = xml[:j] + xml[j:].replace('value="1"', 'value="0"', 1)
tmp = os.path.join(__import__("tempfile").gettempdir(), f"real_{os.getpid()}.xml")
open(tmp, "w").write(xml)
mi.file_resolver().append(f"{W}/scenes")
ms = mi.load_file(tmp, blob0_max_error=a.me, max_depth=a.max_depth)
os.remove(tmp)
integ = ms.integrator()
ray = mi.RayDifferential3f(mi.Point3f(*[mi.Float(v.astype(np.float32)) for v in o]),
                           mi.Vector3f(*[mi.Float(v.astype(np.float32)) for v in d]))
P, M = [], []
for r in range(a.reps):
    draws = np.random.default_rng(a.seed * 100 + r + 1).random((N, 2 + transport.MAX_SEGMENTS))
    if r < (a.reps if a.port_reps < 0 else a.port_reps):
        P.append(transport.roulette(world, o, d, draws, Q.CLEAN))
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(a.seed * 100 + r + 7, N)
    L, _, _ = integ.sample(ms, sampler, ray, None, True)
    L = np.array(L)
    M.append((L if L.shape[0] == 3 else L.T).astype(np.float64))
# float64: numpy's float32 reduction over (reps, rays) loses about 0.1 % at 64 reps and
# several % at 512 (it made a spurious G/B 'tilt' of the Mitsuba side, issue 16)
P, M = np.stack(P), np.stack(M)        # (reps, 3, N)
if a.float32_means:
    M32 = M.astype(np.float32)
    for name, s in (("blob-labelled", lab), ("sky-labelled", ~lab)):
        print(f"  float32 reduction as before (issue 16): {name} mitsuba {M32[:, :, s].mean((0, 2)).round(5)} "
              f"float64 {M[:, :, s].mean((0, 2)).round(5)}")
print(f"max_depth {a.max_depth} no_mirror {a.no_mirror} mirror_bump {a.mirror_bump} max_error {a.me} lens {a.lens} reps {a.reps} refraction {a.refraction} lights {a.lights} bump {a.bump}: rays {N}")
for name, s in (("blob-labelled", lab), ("sky-labelled", ~lab)):
    mp, mm = P[:, :, s].mean((0, 2)), M[:, :, s].mean((0, 2))
    vp = P[:, :, s].var(0, ddof=1).sum(1) / (P.shape[0] * s.sum() ** 2)
    vm = M[:, :, s].var(0, ddof=1).sum(1) / (a.reps * s.sum() ** 2)
    z = (mm - mp) / np.sqrt(vp + vm)
    print(f"  {name:14s} n {s.sum():6d} port {mp.round(5)} mitsuba {mm.round(5)} "
          f"diff {(100*(mm/mp-1)).round(3)} % z {z.round(2)}; rel SE mitsuba {(100*np.sqrt(vm)/mm).round(3)} % port {(100*np.sqrt(vp)/mp).round(3)} %")
