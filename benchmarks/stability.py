"""Where each method breaks down: the stability sweeps of ``codermind stability``.

    python benchmarks/stability.py [--quick] [--figures DIR] [--write-results [PATH]]

Runs every sweep of ``codermind_harness.stability`` (the same as ``codermind stability``),
writes its figures, ``stability.md`` and ``stability.json`` to ``--figures`` (default
docs/figures) and, with ``--write-results``, the table of thresholds and never-happen checks
to docs/results/stability.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import _results

PAGE = "stability.md"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer points per sweep")
    ap.add_argument("--figures", type=Path, default=_results.ROOT / "docs" / "figures",
                    help="folder for the figures, stability.md and stability.json")
    _results.add_argument(ap, PAGE)
    args = ap.parse_args(argv)
    from codermind_harness import stability
    t0 = time.time()
    results = stability.run(quick=args.quick, progress=lambda line: print(line, flush=True))
    stability.write_report(results, args.figures, _results.command())
    failed = [r.name for r in results if not r.passed]
    if args.write_results:
        figures = Path(args.figures).resolve()
        link = "../figures/" if figures == (_results.ROOT / "docs" / "figures") else None
        checks = sum(len(r.checks) for r in results)
        body = (f"{len(results)} sweeps, {checks} never-happen checks, "
                f"{sum(not c.passed for r in results for c in r.checks)} failing.\n\n"
                + stability.markdown_table(results)
                + ("" if link is None else
                   "\nFigures, one per sweep: "
                   + ", ".join(f"[`{r.name}`]({link}{r.name}.png)" for r in results) + ".\n"))
        _results.write(args.write_results, body, seconds=time.time() - t0)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
