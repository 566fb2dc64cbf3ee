"""Page 4's blob with both lights off (bump off), on the port's exact surface and on
Mitsuba's mesh, with common random numbers: the same roulette draw per ray and segment on both
sides (reflect with 0.9 R, refract with --refraction x (1 - R), else the path ends), so that
the difference is the geometry's alone. Spheres end the path (0) on both sides; a miss adds
the cube map. The deterministic special case (Refraction 0) is probe_blob_det.py."""
import os, sys
import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
import codermind
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import probe_blob_common as C

ap = C.arg_parser(0, "lens draws per sub-sample (0: pinhole)")
ap.add_argument("--density", type=float, default=2.0)
ap.add_argument("--refraction", type=float, default=0.9)
ap.add_argument("--useed", type=int, default=1000)
ap.add_argument("--reps", type=int, default=1)
ap.add_argument("--rays", type=int, default=11)
ap.add_argument("--mitsuba-only", action="store_true")
ap.add_argument("--bump", type=float, default=0.0,
                help="Bumplevel on both geometries: the port's numpy bump (spec 2.9) of the "
                     "flipped normal at each side's own hit point")
ap.add_argument("--exact-hits", action="store_true",
                help="the mesh side shades at the blob's exact_hit (tutorialpath's exact_hits)")
a = ap.parse_args()
world, o, d, lab = C.crop_setup(a, bump=0.0)
env = world.environment
N = o.shape[1]

def step(seg, ids, d, n, p):
    """Common random numbers: the same u per ray and segment on both sides."""
    return C.glass(d, n, U[seg, ids], a.density, a.refraction, a.bump, p)

def port(o, d):
    return C.trace_port(world, o, d, step, a.rays)

def mitsuba(ms, o, d):
    return C.trace_mitsuba(ms, env, C.mi_ray(o, d), step, a.rays, a.exact_hits)

ms = C.load_mitsuba(C.page4_xml(bump=0), blob0_max_error=a.me)
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
    print(f"exact_hits {a.exact_hits} bump {a.bump} max_error {a.me} lens {a.lens} density {a.density} refraction {a.refraction} (CRN seed {a.seed}): rays {N}")
    C.report_port_mesh(vp, sp, ip, vm, sm, im, lab)
