"""Deterministic expectation of page 4's blob with Refraction 0 and both lights off (bump off):
outside hit -> 0.81 R L(refl), inside hit -> 0.9 L(refl); miss -> cube map; 10 segments, then
the 11th ray adds the cube map if it escapes. Spheres end the path (0) on both sides.
Same rays (pinhole or lens draws) on the port's exact surface and on Mitsuba's mesh."""
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
a = ap.parse_args()
world, o, d, lab = C.crop_setup(a, bump=0.0)
env = world.environment
N = o.shape[1]

def step(seg, ids, d, n, p):
    """Refraction 0, expectation: outside 0.81 R, inside 0.9, the mirror direction."""
    g = C.glass(d, n, density=a.density)
    g.w, g.wo = np.where(g.inside, 0.9, 0.81 * g.R), g.mirror
    return g

ms = C.load_mitsuba(C.page4_xml(bump=0), blob0_max_error=a.me)
vp, sp, ip = C.trace_port(world, o, d, step)
vm, sm, im = C.trace_mitsuba(ms, env, C.mi_ray(o, d), step)
print(f"max_error {a.me} lens {a.lens} density {a.density}: rays {N}")
C.report_port_mesh(vp, sp, ip, vm, sm, im, lab)
