"""The two real implementations on the same camera rays: port transport.roulette (clean) and
Mitsuba's tutorialpath integrator.sample, lights off, bump off; K independent repetitions."""
import os, sys
import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
import codermind
from codermind_ref import quirks as Q, transport
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import probe_blob_common as C

ap = C.arg_parser(16)
ap.add_argument("--reps", type=int, default=8)
ap.add_argument("--refraction", type=float, default=0.9)
ap.add_argument("--lights", type=int, default=0)
ap.add_argument("--bump", type=float, default=0.0)
ap.add_argument("--max-depth", type=int, default=11)  # both sides: K rays (port: MAX_SEGMENTS = K - 1)
ap.add_argument("--no-mirror", action="store_true")
ap.add_argument("--mirror-bump", type=float, default=0.1)
ap.add_argument("--port-reps", type=int, default=-1)
ap.add_argument("--exact-hits", choices=("true", "false"), default=None,
                help="the integrator's exact_hits (default: the scene's)")
ap.add_argument("--float32-means", action="store_true", help="also print the old float32 reduction")
a = ap.parse_args()
transport.MAX_SEGMENTS = a.max_depth - 1
edits = dict(bump=a.bump, refraction=a.refraction, lights=a.lights, mirror=not a.no_mirror,
             mirror_bump=a.mirror_bump)
world, o, d, lab = C.crop_setup(a, **edits)
N = o.shape[1]
ms = C.load_mitsuba(C.page4_xml(**edits, exact_hits=a.exact_hits), blob0_max_error=a.me, max_depth=a.max_depth)
integ = ms.integrator()
ray = C.mi_ray(o, d, differential=True)
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
print(f"exact_hits {a.exact_hits} max_depth {a.max_depth} no_mirror {a.no_mirror} mirror_bump {a.mirror_bump} max_error {a.me} lens {a.lens} reps {a.reps} refraction {a.refraction} lights {a.lights} bump {a.bump}: rays {N}")
for name, s in (("blob-labelled", lab), ("sky-labelled", ~lab)):
    mp, mm = P[:, :, s].mean((0, 2)), M[:, :, s].mean((0, 2))
    vp = P[:, :, s].var(0, ddof=1).sum(1) / (P.shape[0] * s.sum() ** 2)
    vm = M[:, :, s].var(0, ddof=1).sum(1) / (a.reps * s.sum() ** 2)
    z = (mm - mp) / np.sqrt(vp + vm)
    print(f"  {name:14s} n {s.sum():6d} port {mp.round(5)} mitsuba {mm.round(5)} "
          f"diff {(100*(mm/mp-1)).round(3)} % z {z.round(2)}; rel SE mitsuba {(100*np.sqrt(vm)/mm).round(3)} % port {(100*np.sqrt(vp)/mp).round(3)} %")
