"""Choosing and activating a Mitsuba variant, with a clear message when it cannot run: the one
variant setter of the command line, the converter and the harness."""

from __future__ import annotations

from types import ModuleType

import mitsuba as mi

from ._llvm import llvm_problem
from .errors import CodermindError

DEFAULT_VARIANT = "llvm_ad_rgb"


def set_variant(name: str | None = None) -> ModuleType:
    """Activate ``name`` (default ``llvm_ad_rgb``) or raise CodermindError saying why not;
    returns the ``mitsuba`` module. This package's plugins are registered for the variant
    (:mod:`codermind.registry` re-registers on every switch); setting the variant that is
    already active changes nothing.

    There is no silent fallback: a user who wants the scalar variant asks for it.
    """
    name = name or DEFAULT_VARIANT
    available = mi.variants()
    if name not in available:
        raise CodermindError(f"--variant: unknown variant {name!r}; installed: {', '.join(available)}")
    if name.startswith("llvm_"):
        problem = llvm_problem()
        if problem:
            raise CodermindError(problem)
    elif name.startswith("cuda_"):
        import drjit as dr
        if not dr.has_backend(dr.JitBackend.CUDA):
            raise CodermindError(f"--variant {name}: no CUDA device or driver found; "
                                 f"use the default {DEFAULT_VARIANT}")
    mi.set_variant(name)
    return mi
