"""The inverse-rendering example (docs/examples/inverse_blob.py, issue 15) runs, on its
``--quick`` settings (32x32 pixels, 3 views, 30 iterations instead of the default 150, the
rates held until iteration 17 instead of 15, from the same start as the full run), and
meets the issue's criteria: the loss falls at least 100x, the three blob centres come
within 1% of the radius (largest coordinate error / R), the marble colour within 0.01
(largest channel error).

Evidence: [fact] the truth is known (the target image is rendered from it), so the
centres and the colour are compared with the truth, not with another render of ours.

Measured (docs/examples/README.md, 2026-12-02): the quick run reached 35600x, 0.0014 R and
a colour error of 0.0003 (another run 34100x, 0.0021 R, 0.0004; with other adjoint seeds,
``--grad-seed 1000``, 26340x, 0.0034 R, 0.0004): the margin is 3-7x on the centres. About
35 s CPU. What made 30 iterations enough: the colour alone for the first 4 iterations
(the centres' gradients pointed partly the wrong way while it was far off), Adam with
beta_1 0.6 and beta_2 0.9, and the rates held before they decay (the 40-iteration
schedule before reached 29.7x, 0.116 R, 0.062)."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from conftest import ROOT


def _example():
    spec = importlib.util.spec_from_file_location(
        "inverse_blob", ROOT / "docs" / "examples" / "inverse_blob.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def quick_run():
    # (the example sets the variant, llvm_ad_rgb, and registers the plugins itself)
    example = _example()
    return example.optimise(iterations=example.QUICK_ITERATIONS, hold=example.QUICK_HOLD,
                            log=lambda line: None)


def test_the_start_is_the_issue_s_start():
    # the criteria mean something only from this start: 0.1875 R off (largest coordinate),
    # colour 0.4 off (largest channel), the same start as the full run
    example = _example()
    off = np.abs(example.START_CENTERS - example.TRUE_CENTERS).max() / example.R
    assert off == pytest.approx(0.1875)
    assert np.abs(np.subtract(example.START_COLOR, example.TRUE_COLOR)).max() == \
        pytest.approx(0.4)


def test_quick_run_loss_falls_100x(quick_run):
    assert quick_run["loss_fall"] >= 100, quick_run["loss_fall"]


def test_quick_run_centres_within_1_percent_of_the_radius(quick_run):
    assert quick_run["centre_error_over_r"] <= 0.01, quick_run["centre_error_over_r"]


def test_quick_run_recovers_the_marble_colour(quick_run):
    assert quick_run["color_error"] <= 0.01, quick_run["color_error"]
