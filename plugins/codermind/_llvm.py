"""Pick a libLLVM that Dr.Jit's LLVM backend can use, before drjit is imported.

Dr.Jit 1.5 loads, in order: symbols already in the process, ``DRJIT_LIBLLVM_PATH``,
a ``libLLVM.so`` on the library path, then the highest ``libLLVM*.so.*`` in the
system library folder. LLVM 15 and 16 load but abort the process on the first
kernel ("Cannot select fminimum"); LLVM >= 17 works. When the user has not chosen
(no ``DRJIT_LIBLLVM_PATH``) and a working LLVM is installed, point Dr.Jit at it.
"""

from __future__ import annotations

import glob
import os
import re
import sys

MIN_MAJOR = 17
FIX = ("install a newer LLVM (Debian 12: `apt-get install libllvm19`) or set "
       "DRJIT_LIBLLVM_PATH to a libLLVM >= 17; `--variant scalar_rgb` runs without LLVM")


def _major(path: str) -> int | None:
    m = re.search(r"libLLVM[-.]?(?:so\.)?(\d+)", os.path.basename(path))
    return int(m.group(1)) if m else None


def candidates() -> list[str]:
    """System libLLVM files, best (highest major version) first."""
    found = glob.glob("/usr/lib/*-linux-gnu/libLLVM*.so*") + glob.glob("/usr/lib/libLLVM*.so*")
    found = [f for f in found if _major(f) is not None]
    return sorted(set(found), key=lambda f: (_major(f), f), reverse=True)


def prefer_working_llvm() -> None:
    if "drjit" in sys.modules or os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    good = [f for f in candidates() if _major(f) >= MIN_MAJOR]
    if good:
        os.environ["DRJIT_LIBLLVM_PATH"] = good[0]


def llvm_problem() -> str | None:
    """None if Dr.Jit's LLVM backend is usable, else a one-line explanation with the fix."""
    import drjit as dr
    if not dr.has_backend(dr.JitBackend.LLVM):
        return f"Dr.Jit's LLVM backend could not load libLLVM: {FIX}"
    major = dr.detail.llvm_version()[0]
    if major < MIN_MAJOR:
        return (f"Dr.Jit loaded LLVM {major}, which aborts on the first kernel "
                f"(\"Cannot select fminimum\"): {FIX}")
    return None
