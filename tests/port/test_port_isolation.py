"""The port stays independent of the Mitsuba side: numpy and the standard library only."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import codermind_ref

PACKAGE = Path(codermind_ref.__file__).parent
FORBIDDEN = ("mitsuba", "drjit", "codermind", "PIL", "scipy", "skimage")

SCRIPT = r"""
import importlib, json, pkgutil, sys, tempfile
import codermind_ref
for info in pkgutil.walk_packages(codermind_ref.__path__, "codermind_ref."):
    importlib.import_module(info.name)
scene = codermind_ref.parse_scene(sys.argv[1])
result = codermind_ref.render(scene, "clean", seed=1, rect=(150, 180, 170, 200), workers=1)
with tempfile.TemporaryDirectory() as folder:
    codermind_ref.write_outputs(result, folder + "/out")
print(json.dumps(sorted(sys.modules)))
"""


def test_port_imports_nothing_from_the_mitsuba_side(tutorial_dir):
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(tutorial_dir / "page4" / "scene.txt")],
                         capture_output=True, text=True, timeout=120, check=True)
    loaded = json.loads(out.stdout)
    assert "codermind_ref.blob" in loaded and "numpy" in loaded
    bad = [m for m in loaded if m.split(".")[0] in FORBIDDEN]
    assert bad == []


def test_port_source_imports_only_numpy_and_stdlib():
    allowed = set(sys.stdlib_module_names) | {"numpy", "__future__"}
    modules = sorted(PACKAGE.glob("*.py"))
    assert len(modules) > 10
    for path in modules:
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [] if node.level else [node.module]
            elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module":
                raise AssertionError(f"{path.name}: dynamic import")
            else:
                continue
            for name in names:
                assert name.split(".")[0] in allowed, f"{path.name} imports {name}"
