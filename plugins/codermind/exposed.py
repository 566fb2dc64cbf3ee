"""Scene parameters of the plugins for ``mi.traverse``, shared by their ``traverse`` and
``parameters_changed`` methods.

The plugins keep most numbers as Python floats (their kernels test some of them in
Python, e.g. ``if self.aperture == 0``). ``mi.traverse`` needs a Mitsuba object it can
write into, so :func:`exposed` hands out one ``mi.Float`` per parameter (made once,
from the current value) and :func:`take_float` reads it back after an update, checks it
with the constructor's own check (:func:`codermind.params.check_float`, so the message
is the same), and stores it on the plugin: as a Python float, or as the ``mi.Float``
itself (gradients included) for one that the plugin uses only in Dr.Jit arithmetic. A
differentiable parameter that the plugin also tests in Python keeps the float as its
attribute and its kernels read the ``mi.Float`` through :func:`kernel_value`.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from .params import check_float


def scalar(value) -> float:
    """The (first) value of a Dr.Jit or Python number as a Python float."""
    if dr.is_array_v(value):
        if dr.width(value) != 1:
            raise ValueError(f"expected a single number, got {dr.width(value)} values")
        return float(dr.slice(dr.detach(value)))
    return float(value)


def exposed(plugin_object, name: str, make=None):
    """The object ``mi.traverse`` reads and writes for parameter ``name``: made once by
    ``make()`` (default: ``mi.Float`` of the attribute of that name) and kept."""
    store = plugin_object.__dict__.setdefault("_exposed", {})
    if name not in store:
        store[name] = make() if make is not None else \
            mi.Float(scalar(getattr(plugin_object, name)))
    return store[name]


def kernel_value(plugin_object, name: str):
    """Parameter ``name`` for a plugin's Dr.Jit kernels: the ``mi.Float`` that
    ``mi.traverse`` writes (gradients included) once it has exposed the parameter, else the
    attribute (a Python float, which stays the plugin's copy for tests in Python)."""
    return plugin_object.__dict__.get("_exposed", {}).get(name, getattr(plugin_object, name))


def take_float(plugin_object, plugin: str, name: str, lo: float | None = None,
               hi: float | None = None, open_lo: bool = False,
               keep_array: bool = False) -> float:
    """Check the exposed value of ``name`` with the scene reader's own check
    (:func:`codermind.params.check_float`: finite in float32, within [lo, hi], or
    (lo, hi] with ``open_lo``) and store it on the plugin; returns it as a float."""
    value = exposed(plugin_object, name)
    v = check_float(plugin, name, scalar(value), lo, hi, open_lo)
    setattr(plugin_object, name, value if keep_array else v)
    return v


def take_int(plugin_object, plugin: str, name: str, lo: int, hi: int) -> int:
    """An integer parameter exposed as a ``mi.Float`` (Mitsuba exposes no Python ints)."""
    v = scalar(exposed(plugin_object, name))
    if not (v == int(v) and lo <= v <= hi):
        raise ValueError(f"{plugin}: '{name}' must be an integer in [{lo}, {hi}], got {v:g}")
    setattr(plugin_object, name, int(v))
    return int(v)


def scalar_matrix(transform) -> mi.ScalarMatrix4f:
    """The scalar 4x4 matrix of a (JIT or scalar) transform."""
    m = transform.matrix
    if dr.is_jit_v(m):
        import numpy as np
        m = mi.ScalarMatrix4f(np.array(dr.detach(m), dtype=np.float64).reshape(4, 4))
    return mi.ScalarMatrix4f(m)
