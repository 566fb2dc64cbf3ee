"""The long run of the property and fuzz tests (tests/plugins/test_properties.py,
tests/port/test_parser_fuzz.py) with Hypothesis's ``long`` profile (tests/conftest.py: random
examples, per-test counts given by ``examples(ci=..., long=...)``).

    python benchmarks/properties.py [--seed 1] [--files tests/plugins/test_properties.py ...]
                                    [--profile long] [--write-results [PATH]]

Runs pytest once per test file (serially, ``-n 0``) with ``--hypothesis-show-statistics``
and ``--hypothesis-seed``, and tabulates per test: the outcome, the examples run (passing /
failing / invalid, from Hypothesis's statistics) and the time. ``--write-results`` writes
the table to docs/results/properties.md. Takes about half an hour on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time

import _results

PAGE = "properties.md"
FILES = ["tests/plugins/test_properties.py", "tests/port/test_parser_fuzz.py"]


def parse(output: str) -> list[list]:
    """One row per test from pytest's -rA outcome lines and Hypothesis's statistics."""
    outcome = {m[1]: m[0] for m in re.findall(r"^(PASSED|FAILED|ERROR|SKIPPED) (\S+)", output,
                                                re.M)}
    stats = {}
    heads = list(re.finditer(r"^(\S+::\S+):$", output, re.M))
    for head, nxt in zip(heads, heads[1:] + [None]):
        block = output[head.end():nxt.start() if nxt else len(output)]
        phase = re.search(r"during generate phase \(([\d.]+) seconds\)", block)
        counts = re.search(r"(\d+) passing(?: examples)?, (\d+) failing(?: examples)?,"
                           r"(?: and)? (\d+) invalid", block)
        if counts:
            stats[head[1]] = (float(phase[1]) if phase else None, int(counts[1]),
                              int(counts[2]), int(counts[3]))
    rows = []
    for test in sorted(set(outcome) | set(stats)):
        seconds, passing, failing, invalid = stats.get(test, (None, "-", "-", "-"))
        rows.append([f"`{test}`", outcome.get(test, "?"), passing, failing, invalid,
                     "-" if seconds is None else f"{seconds:.0f}"])
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--profile", default="long", help="the Hypothesis profile (ci: a check)")
    ap.add_argument("--files", nargs="+", default=FILES)
    ap.add_argument("-k", dest="keyword", help="pytest -k expression")
    _results.add_argument(ap, PAGE)
    args = ap.parse_args(argv)
    env = {**os.environ, "HYPOTHESIS_PROFILE": args.profile}
    rows, t0, status = [], time.time(), 0
    for path in args.files:
        cmd = [sys.executable, "-m", "pytest", "-q", "-n", "0", "-rA", path,
               "--hypothesis-show-statistics", f"--hypothesis-seed={args.seed}"]
        if args.keyword:
            cmd += ["-k", args.keyword]
        print(" ".join(cmd), flush=True)
        done = subprocess.run(cmd, cwd=_results.ROOT, env=env, capture_output=True, text=True)
        print(done.stdout[-3000:], done.stderr[-2000:], flush=True)
        status = status or done.returncode
        rows += parse(done.stdout)
    table = _results.table(["test", "outcome", "passing examples", "failing", "invalid",
                            "generate s"], rows)
    print(table)
    if args.write_results:
        _results.write(args.write_results, table, seconds=time.time() - t0)
    return status


if __name__ == "__main__":
    sys.exit(main())
