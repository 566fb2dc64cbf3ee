"""Integrator plugins (one module per XML type)."""
