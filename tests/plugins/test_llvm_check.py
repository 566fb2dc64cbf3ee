"""The LLVM check: a clear one-line error instead of Dr.Jit's process abort."""

from __future__ import annotations

import glob

import pytest

from support import ROOT, run_cli

from codermind import _llvm


def test_prefers_a_working_llvm(monkeypatch):
    monkeypatch.setattr(_llvm, "candidates",
                        lambda: ["/usr/lib/x/libLLVM-19.so", "/usr/lib/x/libLLVM-15.so.1"])
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.delitem(__import__("sys").modules, "drjit", raising=False)
    _llvm.prefer_working_llvm()
    import os
    assert os.environ["DRJIT_LIBLLVM_PATH"] == "/usr/lib/x/libLLVM-19.so"


@pytest.mark.parametrize("name, major", [("libLLVM-15.so.1", 15), ("libLLVM.so.19.1", 19),
                                         ("libLLVM-14.0.6.so.1", 14), ("libLLVM-21.so", 21)])
def test_reads_the_major_version_from_the_file_name(name, major):
    assert _llvm._major("/usr/lib/x86_64-linux-gnu/" + name) == major


@pytest.mark.skipif(not glob.glob("/usr/lib/*-linux-gnu/libLLVM-15.so*"),
                    reason="no LLVM 15 on this machine")
def test_llvm15_gives_one_line_and_exit_2(tmp_path):
    llvm15 = glob.glob("/usr/lib/*-linux-gnu/libLLVM-15.so*")[0]
    out = run_cli("render", ROOT / "scenes" / "default.xml", "-o", tmp_path / "x",
                  env={"DRJIT_LIBLLVM_PATH": llvm15})
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "LLVM 15" in lines[0] and "libllvm19" in lines[0]
