"""codermind chart: the Pareto front, the slope and threshold helpers, a quick run's files,
and bad options."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from codermind_harness.chart_data import fit_slope, pareto_front, time_to_reach
from support import run_cli


def test_pareto_front_of_points_on_and_above_a_hyperbola():
    # e = 1 / t is a front: every point of it trades time for error; points above it
    # (2 / t, or a point slower and worse than one of them) are dominated
    t = np.array([1, 2, 4, 8, 2, 4, 9], float)
    e = np.array([1, 0.5, 0.25, 0.125, 1.0, 0.5, 0.2])
    assert pareto_front(t, e).tolist() == [True] * 4 + [False] * 3


def test_pareto_front_keeps_ties_and_drops_nan():
    front = pareto_front([1, 1, 2, 3], [0.5, 0.5, 0.1, math.nan])
    assert front.tolist() == [True, True, True, False]


def test_pareto_front_of_a_point_that_dominates_all_is_that_point():
    assert pareto_front([1, 2, 3], [0.1, 0.2, 0.3]).tolist() == [True, False, False]


def test_fit_slope_of_a_power_law():
    x = np.array([1, 10, 100, 1000.0])
    assert fit_slope(x, 3 * x ** 1.5) == pytest.approx(1.5)
    assert math.isnan(fit_slope([1], [2]))


def test_time_to_reach_interpolates_log_log():
    # e = 1 / t through (1, 1) and (100, 0.01): 1e-1 is reached at t = 10 exactly
    assert time_to_reach([1, 100], [1, 0.01], 0.1) == pytest.approx(10)
    assert time_to_reach([1, 2], [1, 0.5], 0.1) is None
    assert time_to_reach([3, 1], [0.05, 1], 0.1) == pytest.approx(3 ** (math.log(10) / math.log(20)))


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("chart")
    proc = run_cli("chart", "--quick", "--only", "page4", "-o", out, timeout=240)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return out, proc


def test_quick_run_writes_png_csv_and_json(quick_run):
    out, proc = quick_run
    for name in ("error_vs_time_page4.png", "cost_scaling.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with open(out / "error_vs_time_page4.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert {"method", "spp", "seconds", "rel_mse", "flip", "front_rel_mse"} <= set(rows[0])
    methods = {r["method"] for r in rows}
    assert {"mitsuba spp", "mitsuba max_error", "port clean", "chooser pick", "maximal model",
            "scalar_rgb", "llvm_ad_rgb (scalar crop)"} <= methods
    for r in rows:
        assert float(r["seconds"]) > 0 and float(r["rel_mse"]) >= 0
        assert 0 <= float(r["flip"]) <= 1
    assert any(r["front_rel_mse"] == "True" for r in rows)
    doc = json.loads((out / "chart.json").read_text())
    assert doc["scenes"][0]["scene"] == "page4"
    assert "page4" in proc.stdout and "mitsuba spp" in proc.stdout


def test_quick_run_error_falls_with_spp(quick_run):
    out, _ = quick_run
    with open(out / "error_vs_time_page4.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["method"] == "mitsuba spp"]
    spp = [int(r["spp"]) for r in rows]
    assert spp == sorted(spp) and len(set(spp)) == len(spp) >= 3
    # a 4x spp step cuts the noise's rel MSE (more than the reference's noise allows to hide)
    errors = [float(r["rel_mse"]) for r in rows]
    assert errors[-1] < errors[0]


def test_quick_run_cost_csv_has_slopes(quick_run):
    out, _ = quick_run
    with open(out / "cost_scaling.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert {r["experiment"] for r in rows} >= {"pixels", "spp", "sources", "triangles"}
    pix = [r for r in rows if r["experiment"] == "pixels" and r["method"].startswith("port")]
    assert all(r["slope"] for r in pix)


@pytest.mark.parametrize("args, message", [
    (("--only", "page9"), "invalid choice"),
    (("--bogus",), "unrecognized arguments"),
])
def test_bad_option_is_a_one_line_error(tmp_path, args, message):
    proc = run_cli("chart", "-o", tmp_path, *args, timeout=60)
    assert proc.returncode == 2
    assert message in proc.stderr and "Traceback" not in proc.stderr


def test_unwritable_output_is_a_one_line_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    proc = run_cli("chart", "--quick", "--only", "page1", "--no-cost", "-o", blocker / "sub",
                   timeout=120)
    assert proc.returncode == 2, proc.stderr[-1000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("codermind")]
    assert len(lines) == 1 and "cannot write" in lines[0]
