"""How much FLIP varies between renders of noise alone, to calibrate compare's FLIP rule.

For each scene, grid and sample count: the port with seeds 0..P (P + 1 renders) gives the
noise floor F0_s = FLIP(port_s, port_s+1) for P seed pairs; the Mitsuba side with seeds
0..M-1 gives F_s = FLIP(port_s, mitsuba_s), which compare judges against F0_s. All at one
exposure (the port's auto exposure for seed 0), as compare does. Prints, per row, the mean
and relative sd of F0 and the ratios F_s / F0_s, and writes the rows as JSON (``--out``);
``--write-results`` writes the table to docs/results/compare.md (section ``flip-floor``).

    python benchmarks/flip_floor.py [--out FILE] [--pairs P] [--mitsuba M] [--only K ...]
                                    [--write-results [PATH]]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import _results

ROOT = _results.ROOT

CASES = [   # (scene, rect x0,y0,x1,y1 (y up), spp)
    ("scenes/page4.txt", (272, 220, 352, 280), 16),
    ("scenes/page4.txt", (272, 220, 352, 280), 64),
    ("TUTORIAL/page4/scene.txt", (272, 220, 352, 280), 16),
    ("TUTORIAL/page4/scene.txt", (272, 220, 352, 280), 64),
    ("scenes/page4.txt", (392, 130, 440, 170), 64),
]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/flip_floor.json")
    ap.add_argument("--pairs", type=int, default=6)
    ap.add_argument("--mitsuba", type=int, default=3)
    ap.add_argument("--only", type=int, nargs="+", metavar="K",
                    help="only these rows (0-based) of the case list")
    _results.add_argument(ap, "compare.md")
    args = ap.parse_args(argv)
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401
    from codermind_harness import metrics, sides
    from codermind_harness.compare import strip_free_rows
    tutorial = _results.TUTORIAL
    rows = []
    tmp = Path(args.out).resolve().parent / "flip_floor_xml"
    tmp.mkdir(parents=True, exist_ok=True)
    for k, (name, rect, spp) in enumerate(CASES):
        if args.only is not None and k not in args.only:
            continue
        path = ROOT / name if name.startswith("scenes/") else \
            Path(name.replace("TUTORIAL", str(tutorial)))
        if not path.is_file():
            print(f"skip {path} (not found)")
            continue
        t0 = time.perf_counter()
        scene = sides.parse(path)
        grid = sides.Grid.of(scene.width, scene.height, scene.page, rect, 1)
        rws = strip_free_rows(grid, scene.page)
        e = sides.port_exposure(scene, 0)
        ports = [sides.render_port(scene, grid, spp, s, e, "clean", True, 2, False)
                 for s in range(args.pairs + 1)]
        xml = sides.convert_xml(path, scene, tmp, name=f"{path.parent.name}-{path.stem}.xml")
        mits = [sides.render_mitsuba(xml, grid, spp, s, e, {"spp": str(spp)}, variance=False,
                                     progress=False) for s in range(args.mitsuba)]
        f0 = [metrics.flip(ports[s].encoded[rws], ports[s + 1].encoded[rws])[0]
              for s in range(args.pairs)]
        f = [metrics.flip(ports[s].encoded[rws], mits[s].encoded[rws])[0]
             for s in range(args.mitsuba)]
        row = {"scene": name, "rect": rect, "spp": spp, "pixels": grid.pixels, "exposure": e,
               "floor": f0, "mitsuba": f, "floor_mean": float(np.mean(f0)),
               "floor_rel_sd": float(np.std(f0, ddof=1) / np.mean(f0)),
               "ratio": [a / b for a, b in zip(f, f0)],
               "seconds": time.perf_counter() - t0}
        rows.append(row)
        print(f"{name} {rect} {spp} spp: floor {row['floor_mean']:.5f} rel sd "
              f"{row['floor_rel_sd']:.4f}; F/F0 {', '.join(f'{r:.4f}' for r in row['ratio'])} "
              f"({row['seconds']:.0f} s)", flush=True)
    Path(args.out).write_text(json.dumps(rows, indent=2) + "\n")
    if args.write_results:
        table = _results.table(
            ["scene", "crop (x0, y0, x1, y1; y up)", "pixels", "spp",
             f"floor F0 (mean of {args.pairs})", "rel sd of F0",
             f"F / F0, seeds 0-{args.mitsuba - 1}", "s"],
            [[f"`{r['scene'].replace('TUTORIAL/', 'tutorial/')}`", ",".join(map(str, r["rect"])),
              r["pixels"], r["spp"], f"{r['floor_mean']:.5f}", f"{r['floor_rel_sd']:.4f}",
              ", ".join(f"{x:.4f}" for x in r["ratio"]), f"{r['seconds']:.0f}"] for r in rows])
        _results.write(args.write_results, table, section="flip-floor")
    return 0


if __name__ == "__main__":
    sys.exit(main())
