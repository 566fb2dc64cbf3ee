"""Mitsuba's tutorialpath with two blob meshes on the same camera rays and sampler seeds: how
much of the image depends on the mesh (the exact surface is the same for both).

The two renders share every random number up to where the geometry makes a path differ, so
their ratio is measured far more precisely than either against the port. Variants: ``base``
(the scene as converted), ``nolights`` (the lights' intensity 0 through ``mi.traverse``),
``noshadow`` (shadow rays never blocked). With ``--where`` it also prints the sub-samples
that carry the difference, with their distance (in sub-samples) from the nearest sub-sample
whose pinhole ray misses the blob: a silhouette effect sits at distance 1.

    python benchmarks/probe_blob_meshpair.py [--mes 0.0216,0.0054] [--reps 64]
        [--variants base,nolights,noshadow] [--max-depth 11] [--where 12] [--rect ...]
"""
import os
import sys
import time

import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import codermind  # noqa: E402,F401
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import probe_blob_common as C  # noqa: E402

ap = C.arg_parser(16, me=False)
ap.add_argument("--reps", type=int, default=64)
ap.add_argument("--mes", default="0.0216,0.0054", help="the two meshes' max_error")
ap.add_argument("--variants", default="base,nolights,noshadow")
ap.add_argument("--max-depth", type=int, default=11)
ap.add_argument("--where", type=int, default=0, help="list the N sub-samples of largest |diff|")
a = ap.parse_args()
world, o, d, lab = C.crop_setup(a)
ray = C.mi_ray(o, d, differential=True)
N = o.shape[1]
mes = [float(x) for x in a.mes.split(",")]
variants = a.variants.split(",")
means, maps = {}, {}
for me in mes:
    t0 = time.time()
    ms = C.load_mitsuba(C.page4_xml(), blob0_max_error=me, max_depth=a.max_depth)
    print(f"max_error {me}: loaded in {time.time() - t0:.1f} s", flush=True)
    integ = ms.integrator()
    params = mi.traverse(ms)
    keys = [k for k in params.keys() if k.endswith("intensity.value")]
    lit = {k: mi.Color3f(params[k]) for k in keys}
    for v in variants:
        for k in keys:
            params[k] = mi.Color3f(0.0) if v == "nolights" else lit[k]
        params.update()
        if v == "noshadow":             # the integrator's own shadow rays, made empty
            real = integ._shadow

            def empty(si, ds, squared, on_exact, real=real):
                r = real(si, ds, squared, on_exact)
                r.maxt = mi.Float(0.0)
                return r
            integ._shadow = empty
        per_rep, total = [], np.zeros(N)
        for r in range(a.reps):
            sampler = mi.load_dict({"type": "independent"})
            sampler.seed(a.seed * 100 + r + 7, N)
            L = np.array(integ.sample(ms, sampler, ray, None, True)[0])
            L = (L if L.shape[0] == 3 else L.T).astype(np.float64)
            per_rep.append(L[:, lab].mean(1))
            total += L.sum(0)
        if v == "noshadow":
            del integ._shadow
        means[me, v], maps[me, v] = np.array(per_rep), total / a.reps
        print(f"  {v}: blob mean {means[me, v].mean(0).round(5)}", flush=True)

k = max(a.lens, 1)
x0, y0, x1, y1 = map(int, a.rect.split(","))
W = 2 * (x1 - x0)
labp = lab.reshape(-1, k)[:, 0]
for v in variants:
    ratio = means[mes[0], v] / means[mes[1], v] - 1
    se = ratio.std(0, ddof=1) / np.sqrt(len(ratio))
    print(f"{v}: mesh {mes[0]} / mesh {mes[1]} - 1 on the blob = {(100 * ratio.mean(0)).round(3)}"
          f" % +- {(100 * se).round(3)} %")
    if a.where:
        diff = (maps[mes[0], v] - maps[mes[1], v]).reshape(-1, k).sum(1)
        idx = np.flatnonzero(labp)[np.argsort(-np.abs(diff[labp]))[:a.where]]
        off = np.argwhere(~labp.reshape(-1, W))
        share = diff[idx].sum() / diff[labp].sum()
        print(f"  the {a.where} largest sub-samples carry {100 * share:.0f} % of the difference:")
        for i in idx:
            yy, xx = divmod(i, W)
            dist = np.abs(off - [yy, xx]).max(1).min() if len(off) else -1
            print(f"    ({x0 + xx / 2:.1f}, {y0 + yy / 2:.1f}) distance {dist} diff {diff[i]:+.4f}")
