"""The inverse-rendering example (docs/examples/inverse_blob.py, issue 15) runs, on its
``--quick`` settings (32x32 pixels, 3 views, 40 iterations instead of the default 150),
and is checked against the issue's criteria: the loss falls at least 100x, the three blob
centres come within 1% of the radius, the marble colour within 0.01.

Evidence: [fact] the truth is known (the target image is rendered from it), so the
centres and the colour are compared with the truth, not with another render of ours.

Measured (docs/examples/README.md): the default 150-iteration run meets all three
(2151x, 0.0079 R, colour within 0.0023), but it takes about 6 minutes here. The quick run
does not: 29.7x, 0.116 R, colour 0.062. The three criteria are therefore asserted on the
quick run as strict xfails (they report when they start to pass); what is asserted plainly
is that the quick run's optimisation works at all: the loss falls at least 10x and the
centre error falls below 3/4 of its start (0.1875 R; measured 0.116-0.117 R)."""

from __future__ import annotations

import importlib.util

import pytest

from conftest import ROOT

START_ERROR = 0.1875        # the example's start, largest centre coordinate error / R


def _example():
    spec = importlib.util.spec_from_file_location(
        "inverse_blob", ROOT / "docs" / "examples" / "inverse_blob.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def quick_run():
    # (the example sets the variant, llvm_ad_rgb, and registers the plugins itself)
    return _example().optimise(iterations=40, size=32, final_lr=0.05,
                                log=lambda line: None)


def test_quick_run_descends(quick_run):
    assert quick_run["loss_fall"] >= 10, quick_run["loss_fall"]
    assert quick_run["centre_error_over_r"] <= 0.75 * START_ERROR, quick_run


@pytest.mark.xfail(strict=True, reason="measured 29.7x after the quick run's 40 iterations "
                                       "(2151x after the default 150)")
def test_quick_run_loss_falls_100x(quick_run):
    assert quick_run["loss_fall"] >= 100, quick_run["loss_fall"]


@pytest.mark.xfail(strict=True, reason="measured 0.116 R after the quick run's 40 "
                                       "iterations (0.0079 R after the default 150)")
def test_quick_run_centres_within_1_percent_of_the_radius(quick_run):
    assert quick_run["centre_error_over_r"] <= 0.01, quick_run["centre_error_over_r"]


@pytest.mark.xfail(strict=True, reason="measured 0.062 after the quick run's 40 iterations "
                                       "(0.0023 after the default 150)")
def test_quick_run_recovers_the_marble_colour(quick_run):
    assert quick_run["color_error"] <= 0.01, quick_run["color_error"]
