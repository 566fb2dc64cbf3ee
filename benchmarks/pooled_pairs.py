"""The pooled tests' failure rate on one crop, measured on many renders of each side instead
of one compare run per seed.

Renders the crop with ``codermind compare``'s own sides (``sides.render_mitsuba``,
``sides.render_port``) for seeds S, S+1, ..., keeps each render's linear image and variance
(``--keep DIR``, one ``.npz`` per seed, reused when present), then judges every pair by the
pooled tests compare runs (tiles and objects, ``compare.pooled_tests``' groups and levels):

* **port vs port** and **Mitsuba vs Mitsuba**, two seeds of one side: the null of the tests
  on this crop's real radiance distribution (no modelling difference at all);
* **Mitsuba vs port**, every Mitsuba render against every port render (N x N pairs, the
  diagonal being compare's own same-seed runs): the rate compare fails this crop at;
  a 95 % interval by the bootstrap over both sides' renders (pairs share renders, so the
  binomial interval of N x N would be too narrow);
* **the bias**: Mitsuba - port summed over all seeds, per object and per 16 x 16 tile, as
  Z = sum(a - b) / sqrt(sum(var_a + var_b)) and as a share of the port's radiance.

Three statistics: Stouffer's Z of the raw ratio z = (a - b) / sd (``raw``), of the normal
scores of each sub-sample's Welch t (``welch``), and the pooled difference
(``difference``, ``metrics.pooled_difference``: what compare pools).

    python benchmarks/pooled_pairs.py [SCENE] [--rect x0,y0,x1,y1] [--spp 16] [--seeds 58]
        [--first-seed 3000] [--blob-max-error E] [--keep DIR] [--redo-mitsuba]

``--redo-mitsuba`` renders the Mitsuba side of kept seeds again and keeps their port renders:
after a change to the plugins, the same port renders judge the new Mitsuba side, and the
two Mitsuba versions pair seed by seed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "plugins"), str(ROOT / "reference")]


def render_seeds(args) -> list[dict]:
    from codermind_harness import compare, sides
    opt = compare.Options(spp=args.spp, rect=args.rect, blob_max_error=args.blob_max_error,
                          out_dir=args.keep, progress=False)
    case = compare.prepare(args.scene, opt)
    xml, defines = compare.mitsuba_xml(case, opt, "pairs", args.keep)
    labels, names = sides.object_labels(xml, case.grid, defines)
    out = []
    for k in range(args.seeds):
        seed = args.first_seed + k
        path = args.keep / f"seed{seed}.npz"
        kept = dict(np.load(path)) if path.is_file() else None
        if kept is None or args.redo_mitsuba:
            t0 = time.perf_counter()
            again = "Mitsuba again, " if kept is not None else ""
            e = sides.port_exposure(case.scene, seed, "clean")
            if kept is None:
                port = sides.render_port(case.scene, case.grid, case.spp, seed, e, "clean", True,
                                         None, False)
                kept = dict(pl=port.linear, pv=port.variance, pdof=port.dof, labels=labels,
                            names=np.array(names))
            mits = sides.render_mitsuba(xml, case.grid, case.spp, seed, e, defines,
                                        progress=False, iid=True)
            kept.update(ml=mits.linear, mv=mits.variance, mdof=mits.dof)
            tmp = path.with_suffix(".tmp.npz")
            np.savez(tmp, **kept)
            tmp.replace(path)
            print(f"seed {seed}: {again}{time.perf_counter() - t0:.1f} s", file=sys.stderr,
                  flush=True)
        out.append(dict(np.load(path)))
    return out


def object_groups(runs: list[dict]) -> tuple[np.ndarray, list[str]]:
    """(H, W) object label per sub-sample, the sky (label < 0) as one more group, as compare's
    pooled_tests; and the groups' names."""
    names = [str(x) for x in runs[0]["names"]] + ["sky"]
    lab = np.asarray(runs[0]["labels"])
    return np.where(lab < 0, len(names) - 1, lab), names


def verdicts(runs: list[dict], mode: str):
    from codermind_harness import metrics
    lab, _ = object_groups(runs)
    tiles = metrics.tile_labels(lab.shape)

    def fails(a, va, b, vb, da, db) -> bool:
        if mode == "difference":        # what compare pools
            return not (metrics.pooled_difference(a, va, b, vb, tiles, "tiles", da, db).passed
                        and metrics.pooled_difference(a, va, b, vb, lab, "objects", da,
                                                      db).passed)
        welch = mode == "welch"
        z = metrics.signed_z(a, va, b, vb, dof_a=da if welch else None,
                             dof_b=db if welch else None)
        return not (metrics.stouffer(z, tiles, "tiles").passed
                    and metrics.stouffer(z, lab, "objects").passed)

    side = lambda r, s: (r[s + "l"], r[s + "v"], int(r[s + "dof"]))      # noqa: E731
    n = len(runs)
    nulls = {}
    for s, name in (("p", "port vs port"), ("m", "Mitsuba vs Mitsuba")):
        f = [fails(*_pair(side(runs[i], s), side(runs[j], s))) for i in range(n)
             for j in range(i + 1, n)]
        nulls[name] = (int(np.sum(f)), len(f))
    cross = np.array([[fails(*_pair(side(runs[i], "m"), side(runs[j], "p"))) for j in range(n)]
                      for i in range(n)])
    return nulls, cross


