"""Shared fixtures. Tests that need Mitsuba request a variant fixture; the port's tests
import nothing from Mitsuba (its isolation is checked in a subprocess)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
TUTORIAL = SHARED / "tutorial"


def run_cli(*args: str, cwd: str | os.PathLike | None = None, timeout: float = 300,
            env: dict | None = None) -> subprocess.CompletedProcess:
    """Run ``python -m codermind ARGS`` and capture its output."""
    return subprocess.run([sys.executable, "-m", "codermind", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})


def _set(variant: str):
    import mitsuba as mi
    mi.set_variant(variant)
    import codermind  # noqa: F401  (registers the plugins)
    return mi


@pytest.fixture
def llvm():
    """Mitsuba in llvm_ad_rgb with the plugins registered; yields the mitsuba module."""
    return _set("llvm_ad_rgb")


@pytest.fixture
def scalar():
    """Mitsuba in scalar_rgb with the plugins registered; yields the mitsuba module."""
    return _set("scalar_rgb")


@pytest.fixture
def tutorial_dir() -> Path:
    """The original tutorial files (../shared/tutorial); tests needing them skip without."""
    if not TUTORIAL.is_dir():
        pytest.skip("../shared/tutorial not present")
    return TUTORIAL
