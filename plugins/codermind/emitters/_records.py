"""Zero-initialised sampling records for emitters, in every variant: ``dr.zeros`` cannot
build these records in scalar variants, and a default-constructed record is empty (not
zero) in JIT variants."""

from __future__ import annotations

import drjit as dr
import mitsuba as mi


def zero_direction_sample() -> mi.DirectionSample3f:
    return dr.zeros(mi.DirectionSample3f) if dr.is_jit_v(mi.Float) else mi.DirectionSample3f()


def zero_position_sample() -> mi.PositionSample3f:
    return dr.zeros(mi.PositionSample3f) if dr.is_jit_v(mi.Float) else mi.PositionSample3f()


def emitter_ptr(emitter: mi.Emitter):
    """The value of a record's ``emitter`` field (scalar variants have no EmitterPtr)."""
    return mi.EmitterPtr(emitter) if dr.is_jit_v(mi.Float) else emitter
