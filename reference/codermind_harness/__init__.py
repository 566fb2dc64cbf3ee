"""Comparison of the two sides (the Mitsuba plugins and the standalone port) and the
stability sweeps that drive each method into the regime where it fails.

It sits between the command line (codermind_cli, which imports it) and the plugins
(codermind) and the port (codermind_ref), which it imports; see tests/test_layers.py.
Importing this package imports nothing heavy; each module imports what it needs:

- :mod:`codermind_harness.metrics`: the per-sub-sample two-sample z-test, FLIP with guarded
  inputs, relative MSE;
- :mod:`codermind_harness.sides`: rendering a tutorial scene on both sides at matched sample
  positions and counts (the converted XML through Mitsuba's ``path``; the port in clean mode);
- :mod:`codermind_harness.compare`: ``codermind compare`` (per-scene verdict, JSON, table,
  heat map);
- :mod:`codermind_harness.chart`: ``codermind chart`` (error vs time, Pareto fronts), with
  :mod:`~codermind_harness.chart_data` (configs, points, fits), ``chart_cost`` (cost
  scaling) and ``chart_report`` (files, table);
- :mod:`codermind_harness.progress`: the port's progress line (also ``codermind reference``'s);
- :mod:`codermind_harness.stability`: the sweep registry, result records, the report
  (markdown, JSON, one PNG per sweep) behind ``codermind stability``;
- ``sweep_*`` modules: one function per sweep (see ``stability.SWEEPS``);
- :mod:`codermind_harness.zone_exact`: the tutorial's blob field solved in 50-digit
  decimal arithmetic, the exact reference of the zone-method sweeps.
"""
