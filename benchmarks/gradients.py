"""The gradient table: every differentiable parameter of every plugin under every option
set of tests/support/gradient_cases.py, AD against finite differences, with more samples than CI
(tests/plugins/test_gradient_table.py runs the default-options rows), and the reverse-mode check.

    python benchmarks/gradients.py [--spp 64] [--seeds 4] [--only TEXT] [--write-results [PATH]]

Prints one line per row; ``--write-results`` writes the table to docs/results/gradients.md.
``--only`` keeps the rows whose id contains TEXT.
"""

from __future__ import annotations

import argparse
import sys
import time

import _results

cases = _results.tests_module("gradient_cases")


def run(mi, rows, spp: int, seeds: int) -> list[tuple]:
    """(row, result or None, error, reverse mode's error) for every row; skipped rows are
    measured too, to show what happens."""
    out = []
    for row in rows:
        start = time.time()
        result, error, reverse = None, "", ""
        try:
            result = cases.measure(mi, row, spp=spp, seeds=seeds, backward=True)
        except Exception as e:           # e.g. prb's "not attached to the AD graph"
            reverse = _first_line(e)
            try:
                result = cases.measure(mi, row, spp=spp, seeds=seeds)
            except Exception as e2:
                error = _first_line(e2)
        print(f"{time.time() - start:6.1f} s  {row.id}: "
              f"{result.describe() if result else error} -> "
              f"{verdict(row, result, error, reverse)}"
              f"{'; reverse mode: ' + reverse if reverse else ''}", flush=True)
        out.append((row, result, error, reverse))
    return out


def _first_line(e: BaseException) -> str:
    cause = e.__cause__ or e
    text = str(cause).strip().splitlines()
    return (text[0] if text else type(cause).__name__)[:160]


def verdict(row, m, error: str, reverse: str) -> str:
    """pass / pass (0) / FAIL (...) / skipped / ERROR; reverse mode may raise only where
    the derivative is 0 (prb refuses a render with nothing attached to the AD graph)."""
    if row.skip:
        return "skipped" + (f" (AD: {error})" if error else "")
    if m is None:
        return f"ERROR: {error}"
    if reverse and not row.zero:
        return "FAIL (reverse mode raises)"
    return m.verdict()


def _g(x: float) -> str:
    return f"{x:.5g}"


def table(measured, setups_run, spp: int, seeds: int) -> str:
    """The results page; ``setups_run`` the setups the rows came from (with those that
    have none)."""
    import drjit as dr
    import mitsuba as mi
    verdicts = [(r, verdict(r, m, e, b)) for r, m, e, b in measured]
    passed = sum(1 for _, v in verdicts if v.startswith("pass"))
    failed = [(r, v) for r, v in verdicts if not v.startswith(("pass", "skipped"))]
    skipped = [r for r, _, _, _ in measured if r.skip]
    params = {(r.owner, r.param) for r, _, _, _ in measured}
    setups = {r.setup.id for r, _, _, _ in measured}
    idle = {s.plugin for s in setups_run} - {o for o, _ in params}
    lines = [
        f"Mitsuba {mi.__version__}, Dr.Jit {dr.__version__}, {spp} spp x {seeds} seeds of "
        f"{cases.SIZE}x{cases.SIZE} pixels per render.",
        "",
        f"**{len(measured)} rows ({len(params)} differentiable parameters of "
        f"{len({o for o, _ in params})} plugins, in {len(setups)} option sets): {passed} "
        f"pass, {len(failed)} fail, {len(skipped)} skipped.**",
        "",
    ]
    if failed:
        lines.append("Failing:")
        lines.append("")
        for (r, m, _, _), (_, v) in zip(measured, verdicts):
            if v.startswith(("pass", "skipped")):
                continue
            extra = "" if m is None else (
                f": AD {_g(m.ad)}, FD {_g(m.fd)}, tolerance {m.tolerance:.3g}; the largest "
                f"paired pixel difference is {m.worst:.3g}, {m.worst / m.spread:.0f} times "
                f"their sd")
            lines.append(f"- `{r.id}`: {v}{extra}.")
        lines.append("")
    if skipped:
        lines.append("Skipped, where the derivative cannot be right (the plugin's docstring "
                     "says so); they are measured all the same:")
        lines.append("")
        reasons: dict = {}
        for r in skipped:
            reasons.setdefault(r.skip, []).append(r.id)
        for reason, ids in reasons.items():
            lines.append(f"- {', '.join(f'`{i}`' for i in ids)}: {reason}.")
        lines.append("")
    if idle:
        lines.append(f"{', '.join(f'`{n}`' for n in sorted(idle))} expose no differentiable "
                     "parameter; their option sets are rows of the plugins they show.")
        lines.append("")
    lines += [
        "AD is forward mode; *backward* is reverse mode at the first seed minus forward "
        "mode at that seed, against its float32 accumulation bound. *tolerance* = noise + "
        "step + rounding.",
        "",
        "| plugin | options | parameter | integrator | h | AD | FD (h) | FD (2h) | "
        "tolerance | noise / step / rounding | backward | verdict |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for (row, m, error, reverse), (_, v) in zip(measured, verdicts):
        if m is None:
            lines.append(f"| {row.setup.plugin} | {row.setup.options} | `{row.name}` | "
                         f"{row.integrator} | | | | | | | | {v} |")
            continue
        back = f"raises: {reverse}" if reverse else \
            f"{m.backward - m.forward_first:.2g} (bound {m.backward_bound:.2g})"
        lines.append(
            f"| {row.setup.plugin} | {row.setup.options} | `{row.name}` | {row.integrator} "
            f"| {m.h:.3g} | {_g(m.ad)} | {_g(m.fd)} | {_g(m.fd2)} | {m.tolerance:.3g} | "
            f"{m.noise_term:.2g} / {m.step_term:.2g} / {m.rounding_term:.2g} | {back} | "
            f"{v} |")
    lines += ["", "## Frames", "",
              "What each option set's scene avoids, where that makes a derivative well posed:",
              ""]
    seen = set()
    for row, _, _, _ in measured:
        s = row.setup
        if s.frame and s.id not in seen:
            seen.add(s.id)
            lines.append(f"- `{s.id}`: {s.frame}.")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--only", default="", help="keep the rows whose id contains this")
    _results.add_argument(ap, "gradients.md")
    args = ap.parse_args(argv)
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401  (registers the plugins)
    mi.set_log_level(mi.LogLevel.Error)
    start = time.time()
    setups = [s for s in cases.SETUPS if any(args.only in row.id
                                              for row in cases.scene_rows(mi, s)[0])
              or args.only in s.id]
    rows = [row for row in cases.rows(mi, setups) if args.only in row.id]
    measured = run(mi, rows, args.spp, args.seeds)
    if args.write_results:
        _results.write(args.write_results, table(measured, setups, args.spp, args.seeds),
                       seconds=time.time() - start)
    return 0


if __name__ == "__main__":
    sys.exit(main())
