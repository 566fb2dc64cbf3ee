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


#: Mitsuba's registration function of each category
_REGISTER = {"textures": "register_texture", "bsdfs": "register_bsdf",
             "shapes": "register_shape", "sensors": "register_sensor",
             "emitters": "register_emitter", "integrators": "register_integrator"}


def supported(variant: str) -> bool:
    """Whether the plugins support ``variant``: the RGB variants (``scalar_rgb``,
    ``llvm_ad_rgb``, ``cuda_ad_rgb``). The tutorial computes in RGB; its colours, cube-map
    faces and tone pipeline have no spectral or polarized meaning here."""
    return variant.endswith("_rgb") and "polarized" not in variant


def _refusal(name: str, variant: str):
    def refuse(props: mi.Properties):
        rgb = ", ".join(v for v in mi.variants() if supported(v))
        raise ValueError(f"{name}: the variant {variant!r} is not supported; use an RGB "
                         f"variant ({rgb})")
    return refuse


def register_all() -> None:
    """(Re-)register every plugin for the current variant (no-op without one). In a variant
    the plugins do not support, each plugin's name is registered with a factory that refuses
    it in one line, so a scene naming one fails at loading, before any rendering."""
    variant = mi.variant()
    if variant is None:
        return
    if not supported(variant):
        for name in plugin_modules():
            category, plugin = name.split(".")[-2:]
            getattr(mi, _REGISTER[category])(plugin, _refusal(plugin, variant))
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
