"""Shared fixtures. Tests that need Mitsuba request a variant fixture; the port's tests
import nothing from Mitsuba (its isolation is checked in a subprocess). Shared helpers
live in tests/support."""

from __future__ import annotations

from pathlib import Path

import pytest

from support import TUTORIAL, set_variant


def pytest_report_header(config) -> str:
    if TUTORIAL.is_dir():
        return f"tutorial originals: {TUTORIAL}"
    return (f"tutorial originals: NOT FOUND at {TUTORIAL}; the tests against the original "
            "scenes and page 1's expected image skip (set CODERMIND_TUTORIAL)")


@pytest.fixture
def llvm():
    """Mitsuba in llvm_ad_rgb with the plugins registered; yields the mitsuba module."""
    return set_variant("llvm_ad_rgb")


@pytest.fixture
def scalar():
    """Mitsuba in scalar_rgb with the plugins registered; yields the mitsuba module."""
    return set_variant("scalar_rgb")


@pytest.fixture
def tutorial_dir() -> Path:
    """The original tutorial files (``TUTORIAL``); tests needing them skip without."""
    if not TUTORIAL.is_dir():
        pytest.skip(f"tutorial originals not found at {TUTORIAL} (set CODERMIND_TUTORIAL)")
    return TUTORIAL
