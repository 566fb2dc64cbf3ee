"""What the tests share: the repository's paths, the hypothesis profiles, the command
line run as a subprocess, and the helpers of this folder (closed forms, reference
implementations, scene generators, statistics). Imported as ``support`` (pytest puts
``tests/`` on the path; see pyproject.toml)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from hypothesis import HealthCheck, Phase, settings

# Hypothesis (tests/plugins/test_properties.py, tests/port/test_parser_fuzz.py): CI runs the "ci" profile,
# small and derandomized (the same examples every run, no deadline flakiness); a long run is
# HYPOTHESIS_PROFILE=long (random examples; see docs/harness.md for the command, docs/results/properties.md for its result).
PROFILE = os.environ.get("HYPOTHESIS_PROFILE", "ci")
_COMMON = dict(deadline=None, database=None, print_blob=True,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                      HealthCheck.function_scoped_fixture])
settings.register_profile("ci", max_examples=20, derandomize=True, **_COMMON)
settings.register_profile("long", max_examples=100_000, derandomize=False, **_COMMON)
settings.load_profile(PROFILE)


def examples(ci: int, long: int, shrink: bool = True):
    """Per-test example counts (``@examples(ci=..., long=...)``) for tests whose examples
    are expensive (a Mitsuba plugin is built and its kernels compiled per example).
    ``shrink=False``: a failing example is reported as drawn, not shrunk (for examples
    that take seconds each, such as the random scenes of tests/support/random_scenes.py)."""
    if shrink:
        return settings(max_examples=long if PROFILE == "long" else ci)
    return settings(max_examples=long if PROFILE == "long" else ci,
                    phases=[Phase.explicit, Phase.reuse, Phase.generate])


ROOT = Path(__file__).resolve().parents[2]
#: The original tutorial files (scenes, cube-map faces, page 1's expected image) are not in
#: the repository; they are looked for in ../shared/tutorial, or where CODERMIND_TUTORIAL says.
TUTORIAL = Path(os.environ.get("CODERMIND_TUTORIAL") or ROOT.parent / "shared" / "tutorial")


def run_cli(*args: str, cwd: str | os.PathLike | None = None, timeout: float = 300,
            env: dict | None = None) -> subprocess.CompletedProcess:
    """Run ``python -m codermind_cli ARGS`` (the ``codermind`` command) and capture its output."""
    return subprocess.run([sys.executable, "-m", "codermind_cli", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})


def set_variant(variant: str):
    """Mitsuba in ``variant`` with the plugins registered; returns the mitsuba module."""
    import mitsuba as mi
    mi.set_variant(variant)
    import codermind  # noqa: F401  (registers the plugins)
    return mi
