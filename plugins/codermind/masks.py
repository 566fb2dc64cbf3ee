"""Mask helpers shared by the plugins, for the Dr.Jit masks of vectorized variants and the
Python bools of scalar ones."""

from __future__ import annotations


def logical_not(mask):
    """Logical not of a Dr.Jit mask or a Python bool (``~True`` is -2, not False)."""
    return mask ^ True
