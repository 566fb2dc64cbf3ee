"""The null distribution of compare's pooled test (Stouffer's Z of the clipped per-sub-sample z,
``metrics.stouffer``) when the two sides sample differently, on synthetic data.

Both sides are unbiased estimators of the same two-valued radiance (1 with probability p,
else 0: a sub-sample whose rays sometimes find a bright path): the port's N samples are
independent, Mitsuba's come in 16 passes of N / 16 jittered-stratified samples (as
``multijitter`` stratifies each pass), its variance from the pass means (as
``codermind.tutorial.render``). Under this null E[z] should be 0; the script prints the mean
clipped z, the Stouffer Z it gives over 3000 sub-samples (the page-4 blob crop's size), the
same for two independent sides (the port against itself), and the pooled difference
sum(a - b) / sqrt(sum(var_a + var_b)) over all sub-samples, whose numerator has mean 0 for
any two unbiased sides.

    python benchmarks/pooled_null.py [--n 200000] [--write-results [PATH]]

``--write-results`` writes the table to docs/results/compare.md (section ``pooled-null``).
"""

from __future__ import annotations

import argparse

import numpy as np

import _results

PASSES = 16
CLIP = 4.0          #: metrics.Z_CLIP


def iid(rng, n: int, spp: int, p: float):
    x = (rng.random((n, spp)) < p).astype(float)
    return x.mean(1), x.var(1, ddof=1) / spp


def stratified(rng, n: int, spp: int, p: float):
    m = spp // PASSES
    u = (np.arange(m)[None, None, :] + rng.random((n, PASSES, m))) / m
    pm = (u < p).mean(2)                                   # pass means
    return pm.mean(1), pm.var(1, ddof=1) / PASSES


def clipped_z(a, va, b, vb):
    sd = np.sqrt(va + vb)
    ok = sd > 0
    return np.clip((a - b)[ok] / sd[ok], -CLIP, CLIP)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=200000, help="sub-samples per setting")
    ap.add_argument("--seed", type=int, default=1)
    _results.add_argument(ap, "compare.md")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    lines = []
    emit = lines.append
    emit("| spp | p | mean z, stratified vs iid | Stouffer Z over 3000 | mean z, iid vs iid "
          "| Stouffer Z over 3000 | pooled difference Z, stratified vs iid, all sub-samples |")
    emit("| --- | --- | --- | --- | --- | --- | --- |")
    for spp in (16, 64, 256, 1024):
        for p in (0.02, 0.1, 0.3):
            n = args.n if spp <= 256 else args.n // 4
            b, vb = iid(rng, n, spp, p)
            a, va = stratified(rng, n, spp, p)
            b2, vb2 = iid(rng, n, spp, p)
            z, z2 = clipped_z(a, va, b, vb), clipped_z(b2, vb2, b, vb)
            zd = (a - b).sum() / np.sqrt((va + vb).sum())
            emit(f"| {spp} | {p} | {z.mean():+.4f} | {z.mean() * np.sqrt(3000):+.2f} | "
                 f"{z2.mean():+.4f} | {z2.mean() * np.sqrt(3000):+.2f} | {zd:+.2f} |")
            print(lines[-1], flush=True)
    if args.write_results:
        _results.write(args.write_results, "\n".join(lines) + "\n", section="pooled-null")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
