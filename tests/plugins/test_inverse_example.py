"""The inverse-rendering example (docs/examples/inverse_blob.py) runs, on its
``--quick`` settings (32x32 pixels, 3 views, 30 iterations instead of the default 150, the
rates held until iteration 17 instead of 15, from the same start as the full run), and
meets its criteria: the loss falls at least 100x, the three blob centres come
within 1% of the radius (largest coordinate error / R), the marble colour within 0.01
(largest channel error).

Evidence: [fact] the truth is known (the target image is rendered from it), so the
centres and the colour are compared with the truth, not with another render of ours.

Measured (docs/examples/README.md): the quick run reached 93600x, 0.0028 R and a colour
error of 0.0003 (with other adjoint seeds, ``--grad-seed 1000``: 143800x, 0.0043 R,
0.0004): the margin is 2.3-3.6x on the centres. About 70 s CPU."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from support import ROOT


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
