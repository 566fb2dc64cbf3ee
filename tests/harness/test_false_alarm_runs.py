"""benchmarks/false_alarm.py: its run list is what its docs claim (>= 100 runs, page-4 runs
with seeds that share no random number, grids inside the image and off the calibration
strip), and its binomial interval is Clopper-Pearson's [fact: closed forms for k = 0, n]."""

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _module():
    spec = importlib.util.spec_from_file_location("false_alarm", ROOT / "benchmarks" / "false_alarm.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_run_list(tutorial_dir, monkeypatch):
    fa = _module()
    monkeypatch.setattr(fa, "TUTORIAL", tutorial_dir)
    runs = fa.false_alarm_runs(96)
    assert len(runs) >= 100
    rnd = [r for r in runs if "page4" in str(r["scene"])]
    assert len(rnd) == 96
    seeds = sorted(r["seed"] for r in rnd)
    # exposure seeds SEED..SEED+7 and the noise floor SEED+1: no overlap between runs
    assert all(b - a >= 8 for a, b in zip(seeds, seeds[1:]))
    assert {r["spp"] for r in rnd} == {None, 16, 256}
    for r in runs:
        assert Path(r["scene"]).is_file()
        if r["rect"] is not None:
            x0, y0, x1, y1 = r["rect"]
            assert 0 <= x0 < x1 <= fa.W and fa.STRIP <= y0 or r["rect"] == (1, 1, fa.W, fa.H)
            assert y1 <= fa.H
    sweep = fa.sweep_runs()
    assert {r["spp"] for r in sweep} == {16, 64, 256, 1024}
    assert len({(str(r["scene"]), r["rect"]) for r in sweep}) == len(sweep) // 4
    # several seeds: the random grids again with seeds 10 apart, the deterministic ones once
    seeded = fa.sweep_runs((16,), seeds=3)
    random = [r for r in seeded if "page4" in str(r["scene"])]
    assert sorted({r["seed"] for r in random}) == [0, 10, 20]
    assert len(random) == 3 * len([r for r in sweep if r["spp"] == 16 and "page4" in str(r["scene"])])
    assert {r["seed"] for r in seeded if "page4" not in str(r["scene"])} == {0}


def test_sweep_cells_count_failing_seeds():
    fa = _module()
    row = dict(scene="s", rect=[0, 0, 8, 8], stride=1, spp=16, passed=True, failed="",
               blob_sub_samples=0, pass_rate=1.0, pooled_max={}, flip=0.0, flip_limit=0.01)
    rows = [dict(row, seed=0, passed=False, failed="objects"), dict(row, seed=10),
            dict(row, seed=0, spp=64)]
    table = "\n".join(fa.pivot(rows))
    assert "1 / 2 seeds fail (0: objects)" in table and "| pass, z 1.0000" in table


def test_clopper_pearson():
    fa = _module()
    lo, hi = fa.clopper_pearson(0, 100)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 100), rel=1e-9)
    lo, hi = fa.clopper_pearson(100, 100)
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / 100), rel=1e-9)
    lo, hi = fa.clopper_pearson(2, 100)
    assert lo < 0.02 < hi and hi == pytest.approx(0.0704, abs=1e-3)
