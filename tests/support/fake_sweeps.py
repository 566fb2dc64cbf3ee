"""Two stability sweeps made of ``math.sqrt`` points, importable on any worker: one in two
rounds (the second needs the first's results) and one whose point raises. The runner tests
check that a pool or a cluster gives what the local runner gives."""

from __future__ import annotations

import math
import sys
import types


def install(monkeypatch) -> None:
    """Replace ``stability.SWEEPS`` by the two sweeps for one test."""
    from codermind_harness import stability

    def two_rounds(quick):
        def second(first):
            def finish(roots):
                r = stability.SweepResult("two_rounds", "two rounds", "x", "y", "-", roots[0])
                r.table = [{"first": first, "second": roots}]
                return r
            return stability.Plan([sum(first)], math.sqrt, finish)
        return stability.Plan([1.0, 4.0, 9.0], math.sqrt, second)

    def crashes(quick):
        return stability.Plan([4.0, -1.0], math.sqrt, lambda roots: None)

    module = types.ModuleType("codermind_harness._fake_plans")
    module.two_rounds, module.crashes = two_rounds, crashes
    monkeypatch.setitem(sys.modules, "codermind_harness._fake_plans", module)
    monkeypatch.setattr(stability, "SWEEPS", {
        "two_rounds": ("_fake_plans", "two_rounds", "two rounds of points"),
        "crashes": ("_fake_plans", "crashes", "a point raises")})
