"""Imports run one way: command line (codermind_cli) -> harness (codermind_harness) -> plugins
(codermind); the port (codermind_ref) imports nothing of ours; inside each package no module
imports another in a circle; the harness imports inside functions only what is heavy to
import. Checked statically over every module's source (imports inside functions and
``importlib.import_module("...")`` included), as tests/port/test_port_isolation.py does for the
port, and once at run time."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
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


def _targets(node: ast.AST, module: str, is_package: bool, known: set[str]) -> list[str]:
    """The modules of ``known`` that an import node loads by name: ``from . import x`` the
    submodule x (not the package that holds it), ``from .m import name`` the module m."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name in known]
    if isinstance(node, ast.ImportFrom):
        if node.level:
            base = module.split(".")
            base = ".".join(base[:len(base) - node.level + (1 if is_package else 0)]
                            + ([node.module] if node.module else []))
        else:
            base = node.module
        subs = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in known]
        rest = len(subs) < len(node.names)
        return subs + ([base] if rest and base in known else [])
    if isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(
            node.func, "id", "")) in ("import_module", "__import__"):
        arg = node.args[0] if node.args else None
        if isinstance(arg, ast.Constant) and arg.value in known:
            return [arg.value]
    return []


def import_graph(package: str) -> dict[str, set[str]]:
    """module -> the modules of the same package it imports (at the top or in a function)."""
    paths = {_module_name(package, p): p for p in modules(package)}
    graph = {}
    for name, path in paths.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        graph[name] = {t for node in ast.walk(tree)
                       for t in _targets(node, name, path.name == "__init__.py", set(paths))
                       if t != name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """A circle of imports (its modules, the first repeated at the end), or None."""
    state: dict[str, int] = {}              # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


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


@pytest.mark.parametrize("package", sorted(PACKAGES))
def test_no_module_imports_another_of_its_package_in_a_circle(package):
    graph = import_graph(package)
    assert len(graph) >= 5
    cycle = find_cycle(graph)
    assert cycle is None, f"{package}: import cycle " + " -> ".join(cycle)


def test_the_cycle_checker_finds_a_circle_through_a_function_local_import(tmp_path):
    """The check itself can fail: a -> b at the top, b -> a inside a function."""
    (tmp_path / "a.py").write_text("from . import b\n")
    (tmp_path / "b.py").write_text("def f():\n    from .a import g\n")
    (tmp_path / "c.py").write_text("from .b import f\n")
    PACKAGES["_probe"] = tmp_path
    try:
        graph = import_graph("_probe")
    finally:
        del PACKAGES["_probe"]
    assert graph == {"_probe.a": {"_probe.b"}, "_probe.b": {"_probe.a"}, "_probe.c": {"_probe.b"}}
    assert find_cycle(graph) == ["_probe.a", "_probe.b", "_probe.a"]
    assert find_cycle({"x": {"y"}, "y": set()}) is None


#: What the harness may import inside a function: modules that take seconds to import
#: (codermind starts Mitsuba and its JIT) or are optional (distributed: --cluster only).
HEAVY = {"codermind", "mitsuba", "drjit", "distributed", "matplotlib", "scipy",
         "flip_evaluator"}


def function_local_imports(path: Path) -> list[str]:
    """Top-level names of the modules imported inside a function of ``path``."""
    names = []
    for fn in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for node in ast.walk(fn):
                if isinstance(node, ast.Import):
                    names += [a.name.split(".")[0] for a in node.names]
                elif isinstance(node, ast.ImportFrom):
                    names.append("." * node.level + (node.module or "").split(".")[0])
    return names


def test_the_harness_imports_inside_functions_only_heavy_modules():
    found = modules("codermind_harness")
    assert len(found) > 10
    local = [(p.name, n) for p in found for n in function_local_imports(p)]
    assert len(local) > 10                  # Mitsuba's are there: the check sees them
    assert [f"{p} imports {n} in a function" for p, n in local if n not in HEAVY] == []


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
