"""Choosing and activating a Mitsuba variant, with a clear message when it cannot run."""

from __future__ import annotations

import mitsuba as mi

from ._llvm import llvm_problem
from .errors import CodermindError

DEFAULT_VARIANT = "llvm_ad_rgb"


def set_variant(name: str | None = None) -> str:
    """Activate ``name`` (default ``llvm_ad_rgb``) or raise CodermindError saying why not.

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
    return name
