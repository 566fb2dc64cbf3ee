"""``codermind stability``: every sweep runs (quick mode) and none of its never-happen checks
fails; a crash or a failed check gives exit status 1; the exact zone solver and the chi2 lobe
domain the sweeps rely on are right."""

from __future__ import annotations

import json
import sys
import types

import numpy as np
import pytest

from support import run_cli


def test_quick_run_of_every_sweep_passes_and_writes_the_report(tmp_path):
    from codermind_harness.stability import SWEEPS
    out = run_cli("stability", "--quick", "-o", tmp_path / "report", timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
    report = tmp_path / "report"
    records = json.loads((report / "stability.json").read_text())
    assert [r["name"] for r in records] == list(SWEEPS)
    for r in records:
        assert r["passed"] and r["checks"], r["name"]
        assert (report / f"{r['name']}.png").stat().st_size > 1000
    table = (report / "stability.md").read_text()
    assert "| sweep | swept | measured | threshold |" in table and "--quick" in table
    assert "| `tone_curve` |" in out.stdout
    assert f"[{len(SWEEPS)}/{len(SWEEPS)}]" in out.stderr          # progress


@pytest.fixture
def fake_sweeps(monkeypatch):
    """Two extra sweeps: one raises, one reports a failed check."""
    from codermind_harness import stability

    def boom(quick):
        raise ZeroDivisionError("division by zero in a sweep")

    def fails(quick):
        r = stability.SweepResult("fails", "a failing sweep", "x", "y", "none", None)
        r.check("nothing is NaN", False, "3 NaN")
        r.series = [stability.Series("y", [1.0, 2.0], [1.0, float("nan")])]
        return r

    module = types.ModuleType("codermind_harness._fake")
    module.boom, module.fails = boom, fails
    monkeypatch.setitem(sys.modules, "codermind_harness._fake", module)
    monkeypatch.setattr(stability, "SWEEPS", {"boom": ("_fake", "boom", "raises"),
                                              "fails": ("_fake", "fails", "fails a check")})


def test_crash_and_failed_check_give_exit_1(fake_sweeps, tmp_path, capsys):
    from codermind_cli.main import main
    assert main(["stability", "--only", "boom", "fails", "-o", str(tmp_path)]) == 1
    records = {r["name"]: r for r in json.loads((tmp_path / "stability.json").read_text())}
    assert not records["boom"]["passed"]
    assert "ZeroDivisionError: division by zero in a sweep" in records["boom"]["checks"][0]["detail"]
    assert records["fails"]["checks"] == [{"what": "nothing is NaN", "passed": False,
                                           "detail": "3 NaN"}]
    captured = capsys.readouterr()
    assert "FAIL" in captured.out and "never-happen checks failed in: boom, fails" in captured.err


def test_unknown_sweep_is_a_usage_error(tmp_path):
    out = run_cli("stability", "--only", "nosuchsweep", "-o", tmp_path)
    assert out.returncode == 2 and "nosuchsweep" in out.stderr


def test_zone_solver_is_exact_and_agrees_with_the_port():
    """The 50-digit solver equals the closed form of a lone source (a sphere of radius R),
    and the port's float64 zone method agrees with it on camera rays at the page-4 blob."""
    from decimal import Decimal, localcontext
    from codermind_harness import sweep_zone, zone_exact
    o, d = np.array([0.3, -0.2, -400.0]), np.array([0.0, 0.0, 1.0])
    t = zone_exact.first_hit(o, d, sweep_zone.LONE, 80.0)
    with localcontext() as ctx:
        ctx.prec = 50
        exact = Decimal(400) - (Decimal(80) ** 2 - Decimal(0.3) ** 2 - Decimal(-0.2) ** 2).sqrt()
    assert abs(t - exact) < Decimal(10) ** -40
    assert zone_exact.first_hit(np.array([81.0, 0, -400]), d, sweep_zone.LONE, 80.0) is None
    assert abs(zone_exact.field_at(o + float(t) * d, sweep_zone.LONE, 80.0) - 1) < 1e-12
    rng = np.random.default_rng(4)
    origins, dirs = sweep_zone._aimed_rays(rng, 60)
    t_port, hit = sweep_zone._port(origins, dirs, sweep_zone.CENTERS, sweep_zone.RADIUS)
    ref = [zone_exact.first_hit(origins[i], dirs[i], sweep_zone.CENTERS, sweep_zone.RADIUS)
           for i in range(60)]
    err, disagree = sweep_zone._compare(t_port, hit, ref)
    assert not disagree.any() and hit.sum() > 10 and err.max() < 1e-12


def test_lobe_domain_maps_both_ways(llvm):
    """The chi2 domain of the blinnphong sweep: forward then backward is the identity, and
    its density integrates a solid-angle pdf to the same total."""
    mi = llvm
    from codermind_harness.sweep_bsdf import LobeDomain
    domain = LobeDomain(mi, [0.6, 0.0, 0.8], 5e5)
    rng = np.random.default_rng(1)
    p = mi.Point2f(rng.uniform(-3.1, 3.1, 1000), rng.uniform(0.01, 0.99, 1000) * domain.s_max)
    back = domain.map_backward(domain.map_forward(p))
    np.testing.assert_allclose(back.numpy(), p.numpy(), rtol=2e-3, atol=2e-5)
    # uniform pdf 1 / (4 pi) on the sphere: integral of the density over the domain is 1
    domain = LobeDomain(mi, [0.6, 0.0, 0.8], 2.0)       # a smooth Jacobian for the midpoint rule
    n = 400
    phi, s = np.meshgrid(np.linspace(-np.pi, np.pi, n, endpoint=False) + np.pi / n,
                         (np.arange(n) + 0.5) / n * domain.s_max)
    q = mi.Point2f(phi.ravel(), s.ravel())
    dens = domain.density(q, mi.Float(np.full(n * n, 1 / (4 * np.pi)))).numpy()
    total = dens.sum() * (2 * np.pi / n) * (domain.s_max / n)
    assert total == pytest.approx(1.0, rel=0.02)
