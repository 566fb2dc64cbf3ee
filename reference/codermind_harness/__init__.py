"""Comparison of the two sides (the Mitsuba plugins and the standalone port) and the
stability sweeps that drive each method into the regime where it fails.

It sits between the command line (codermind_cli, which imports it) and the plugins
(codermind) and the port (codermind_ref), which it imports; see tests/project/test_layers.py.
Importing this package imports nothing heavy; each module imports what it needs, inside a
function only what is slow to import (``codermind``, which starts Mitsuba, ``mitsuba``,
``drjit``, ``scipy``, ``matplotlib``) or optional (``distributed``); no module imports another
in a circle (tests/project/test_layers.py). The work fans out through the runner the command line
hands down (:mod:`codermind_harness.runner`):

- :mod:`codermind_harness.metrics`: the per-sub-sample two-sample z-test, FLIP with guarded
  inputs, relative MSE;
- :mod:`codermind_harness.sides`: rendering a tutorial scene on both sides at matched sample
  positions and counts (the converted XML through Mitsuba's ``path``; the port in clean mode);
- :mod:`codermind_harness.runner`: where the units of work run (this process, a process
  pool), :mod:`~codermind_harness.cluster` a Dask cluster (``--cluster``), and
  :mod:`~codermind_harness.bundle` the XML and its files that travel with a task;
- :mod:`codermind_harness.compare`: ``codermind compare`` (both sides rendered and tested),
  with :mod:`~codermind_harness.case` (a scene checked, the options),
  :mod:`~codermind_harness.verdict` (thresholds, failures), :mod:`~codermind_harness.report`
  (JSON record, heat map, tables) and :mod:`~codermind_harness.compare_image`
  (``--reference IMAGE``);
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