def _pair(a, b):
    return a[0], a[1], b[0], b[1], a[2], b[2]


def bias(runs: list[dict]) -> list[str]:
    from codermind_harness import metrics
    d = sum(r["ml"] - r["pl"] for r in runs)
    v = sum(r["mv"] + r["pv"] for r in runs)
    p = sum(r["pl"] for r in runs)
    lab, names = object_groups(runs)
    lines = []
    for kind, groups in (("object", lab), ("tile", metrics.tile_labels(lab.shape))):
        for g in np.unique(groups):
            m = groups == g
            z = [d[..., c][m].sum() / np.sqrt(v[..., c][m].sum()) for c in range(3)]
            share = [100 * d[..., c][m].sum() / p[..., c][m].sum() for c in range(3)]
            label = names[g] if kind == "object" else str(g)
            lines.append(f"| {kind} {label} | {int(m.sum())} | "
                         + " / ".join(f"{x:+.2f}" for x in z) + " | "
                         + " / ".join(f"{x:+.3f}" for x in share) + " |")
    return lines


def coupling(runs: list[dict], shift: int = 0) -> tuple[float, float]:
    """Mean correlation of Mitsuba's and the port's standardized residuals (each sub-sample's
    deviation from its mean over the seeds) at seeds ``shift`` apart, and its t over the
    seeds: same-seed pairs (shift 0) are compare's own runs, and should be no different."""
    m = np.array([r["ml"] for r in runs])
    p = np.array([r["pl"] for r in runs])
    rm, rp = m - m.mean(0), p - p.mean(0)
    rm, rp = rm / (rm.std(0) + 1e-12), rp / (rp.std(0) + 1e-12)
    per = np.array([np.mean(rm[i] * rp[(i + shift) % len(runs)]) for i in range(len(runs))])
    return float(per.mean()), float(per.mean() / per.std() * np.sqrt(len(runs)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "scenes" / "page4.txt"))
    ap.add_argument("--rect", default="300,250,332,274")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--seeds", type=int, default=58)
    ap.add_argument("--first-seed", type=int, default=3000)
    ap.add_argument("--blob-max-error", type=float)
    ap.add_argument("--keep", type=Path, default=Path("pooled_pairs"))
    ap.add_argument("--boot", type=int, default=2000)
    ap.add_argument("--redo-mitsuba", action="store_true",
                    help="render the Mitsuba side of kept seeds again (keep their port renders)")
    args = ap.parse_args()
    args.rect = tuple(int(x) for x in args.rect.split(","))
    args.keep.mkdir(parents=True, exist_ok=True)
    from codermind.variants import set_variant
    set_variant(None)
    import codermind  # noqa: F401
    runs = render_seeds(args)
    n = len(runs)
    rng = np.random.default_rng(1)
    print(f"{args.scene} rect {args.rect}, {args.spp} spp, seeds {args.first_seed}.."
          f"{args.first_seed + n - 1}, blob max_error {args.blob_max_error or 'of the converter'}"
          f"; pooled tests (tiles, objects) at compare's levels\n")
    print("| statistic | port vs port | Mitsuba vs Mitsuba | Mitsuba vs port (N x N) | 95 % "
          "(bootstrap) | same seed |")
    print("| --- | --- | --- | --- | --- | --- |")
    for mode in ("raw", "welch", "difference"):
        nulls, cross = verdicts(runs, mode)
        boot = [cross[np.ix_(rng.integers(0, n, n), rng.integers(0, n, n))].mean()
                for _ in range(args.boot)]
        cells = [f"{k} / {m} = {100 * k / m:.2f} %" for k, m in nulls.values()]
        print(f"| {mode} | {cells[0]} | {cells[1]} | "
              f"{100 * cross.mean():.2f} % | {100 * np.percentile(boot, 2.5):.2f}-"
              f"{100 * np.percentile(boot, 97.5):.2f} % | {int(cross.diagonal().sum())} / {n} |")
    for shift in (0, 1):
        c, t = coupling(runs, shift)
        print(f"\nresidual correlation of the sides at seeds {shift} apart: {c:+.4f} (t {t:+.2f})",
              end="")
    print()
    print(f"\nMitsuba - port over all {n} seeds ({n * args.spp} spp together):\n")
    print("| group | sub-samples | Z (R / G / B) | % of the port (R / G / B) |")
    print("| --- | --- | --- | --- |")
    print("\n".join(bias(runs)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
