"""Stability sweeps: drive each method (plugins and port) into the regime where it fails,
measure where, and check what must never happen there (NaN or Inf in an output, a crash, a
silent wrong answer where an error was due). Writes OUTDIR/stability.md and stability.json
(the table of thresholds) and one NAME.png per sweep, prints the table, and exits with
status 1 if any never-happen check failed."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "stability"
HELP = "stability sweeps: measured failure thresholds, figures, never-happen checks"


def _sweep_names() -> list[str]:
    from codermind_harness.stability import SWEEPS
    return list(SWEEPS)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", metavar="OUTDIR", default="stability",
                   help="folder for stability.md, stability.json and the PNGs "
                        "(default: ./stability)")
    p.add_argument("--quick", action="store_true",
                   help="fewer sweep points and samples (about 10x faster, coarser thresholds)")
    p.add_argument("--only", nargs="+", metavar="NAME", choices=_sweep_names(),
                   help="run only these sweeps: " + ", ".join(_sweep_names()))
    p.add_argument("--cluster", metavar="ADDRESS",
                   help="run on a Dask cluster: tcp://HOST:PORT (a `dask scheduler`) or local:N "
                        "(N worker processes here); default: this machine; one sweep point per "
                        "task")


def run(args: argparse.Namespace) -> int:
    from codermind.errors import CodermindError
    from codermind_harness import stability
    from codermind_harness.cluster import open_runner

    outdir = Path(args.output)
    command = "codermind stability -o " + str(args.output) + (" --quick" if args.quick else "") + \
        (" --only " + " ".join(args.only) if args.only else "")
    with open_runner(args.cluster) as runner:
        results = stability.run(args.only, quick=args.quick,
                                progress=lambda line: print(line, file=sys.stderr, flush=True),
                                runner=runner)
    try:
        stability.write_report(results, outdir, command)
    except OSError as e:
        raise CodermindError(f"{e.filename or outdir}: cannot write: {e.strerror or e}") from None
    print(stability.markdown_table(results), end="")
    failed = [r.name for r in results if not r.passed]
    print(f"wrote {outdir / 'stability.md'}, {outdir / 'stability.json'} and "
          f"{len(results)} PNG(s) to {outdir}")
    if failed:
        print(f"codermind: never-happen checks failed in: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0
