"""The real port (transport.roulette, clean) against the spec's formulas as probe_blob_crn.py
writes them (its port side), with the same draws per ray and segment: page 4's blob, lights
off, bump off, sphere 1 not a mirror (as probe_blob_real.py)."""
import os, sys
import numpy as np
from codermind_ref import quirks as Q, transport
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import probe_blob_common as C

ap = C.arg_parser(4, me=False)
ap.add_argument("--dseed", type=int, default=1)
a = ap.parse_args()
world, o, d, lab = C.crop_setup(a, bump=0.0, lights=False, mirror=False)
N = o.shape[1]
draws = np.random.default_rng(a.dseed).random((N, 2 + transport.MAX_SEGMENTS))
real = transport.roulette(world, o, d, draws, Q.CLEAN)
val, _, _ = C.trace_port(world, o, d, lambda seg, ids, d, n, p:
                         C.glass(d, n, draws[ids, 2 + seg], inclusive=True))
dm = np.abs(val - real).max(0)
print(f"rays {N}: port vs formulas, same draws: rays with |dL| > 1e-6: {(dm > 1e-6).sum()}; blob means "
      f"port {real[:, lab].mean(1).round(6)} formulas {val[:, lab].mean(1).round(6)}")
