"""Mitsuba shape plugins of this package, one module per XML type."""
