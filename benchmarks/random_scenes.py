"""The long run of the random-scene properties (tests/plugins/test_random_scenes.py,
tests/plugins/test_random_scene_parameters.py) on many scenes drawn by tests/support/random_scenes.py.

Every scene goes to a worker process (a crash ends the worker, which is counted and
restarted) for

- ``compare`` in llvm_ad_rgb: ``path`` (no Russian roulette) and ``tutorialpath`` clean
  (``exact_hits`` false), K = 8 renders a side of 16 spp, and the per-scene two-sample test
  at alpha = 1e-3 (tests/support/zstat.py ``t_test``) unless the scene has a blob without a mesh
  (which ``path`` does not see); the renders also count for crashes, refusals and
  non-finite pixels;
- every ``--extra-every``-th scene, one more llvm_ad_rgb integrator in turn: ``prb``,
  ``direct``, ``tutorialpath`` strict (where the scene is in the tutorial's style; else
  ``prb`` or ``direct``), 2 spp (each costs a kernel compilation, ~0.4 s, the bulk of a
  scene's time);
- every ``--scalar-every``-th scene, every integrator of scalar_rgb at 4 x 4 pixels, 2 spp;
- ``str(scene)``, and one misspelled parameter of one of our plugins (must be refused in one
  line naming the plugin and the misspelling).

    python benchmarks/random_scenes.py --scenes 2000 --write-results [PATH] [--seed S] [--jobs J]

writes the counts to docs/results/random-scenes.md and every scene's record as JSON
(``--json``, default /tmp/random-scenes.json), rewritten as it goes. The scenes are hypothesis examples (generation only, no shrinking) from seed S.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import random
import re
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import _results

ROOT = _results.ROOT
rs = _results.tests_module("random_scenes")

K, K_SPP, ALPHA = 8, 16, 1e-3
EXTRA = ("prb", "direct", "tutorialpath_strict")


class _Enough(Exception):
    pass


def draw_specs(n: int, seed: int) -> list[dict]:
    """``n`` distinct scenes, hypothesis examples of ``rs.scenes()`` from ``seed`` (its first
    examples are the simplest ones whatever the seed, so one run draws them all)."""
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as use_seed
    specs, seen = [], set()

    @use_seed(seed)
    @settings(max_examples=4 * n, phases=[Phase.generate], database=None, deadline=None,
              suppress_health_check=list(HealthCheck), report_multiple_bugs=False)
    @given(rs.scenes())
    def collect(spec):
        key = json.dumps(spec, sort_keys=True)
        if key not in seen:
            seen.add(key)
            specs.append(spec)
        if len(specs) >= n:
            raise _Enough

    try:
        collect()
    except _Enough:
        pass
    if len(specs) < n:
        raise RuntimeError(f"drew only {len(specs)} distinct scenes of {n}")
    return specs


def extra_integrator(index: int, spec: dict) -> str:
    name = EXTRA[index % 3]
    if name == "tutorialpath_strict" and not rs.strict_allowed(spec):
        name = EXTRA[(index // 3) % 2]
    return name


def run_scene(worker: rs.Worker, index: int, spec: dict, extra_every: int,
              scalar_every: int) -> dict:
    """Every job of one scene; the record of what each answered."""
    record = {"index": index, "types": sorted(rs.types(spec)), "spec": spec,
              "analytic_blob": rs.has_analytic_blob(spec), "renders": {}}
    t0 = time.perf_counter()
    llvm = {"variant": "llvm_ad_rgb", "spec": spec}
    out = worker.run({**llvm, "kind": "compare", "k": K, "spp": K_SPP, "significance": ALPHA})
    if "exit" in out:            # which side crashed: each alone
        for name in ("path", "tutorialpath"):
            record["renders"][f"llvm/{name}"] = worker.run(
                {**llvm, "kind": "render", "integrator": name, "spp": 2})
    else:
        record["renders"]["llvm/path"] = out["path"]
        record["renders"]["llvm/tutorialpath"] = out["tutorialpath"]
        if not record["analytic_blob"] and out["passed"] is not None:
            record["test"] = {k: out[k] for k in ("passed", "min_p", "alpha")}
    if index % extra_every == 0:
        extra = extra_integrator(index // extra_every, spec)
        record["renders"][f"llvm/{extra}"] = worker.run(
            {**llvm, "kind": "render", "integrator": extra, "spp": 2})
    if index % scalar_every == 0:
        for name in rs.SCALAR_INTEGRATORS:
            if name == "tutorialpath_strict" and not rs.strict_allowed(spec):
                continue
            record["renders"][f"scalar/{name}"] = worker.run(
                {"variant": "scalar_rgb", "spec": spec, "kind": "render", "integrator": name,
                 "spp": 2, "size": 4})
    record["print"] = worker.run({**llvm, "kind": "print"})
    typos = rs.misspellings(spec)
    if typos and record["print"].get("loaded"):
        path, key, typo = random.Random(index).choice(typos)
        record["typo"] = {"path": path, "key": key, "typo": typo,
                          "plugin": dict(rs.nodes(spec["scene"]))[path]["type"],
                          **worker.run({**llvm, "kind": "typo", "path": path, "key": key,
                                        "typo": typo})}
    record["seconds"] = time.perf_counter() - t0
    return record


def refusal_kind(message: str) -> str:
    """A refusal's message without Mitsuba's prefix, numbers and node names: its kind."""
    message = re.split(r"(?:Value|Runtime)Error: ", message)[-1]
    message = re.sub(r'At dictionary node "[^"]*": ', "", message)
    message = re.sub(r"\[[-+0-9.e, ]+\]", "[...]", message)
    message = re.sub(r"-?\d+(\.\d+)?(e[-+]?\d+)?", "#", message)
    return message[:160]


def binomial_tail(k: int, n: int, p: float) -> float:
    """P(X >= k) for X ~ Binomial(n, p)."""
    from scipy.stats import binom
    return float(binom.sf(k - 1, n, p))


def summarize(records: list[dict]) -> dict:
    renders = collections.Counter()
    crashes, not_refusals, nonfinite = collections.Counter(), [], collections.Counter()
    refusals = collections.Counter()
    for r in records:
        for name, out in r["renders"].items():
            renders[name] += 1
            if "exit" in out:
                crashes[name] += 1
            elif "error" in out:
                if rs.is_refusal(out, r["spec"]):
                    refusals[(refusal_kind(out["message"]))] += 1
                else:
                    not_refusals.append((r["index"], name, out["error"], out["message"],
                                         out.get("cause", "")))
            elif not out["finite"]:
                nonfinite[name] += 1
    tests = [r["test"] for r in records if "test" in r]
    failed = [r for r in records if "test" in r and not r["test"]["passed"]]
    prints = [r for r in records if r["print"].get("loaded") and not r["print"].get("ok")]
    typos = [r for r in records if "typo" in r]
    typo_bad = [r for r in records if "typo" in r and not r["typo"].get("names_it")]
    return {"renders": renders, "crashes": crashes, "not_refusals": not_refusals,
            "nonfinite": nonfinite, "refusals": refusals, "tests": len(tests),
            "failed": failed, "prints": prints,
            "loaded": sum(bool(r["print"].get("loaded")) for r in records),
            "typos": len(typos), "typo_bad": typo_bad,
            "types": collections.Counter(t for r in records for t in r["types"])}


def page(s: dict, records: list[dict]) -> str:
    n = len(records)
    tests, failed = s["tests"], len(s["failed"])
    lines = [
        "## Counts",
        "",
        "| property | checked | failing |",
        "| --- | --- | --- |",
        f"| scenes | {n} | |",
        f"| renders (all variants and integrators) | {sum(s['renders'].values())} | |",
        f"| crashes (worker died: segfault, abort) | {sum(s['renders'].values())} | "
        f"{sum(s['crashes'].values())} |",
        f"| errors that are no one-line refusal naming plugin and parameter | "
        f"{sum(s['renders'].values())} | {len(s['not_refusals'])} |",
        f"| films with NaN or inf | {sum(s['renders'].values())} | "
        f"{sum(s['nonfinite'].values())} |",
        f"| clean `tutorialpath` against `path`: scenes compared / disagreeing at alpha "
        f"{ALPHA:g} per scene | {tests} | {failed} (expected at most {ALPHA * tests:.1f}; "
        f"P(>= {failed}) = {binomial_tail(failed, tests, ALPHA):.2g} if every scene agrees) |",
        f"| `str(scene)` of the scenes that load | {s['loaded']} | {len(s['prints'])} |",
        f"| a misspelled parameter of one of our plugins refused in one line naming it | "
        f"{s['typos']} | {len(s['typo_bad'])} |",
        "",
        "Renders per variant and integrator (crashed / non-finite):",
        "",
        "| variant/integrator | renders | crashed | non-finite |",
        "| --- | --- | --- | --- |",
    ]
    for name in sorted(s["renders"]):
        lines.append(f"| {name} | {s['renders'][name]} | {s['crashes'][name]} | "
                     f"{s['nonfinite'][name]} |")
    lines += ["", "## Refusals by kind", "",
              "Scenes a plugin refused, by message (numbers replaced by `#`); every one is a "
              "single line naming the plugin and a quoted parameter.", "",
              "| refusals | message |", "| --- | --- |"]
    for kind, count in s["refusals"].most_common():
        lines.append(f"| {count} | {kind.replace('|', '/')} |")
    if s["not_refusals"] or s["failed"] or s["prints"] or s["typo_bad"]:
        lines += ["", "## Failures", ""]
        for index, name, error, message, inner in s["not_refusals"][:20]:
            lines.append(f"- scene {index}, {name}: {error}: {message[:200]}"
                         + (f"; cause: {inner[:200]}" if inner else ""))
        for r in s["failed"]:
            t = r["test"]
            lines.append(f"- scene {r['index']}: z-test min p {t['min_p']:.3g} below "
                         f"{t['alpha']:.3g} ({', '.join(r['types'])})")
        for r in s["prints"][:20]:
            lines.append(f"- scene {r['index']}: str(scene): {r['print']['message'][:200]}")
        for r in s["typo_bad"][:20]:
            t = r["typo"]
            lines.append(f"- scene {r['index']}: {t['plugin']} '{t['typo']}' for '{t['key']}'"
                         f": {'refused: ' + t['message'][:160] if t['refused'] else 'accepted'}")
    lines += ["", "## Coverage", "", "Scenes containing each plugin type:", "",
              "| type | scenes |", "| --- | --- |"]
    for t, count in sorted(s["types"].items()):
        lines.append(f"| `{t}` | {count} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=2, help="worker processes")
    parser.add_argument("--extra-every", type=int, default=2)
    parser.add_argument("--scalar-every", type=int, default=5)
    parser.add_argument("--json", default="/tmp/random-scenes.json")
    _results.add_argument(parser, "random-scenes.md")
    parser.add_argument("--from-json", action="store_true",
                        help="only write the page from the records in --json, of a run that "
                             "took --wall seconds with --command")
    parser.add_argument("--wall", type=float, default=0.0)
    parser.add_argument("--command", default="")
    args = parser.parse_args(argv)
    command = _results.command()
    if args.from_json:
        records = json.loads(Path(args.json).read_text())
        return write(records, args.command or command, args.wall, args.write_results)
    specs = draw_specs(args.scenes, args.seed)
    records: list[dict] = [None] * len(specs)
    with tempfile.TemporaryDirectory() as tmp:
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
        assets = rs.write_assets(mi, Path(tmp) / "assets")
        # the workers' Dr.Jit kernel cache (thousands of one-off kernels) in tmp
        env = {**os.environ, "HOME": str(Path(tmp) / "home")}
        local = threading.local()
        workers, lock = [], threading.Lock()
        done = [0]
        t0 = time.perf_counter()

        def job(i: int) -> None:
            if not hasattr(local, "worker"):
                local.worker = rs.Worker(assets, env=env)
                with lock:
                    workers.append(local.worker)
            records[i] = run_scene(local.worker, i, specs[i], args.extra_every,
                                   args.scalar_every)
            with lock:
                done[0] += 1
                if done[0] % 20 == 0 or done[0] == len(specs):
                    finished = [r for r in records if r is not None]
                    Path(args.json).write_text(json.dumps(finished))
                    elapsed = time.perf_counter() - t0
                    print(f"{done[0]}/{len(specs)} scenes, {elapsed / 60:.1f} min", flush=True)

        with ThreadPoolExecutor(args.jobs) as pool:
            list(pool.map(job, range(len(specs))))
        for w in workers:
            w.close()
        wall = time.perf_counter() - t0
    return write(records, command, wall, args.write_results)


def write(records: list[dict], command: str, wall: float, to: str | None) -> int:
    text = page(summarize(records), records)
    print(text)
    if to:
        _results.write(to, text, cmd=command, seconds=wall)
    return 0


if __name__ == "__main__":
    sys.exit(main())
