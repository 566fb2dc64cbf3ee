"""The package as a user installs it (issue 15): the wheel is built from a copy of the
sources, installed with its ``harness`` extra into a fresh virtual environment (a plain
``venv``, no system or shared site-packages), and ``codermind render`` and
``codermind chart --quick`` run from a folder outside the repository, finding the bundled
scenes in the installed package. Needs network access to PyPI for the dependencies
(pip's cache makes reruns quick) unless ``CODERMIND_WHEELHOUSE`` names a folder of wheels
to install from offline (``pip install --no-index --find-links``)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from support import ROOT

pytestmark = pytest.mark.install

#: What the wheel is built from (a copy: an in-tree build would write build/ and egg-info).
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "plugins", "reference", "scenes")


def _run(cmd, cwd, env=None, timeout=900) -> subprocess.CompletedProcess:
    proc = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)
    assert proc.returncode == 0, f"{cmd}:\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
    return proc


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("install")
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name,
                            ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        elif (ROOT / name).is_file():
            shutil.copy2(ROOT / name, src / name)
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", tmp / "dist", src],
         cwd=tmp)
    wheel, = (tmp / "dist").glob("codermind_mitsuba-*.whl")
    venv = tmp / "venv"
    _run([sys.executable, "-m", "venv", venv], cwd=tmp)
    python = venv / "bin" / "python"
    offline = os.environ.get("CODERMIND_WHEELHOUSE")
    source = ["--no-index", "--find-links", offline] if offline else []
    _run([python, "-m", "pip", "install", "-q", *source, f"{wheel}[harness]"], cwd=tmp)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "CODERMIND_SCENES", "VIRTUAL_ENV", "PYTHONHOME")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    outside = tmp / "elsewhere"
    outside.mkdir()
    return venv, outside, env


def test_the_venv_is_fresh_and_uses_the_installed_package(installed):
    venv, outside, env = installed
    out = _run([venv / "bin" / "python", "-c",
                "import sys, site, codermind, codermind_harness, mitsuba; "
                "print(sys.prefix, sys.base_prefix, codermind.__file__, mitsuba.__file__, "
                "site.ENABLE_USER_SITE)"], cwd=outside, env=env).stdout.split()
    prefix, base, plugin, mitsuba = map(Path, out[:4])
    assert prefix == venv and base != venv
    assert (venv / "pyvenv.cfg").read_text().count("include-system-site-packages = false")
    for path in (plugin, mitsuba):
        assert venv in path.parents and ROOT not in path.parents


def test_render_a_bundled_scene_from_outside_the_repository(installed):
    venv, outside, env = installed
    _run([venv / "bin" / "codermind", "render", "page1", "-o", outside / "page1"],
         cwd=outside, env=env)
    assert (outside / "page1.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (outside / "page1.exr").read_bytes()[:4] == b"\x76\x2f\x31\x01"   # EXR magic


def test_chart_quick_from_outside_the_repository(installed):
    venv, outside, env = installed
    _run([venv / "bin" / "codermind", "chart", "--quick", "--only", "page1", "--no-cost",
          "-o", outside / "chart"], cwd=outside, env=env)
    doc = json.loads((outside / "chart" / "chart.json").read_text())
    assert [s["scene"] for s in doc["scenes"]] == ["page1"]
    assert doc["scenes"][0]["xml"] == "scenes/page1.xml"
    assert (outside / "chart" / "error_vs_time_page1.png").is_file()


def test_missing_harness_extra_is_one_line(monkeypatch, capsys):
    """Without the harness extra (matplotlib absent) the CLI says what to install."""
    from codermind_cli import main as cli

    def needs_matplotlib(args):
        raise ModuleNotFoundError("No module named 'matplotlib'", name="matplotlib")

    monkeypatch.setattr(cli, "build_parser", lambda: _parser(needs_matplotlib))
    assert cli.main(["x"]) == cli.EXIT_USAGE
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'codermind-mitsuba[harness]'" in err


def _parser(run):
    import argparse
    p = argparse.ArgumentParser()
    p.add_argument("x")
    p.set_defaults(run=run)
    return p
