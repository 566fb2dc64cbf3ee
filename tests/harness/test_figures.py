"""The harness's figures (compare's heat map, a stability sweep's plot) are drawn on their own
matplotlib Figure, never through pyplot: the caller's backend and current figure are left as
they were, so a notebook that runs ``compare`` keeps showing its own plots. Evidence: the
backend and pyplot's figure list before and after."""

from __future__ import annotations

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")


@pytest.fixture
def svg_backend():
    """pyplot on another backend than the Agg that files are written with, and one figure
    of the caller's open."""
    import matplotlib.pyplot as plt
    old = matplotlib.get_backend()
    plt.switch_backend("svg")
    fig = plt.figure()
    yield plt, fig
    plt.close(fig)
    plt.switch_backend(old)


def test_the_heat_map_leaves_pyplot_alone(svg_backend, tmp_path):
    from codermind_harness import metrics, report
    plt, fig = svg_backend
    a = np.random.default_rng(0).random((8, 10, 3)).astype(np.float32)
    var = np.full_like(a, 0.01)
    z = metrics.z_test(a, var, a + 0.01, var, 0.01, 1e-3, 1e-4)
    report.write_heatmap(tmp_path / "h.png", a, a, slice(None), np.zeros((8, 10)), z, "port",
                         "title")
    assert (tmp_path / "h.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert matplotlib.get_backend() == "svg"
    assert plt.get_fignums() == [fig.number] and plt.gcf() is fig


def test_a_sweep_plot_leaves_pyplot_alone(svg_backend, tmp_path):
    from codermind_harness.stability import plot
    from codermind_harness.sweep_result import Series, SweepResult
    plt, fig = svg_backend
    result = SweepResult("s", "a sweep", "x", "y", "none", None,
                         series=[Series("y(x)", [1.0, 10.0], [1.0, 2.0])])
    plot(result, tmp_path / "s.png")
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert matplotlib.get_backend() == "svg"
    assert plt.get_fignums() == [fig.number]
