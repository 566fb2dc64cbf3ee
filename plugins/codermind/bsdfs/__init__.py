"""Mitsuba bsdf plugins of this package, one module per XML type."""
