"""The runner the command line hands down (codermind_harness.runner): units of work here, in
a process pool or on a Dask cluster (tests/harness/test_cluster.py) give the same results.

Evidence kind: agreement of our own code run two ways (in this process vs. in a pool of
fresh processes). It says nothing about the correctness of either renderer."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from support import ROOT, fake_sweeps

SCENES = ROOT / "scenes"


@pytest.fixture(scope="module")
def pool():
    from codermind_harness.runner import PoolRunner
    with PoolRunner(2) as runner:
        yield runner


def test_the_local_runner_runs_a_unit_when_its_result_is_asked_for():
    """chart's rounds log each point as it finishes: units run lazily, in order."""
    from codermind_harness.runner import Runner
    ran = []
    runner = Runner()
    handles = runner.submit_all(ran.append, [(1,), (2,)])
    assert ran == [] and not runner.remote and runner.tile_map is None
    results = runner.results(handles)
    next(results)
    assert ran == [1]
    assert list(runner.map(math.sqrt, [4.0, 9.0])) == [2.0, 3.0]


def test_a_pool_renders_the_port_bit_identically(pool):
    import codermind_ref as ref
    scene = ref.parse_scene(SCENES / "page1.txt")
    here = ref.render(scene, rect=(0, 0, 64, 40), workers=1)
    there = ref.render(scene, rect=(0, 0, 64, 40), tile_map=pool.tile_map)
    assert np.array_equal(here.rgb8_tga, there.rgb8_tga)
    assert np.array_equal(here.linear, there.linear)


def test_sweep_points_in_a_pool_give_the_local_results(pool, monkeypatch):
    """Two rounds of points (the second needs the first's), and a point that raises."""
    from codermind_harness import stability
    fake_sweeps.install(monkeypatch)
    for two, crashed in (stability.run(), stability.run(runner=pool)):
        assert two.table == [{"first": [1.0, 2.0, 3.0], "second": [6.0 ** 0.5]}]
        assert not crashed.passed
        assert crashed.checks[0].detail == "ValueError: math domain error"


def test_a_chart_mitsuba_runner_travels_as_its_bundle(llvm):
    """Pickled, a MitsubaRunner becomes the one runner of its XML's bundle in the receiving
    process, loading the XML written from the bundle (no shared filesystem); the class
    pickles so by itself, whoever pickles it."""
    from codermind_harness.chart import MitsubaRunner
    runner = MitsubaRunner(SCENES / "page4.xml", 640, 480, 4)
    a, b = (pickle.loads(pickle.dumps(runner)) for _ in range(2))
    assert a is b and a is not runner
    assert a.xml.parent != SCENES and a.xml.read_text() != (SCENES / "page4.xml").read_text()
    assert (a.width, a.height, a.page) == (640, 480, 4)
