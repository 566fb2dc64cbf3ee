"""Imports run one way: command line (codermind_cli) -> harness (codermind_harness) -> plugins
(codermind); the port (codermind_ref) imports nothing of ours. Checked statically over every
module's source (imports inside functions and ``importlib.import_module("...")`` included),
as tests/test_port_isolation.py does for the port, and once at run time."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"codermind": ROOT / "plugins" / "codermind",
            "codermind_cli": ROOT / "plugins" / "codermind_cli",
            "codermind_harness": ROOT / "reference" / "codermind_harness",
            "codermind_ref": ROOT / "reference" / "codermind_ref"}
#: What each layer must not import (the port: anything but the standard library and numpy).
FORBIDDEN = {"codermind": {"codermind_cli", "codermind_harness", "codermind_ref"},
             "codermind_harness": {"codermind_cli"},
             "codermind_cli": set()}
PORT_ALLOWED = set(sys.stdlib_module_names) | {"numpy", "__future__", "codermind_ref"}


def _module_name(package: str, path: Path) -> str:
    parts = [package, *path.relative_to(PACKAGES[package]).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_names(package: str, path: Path) -> list[str]:
    """Absolute names of every module ``path`` imports (relative imports resolved)."""
    module = _module_name(package, path)
    is_package = path.name == "__init__.py"
    names = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".")
                base = base[:len(base) - node.level + (1 if is_package else 0)]
                assert base, f"{path}: relative import above its top-level package"
                names.append(".".join(base + ([node.module] if node.module else [])))
            else:
                names.append(node.module)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(
                node.func, "id", "")) in ("import_module", "__import__"):
            arg = node.args[0] if node.args else None
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                names.append(arg.value)
            elif package == "codermind_ref":
                raise AssertionError(f"{path}: dynamic import in the port")
    return names


def modules(package: str) -> list[Path]:
    return sorted(PACKAGES[package].rglob("*.py"))


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_no_layer_imports_a_layer_above_it(package):
    found = modules(package)
    assert len(found) >= 5
    bad = [f"{path.relative_to(ROOT)} imports {name}"
           for path in found for name in imported_names(package, path)
           if name.split(".")[0] in FORBIDDEN[package]]
    assert bad == []


def test_port_imports_only_numpy_and_the_standard_library():
    found = modules("codermind_ref")
    assert len(found) > 10
    bad = [f"{path.relative_to(ROOT)} imports {name}"
           for path in found for name in imported_names("codermind_ref", path)
           if name.split(".")[0] not in PORT_ALLOWED]
    assert bad == []


def test_the_checker_sees_imports_inside_functions_and_relative_ones(tmp_path):
    """The check itself can fail: an upward import hidden in a function is reported."""
    fake = PACKAGES["codermind"] / "tutorial" / "convert.py"
    names = imported_names("codermind", fake)
    assert "codermind.tutorial.model" in names and "codermind.variants" in names
    probe = tmp_path / "probe.py"
    probe.write_text("def f():\n    import codermind_harness.sides\n"
                     "    importlib.import_module('codermind_cli.main')\n")
    PACKAGES["_probe"] = tmp_path
    try:
        assert imported_names("_probe", probe) == ["codermind_harness.sides", "codermind_cli.main"]
    finally:
        del PACKAGES["_probe"]


SCRIPT = r"""
import importlib, json, pkgutil, sys
import mitsuba as mi
mi.set_variant("scalar_rgb")
import codermind
for info in pkgutil.walk_packages(codermind.__path__, "codermind."):
    if not info.name.endswith("__main__"):
        importlib.import_module(info.name)
print(json.dumps(sorted(sys.modules)))
"""


def test_importing_every_plugin_module_loads_no_layer_above():
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                         timeout=300, check=True)
    loaded = json.loads(out.stdout)
    assert "codermind.blobmesh.mesh" in loaded and "codermind.tutorial.convert" in loaded
    assert [m for m in loaded if m.split(".")[0] in FORBIDDEN["codermind"]] == []
