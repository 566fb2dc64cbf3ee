"""Argument types shared by every sub-command, so that an option means and checks the same
everywhere. Each type raises ``argparse.ArgumentTypeError``; :mod:`codermind_cli.main`
prints it on one line (``codermind COMMAND: error: argument --spp: must be >= 1, got 0``),
exit status 2.

Seeds are in [0, 2^32): the range both Mitsuba (``mi.render(seed=...)``, a 32-bit unsigned
seed) and numpy's ``np.random.seed`` accept, so one seed can be given to either side of
``codermind compare`` (tests/cli/test_cli_args.py checks the bounds against both).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

SEED_LIMIT = 2 ** 32


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def positive_int(text: str) -> int:
    """An integer >= 1 (samples, depths, strides, workers)."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    """A finite number > 0 (exposures, error targets, tessellation errors)."""
    value = _number(text)
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def fraction(text: str) -> float:
    """A number in [0, 1] (pass rates, FLIP thresholds)."""
    value = _number(text)
    if not 0 <= value <= 1:
        raise argparse.ArgumentTypeError(f"must be in [0, 1], got {text}")
    return value


def level(text: str) -> float:
    """A test's significance level, in (0, 1)."""
    value = _number(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be in (0, 1), got {text}")
    return value


def seed(text: str) -> int:
    """A random seed in [0, 2^32) (see the module doc)."""
    value = _integer(text)
    if not 0 <= value < SEED_LIMIT:
        raise argparse.ArgumentTypeError(f"must be in [0, 2^32), got {value}")
    return value


def rect(text: str) -> tuple[int, int, int, int]:
    """``x0,y0,x1,y1``: four integers (checked against the image where it is known)."""
    try:
        values = tuple(int(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 4:
        raise argparse.ArgumentTypeError(f"expected x0,y0,x1,y1 (integers), got {text!r}")
    return values


def define(text: str) -> tuple[str, str]:
    """``-D NAME=VALUE``: an XML ``<default>`` override."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not name.strip().replace("_", "").isalnum():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name.strip(), value.strip()


def exposure(text: str) -> float | str:
    """``probes``, ``render`` or a fixed exposure E > 0 (``codermind render``)."""
    if text in ("probes", "render"):
        return text
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"'probes', 'render' or a number, got {text!r}") from None
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def tutorial_scene(path: str | Path):
    """A tutorial scene file parsed by the port's parser; its errors as CodermindError
    (``file:line: message``)."""
    import codermind_ref
    from codermind.errors import CodermindError
    path = Path(path)
    if not path.is_file():
        raise CodermindError(f"{path}: no such scene file")
    try:
        return codermind_ref.parse_scene(path)
    except codermind_ref.SceneError as e:
        raise CodermindError(str(e)) from None
