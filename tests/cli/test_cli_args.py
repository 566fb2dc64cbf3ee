"""The argument types every sub-command shares (codermind_cli.args): one check per kind of
option, the same in every command, and usage errors on one line."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from codermind_cli import args
from codermind_cli.main import build_parser
from support import run_cli


def test_seed_range_is_what_mitsuba_and_numpy_accept(scalar):
    """External evidence: the bounds of ``args.seed`` are those of ``mi.render(seed=)`` (a
    32-bit unsigned seed) and of ``np.random.seed``."""
    mi = scalar
    scene = mi.load_dict({"type": "scene", "integrator": {"type": "path"}, "sensor": {
        "type": "perspective", "film": {"type": "hdrfilm", "width": 2, "height": 2}}})
    last = args.SEED_LIMIT - 1
    assert args.seed(str(last)) == last
    mi.render(scene, spp=1, seed=last)
    np.random.seed(last)
    for bad in (args.SEED_LIMIT, -1):
        with pytest.raises(argparse.ArgumentTypeError, match=r"\[0, 2\^32\)"):
            args.seed(str(bad))
        with pytest.raises(TypeError):
            mi.render(scene, spp=1, seed=bad)
        with pytest.raises(ValueError):
            np.random.seed(bad)


@pytest.mark.parametrize("kind, text, message", [
    (args.positive_int, "0", "must be >= 1, got 0"),
    (args.positive_int, "2.5", "expected an integer, got '2.5'"),
    (args.seed, "x", "expected an integer, got 'x'"),
    (args.positive_float, "0", "must be a finite number > 0"),
    (args.positive_float, "inf", "must be a finite number > 0"),
    (args.positive_float, "nan", "must be a finite number > 0"),
    (args.positive_float, "lots", "expected a number, got 'lots'"),
    (args.fraction, "1.5", "must be in [0, 1]"),
    (args.rect, "1,2,3", "expected x0,y0,x1,y1"),
    (args.define, "spp", "expected NAME=VALUE"),
    (args.exposure, "-1", "must be a finite number > 0"),
])
def test_bad_values_are_refused_with_the_reason(kind, text, message):
    with pytest.raises(argparse.ArgumentTypeError) as e:
        kind(text)
    assert message in str(e.value)


def test_good_values_parse():
    assert args.positive_int("3") == 3 and args.positive_float("0.5") == 0.5
    assert args.fraction("0") == 0.0 and args.rect("1,2,3,4") == (1, 2, 3, 4)
    assert args.define(" max_depth = 5 ") == ("max_depth", "5")
    assert args.exposure("probes") == "probes" and args.exposure("2") == 2.0


def _types(parser: argparse.ArgumentParser, option: str) -> set:
    found = set()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found |= _types(sub, option)
        elif option in action.option_strings:
            found.add(action.type)
    return found


from codermind_cli.limits import worker_count  # noqa: E402  (--workers: capped per core)


@pytest.mark.parametrize("option, kind", [
    ("--seed", args.seed), ("--spp", args.positive_int), ("--workers", worker_count),
    ("--blob-max-error", args.positive_float), ("--define", args.define),
])
def test_every_command_checks_an_option_the_same_way(option, kind):
    assert _types(build_parser(), option) == {kind}


def test_seed_out_of_range_is_the_same_one_line_error_in_every_command(tmp_path):
    for command in ("render", "compare", "reference"):
        out = run_cli(command, tmp_path / "none", "--seed", str(2 ** 32))
        assert out.returncode == 2
        assert out.stderr == (f"codermind {command}: error: argument --seed: must be in "
                              f"[0, 2^32), got {2 ** 32} (see codermind {command} --help)\n")


def test_python_dash_m_codermind_points_to_the_command_line():
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-m", "codermind", "--help"], capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 2 and "python -m codermind_cli" in out.stderr
