"""Speed against accuracy: ``codermind chart``'s error-against-time sweeps and Pareto fronts.

    python benchmarks/chart.py [--quick] [--only page4 ...] [--no-cost] [--figures DIR]
                               [--write-results [PATH]]

Runs ``codermind_harness.chart`` (the same as ``codermind chart``): every bundled scene's
methods (Mitsuba's spp and blob max_error sweeps, the port, the model chooser's pick, a
maximal model, scalar_rgb) against a converged reference, and the cost scaling; writes the
figures and ``chart.json`` to ``--figures`` (default docs/figures/chart) and, with
``--write-results``, one row per scene and method to docs/results/chart.md. A timing: run
it on a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import _results

PAGE = "chart.md"
FIGURES = _results.ROOT / "docs" / "figures" / "chart"


def table(data: dict) -> str:
    """The rows of chart.json: best error, its time, the front, time to rel MSE 1e-2."""
    rows = []
    for res in data["scenes"]:
        for method, s in res["summary"]["methods"].items():
            t2 = s.get("seconds_to_rel_mse_0.01")
            front = ("yes" if s["on_front"] else "no") if s.get("panel") == "main" else "-"
            rows.append([res["scene"], f"`{method}`", f"{s['best_rel_mse']:.3g}",
                         f"{s['best_flip']:.3g}", f"{s['seconds_at_best']:.2f}", front,
                         "-" if t2 is None else f"{t2:.2f}",
                         "-" if s.get("fit_a") is None else
                         f"{s['fit_a']:.3g} / spp + {s['fit_b']:.2g}"])
    slopes = data.get("cost_slopes") or {}
    text = _results.table(["scene", "method", "best rel MSE", "FLIP", "time s", "on front",
                           "time to rel MSE 1e-2, s", "fit rel MSE = a / spp + b"], rows)
    if slopes:
        text += ("\nCost scaling, fitted log-log slopes: "
                 + ", ".join(f"{k} {v:.2f}" for k, v in slopes.items()
                             if isinstance(v, (int, float))) + ".\n")
    return text + f"\n{data.get('load_text', '')}\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer points (a check, not a result)")
    ap.add_argument("--only", nargs="+", help="scene names (page1 ... page4, garden)")
    ap.add_argument("--no-cost", action="store_true", help="skip the cost-scaling sweeps")
    ap.add_argument("--figures", type=Path, default=FIGURES)
    _results.add_argument(ap, PAGE)
    args = ap.parse_args(argv)
    from codermind_harness import chart
    t0 = time.time()
    _, text = chart.run(args.figures, only=args.only, quick=args.quick, cost=not args.no_cost)
    print(text)
    if args.write_results:
        data = json.loads((args.figures / "chart.json").read_text())
        _results.write(args.write_results, table(data), seconds=time.time() - t0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
