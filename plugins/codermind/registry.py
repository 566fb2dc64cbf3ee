"""Registration of every plugin of this package with Mitsuba, per variant.

Plugins live in the sub-packages ``bsdfs``, ``textures``, ``shapes``, ``sensors``,
``emitters`` and ``integrators``, one module per plugin named after its XML ``type``; each module
registers itself at import (modules starting with ``_`` are helpers). A plugin
class can only be defined while a variant is set and only builds in that variant,
so on every variant switch the modules are reloaded, which defines the classes
again for the new variant and registers them under the same names.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys

import mitsuba as mi

CATEGORIES = ("textures", "bsdfs", "shapes", "sensors", "emitters", "integrators")


def plugin_modules() -> list[str]:
    names = []
    for category in CATEGORIES:
        package = importlib.import_module(f"{__package__}.{category}")
        for info in pkgutil.iter_modules(package.__path__):
            if not info.name.startswith("_"):
                names.append(f"{package.__name__}.{info.name}")
    return names


def register_all() -> None:
    """(Re-)register every plugin for the current variant (no-op without one)."""
    if mi.variant() is None:
        return
    for category in CATEGORIES:
        # Shared helpers (``_noise`` etc.) may hold variant-specific types too.
        package = importlib.import_module(f"{__package__}.{category}")
        for info in pkgutil.iter_modules(package.__path__):
            if info.name.startswith("_"):
                _load(f"{package.__name__}.{info.name}")
    for name in plugin_modules():
        _load(name)


def _load(name: str) -> None:
    module = sys.modules.get(name)
    if module is None:
        importlib.import_module(name)
    else:
        # Helpers here use variant types; code without them (codermind.blobmesh) lives
        # outside these sub-packages, so its classes keep their identity across switches.
        importlib.reload(module)


def _on_variant_change(old: str | None, new: str | None) -> None:
    if new is not None:
        register_all()


_installed = False


def install() -> None:
    """Register now and after every ``mi.set_variant`` (idempotent)."""
    global _installed
    if not _installed:
        mi.detail.add_variant_callback(_on_variant_change)
        _installed = True
    register_all()
