"""Mitsuba 3 plugins for the Codermind ray-tracing tutorial.

``import codermind`` registers every plugin of the package (see
:mod:`codermind.registry`) for the current Mitsuba variant, and again after each
``mi.set_variant(...)``. If no variant is set yet, registration happens at the
first ``mi.set_variant``.
"""

from __future__ import annotations

from ._llvm import prefer_working_llvm

prefer_working_llvm()  # must run before drjit is first imported

from . import registry  # noqa: E402

__version__ = "0.1.0"

registry.install()
