"""``--cluster``: the work on a real Dask cluster (a LocalCluster of 2 worker processes on
127.0.0.1, started once for the module) gives the same results as on this machine.

Evidence kind: agreement of our own code run two ways (local process pool vs. cluster
tasks). What it proves is that the distribution changes nothing (bit-identical port images,
identical compare verdicts and numbers, identical chart errors), including when a worker
process is killed mid-task and the scheduler re-runs its task. It says nothing about the
correctness of either renderer (the other test files do that).
"""

from __future__ import annotations

import functools
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from support import ROOT, fake_sweeps, run_cli

distributed = pytest.importorskip("distributed")
pytestmark = pytest.mark.cluster

SCENES = ROOT / "scenes"
#: a page-4 crop of 2 port tiles (20 x 12 pixels, 4 sub-samples, Complexity 128: rows 0-5 and
#: 6-11, 61440 rays each)
RECT, COMPLEXITY, SEED, TILES = (300, 234, 320, 246), 128, 7, 2


@pytest.fixture(scope="module")
def cluster():
    lc = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None, silence_logs=50)
    try:
        yield lc.scheduler_address
    finally:
        lc.close()


@pytest.fixture(scope="module")
def page4():
    import codermind_ref as ref
    return ref.parse_scene(SCENES / "page4.txt")


@pytest.fixture(scope="module")
def local_render(page4):
    import codermind_ref as ref
    return ref.render(page4, "clean", SEED, COMPLEXITY, rect=RECT, workers=1)


def _same_image(a, b) -> None:
    assert np.array_equal(a.rgb8_tga, b.rgb8_tga)
    assert np.array_equal(a.linear, b.linear)
    assert np.array_equal(a.variance, b.variance, equal_nan=True)
    assert a.exposure == b.exposure


def _render_page1_top(queue, workers: int) -> None:
    try:
        import codermind_ref as ref
        scene = ref.parse_scene(SCENES / "page1.txt")
        queue.put(ref.render(scene, workers=workers).rgb8_tga.tobytes())
    except Exception as e:      # noqa: BLE001  (reported to the test)
        queue.put(f"{type(e).__name__}: {e}")


def test_the_port_in_a_daemonic_process_renders_there_instead_of_forking_a_pool():
    """A Dask worker process is daemonic and may not have children: the port's workers=2
    (5 tiles here) must then run in the process itself, with the same bytes."""
    import codermind_ref as ref
    ctx = multiprocessing.get_context("fork")    # first test: no cluster threads forked yet
    queue = ctx.Queue()
    child = ctx.Process(target=_render_page1_top, args=(queue, 2), daemon=True)
    child.start()
    got = queue.get(timeout=120)
    child.join(30)
    scene = ref.parse_scene(SCENES / "page1.txt")
    assert got == ref.render(scene, workers=1).rgb8_tga.tobytes()


def test_a_run_without_the_option_does_not_import_distributed(tmp_path):
    code = ("import sys; from codermind_cli.main import main; "
            f"rc = main(['reference', {str(SCENES / 'page1.txt')!r}, '-o', "
            f"{str(tmp_path / 'p1')!r}]); "
            "import codermind_harness.cluster; "
            "print(rc, 'distributed' in sys.modules, 'dask' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.stdout.split()[-3:] == ["0", "False", "False"], out.stderr[-2000:]


@pytest.mark.parametrize("value", ["bogus", "local:0", "http://host:8786", "local:x"])
def test_a_bad_cluster_value_is_a_one_line_error_with_status_2(tmp_path, value):
    out = run_cli("reference", SCENES / "page1.txt", "-o", tmp_path / "x", "--cluster", value,
                  timeout=60)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("codermind: error: --cluster"), out.stderr


def test_the_bundle_carries_the_cube_faces_and_names_nothing_outside_it(tmp_path):
    from codermind_harness.bundle import _FOLDERS, Bundle
    bundle = Bundle.of(SCENES / "page4.xml")
    names = dict(bundle.files)
    assert len(names) == 6 and all(n.startswith("inputs/") for n in names)
    assert str(SCENES) not in bundle.text and 'value="sky/' not in bundle.text
    for name, data in names.items():     # byte for byte the files the XML named
        assert data == (SCENES / "sky" / name.split("-", 1)[1]).read_bytes()
    _FOLDERS.pop(bundle.digest, None)
    xml = bundle.materialize()
    assert xml.parent != SCENES and all((xml.parent / n).read_bytes() == d
                                        for n, d in names.items())


def test_port_render_on_the_cluster_is_bit_identical(cluster, page4, local_render):
    """Both tiles in one task here; the killed-worker test below sends one tile per task and
    compares with the same local render, so two groupings are checked."""
    import codermind_ref as ref
    from codermind_harness.cluster import Cluster
    with Cluster(cluster, progress=False) as cl:
        remote = ref.render(page4, "clean", SEED, COMPLEXITY, rect=RECT,
                            tile_map=functools.partial(cl.tile_map, per_task=2))
        assert cl.submitted == 1
    _same_image(remote, local_render)


def test_reference_command_on_the_cluster_writes_the_same_files(cluster, tmp_path):
    scene = SCENES / "page1.txt"
    here = run_cli("reference", scene, "-o", tmp_path / "here", "--workers", "1", timeout=120)
    there = run_cli("reference", scene, "-o", tmp_path / "there", "--cluster", cluster,
                    timeout=120)
    assert here.returncode == 0 and there.returncode == 0, there.stderr[-2000:]
    assert "cluster: " in there.stderr and "tasks on tcp://" in there.stderr
    for ext in ("tga", "png", "exr", "variance.exr"):
        assert (tmp_path / f"here.{ext}").read_bytes() == (tmp_path / f"there.{ext}").read_bytes()


def _numbers(path):
    """compare.json's records without what depends on where or when they ran."""
    records = json.loads(path.read_text())["scenes"]
    for r in records:
        for key in ("seconds", "heatmap", "xml"):
            r.pop(key)
    return records


def test_compare_on_the_cluster_gives_the_local_verdicts_and_numbers(cluster, tmp_path):
    args = [SCENES / "page1.txt", SCENES / "page4.txt", "--rect", "300,240,316,252",
            "--spp", "16", "--seed", "3"]
    here = run_cli("compare", *args, "-o", tmp_path / "here", "-q", timeout=240)
    there = run_cli("compare", *args, "-o", tmp_path / "there", "--cluster", cluster,
                    timeout=240)
    assert here.returncode in (0, 1) and there.returncode == here.returncode, there.stderr[-2000:]
    a, b = _numbers(tmp_path / "here" / "compare.json"), _numbers(tmp_path / "there" / "compare.json")
    assert [r["page"] for r in a] == [1, 4]
    assert a == b                       # z-test, FLIP, relMSE, verdicts: exactly equal
    assert "tasks on tcp://" in there.stderr


def test_chart_quick_run_on_the_cluster_gives_the_local_errors(cluster, tmp_path):
    args = ["chart", "--quick", "--only", "page1", "--no-cost"]
    here = run_cli(*args, "-o", tmp_path / "here", timeout=240)
    there = run_cli(*args, "-o", tmp_path / "there", "--cluster", cluster, timeout=240)
    assert here.returncode == 0 and there.returncode == 0, there.stderr[-2000:]
    docs = [json.loads((tmp_path / d / "chart.json").read_text()) for d in ("here", "there")]
    assert docs[0]["cluster"] is None and docs[1]["cluster"] == cluster
    points = [[(p["method"], p["value"], p["rel_mse"], p["flip"]) for p in d["scenes"][0]["points"]]
              for d in docs]
    assert len(points[0]) >= 4 and points[0] == points[1]
    assert "tasks on tcp://" in there.stderr


def test_a_worker_killed_mid_task_changes_nothing(cluster, page4, local_render):
    """SIGKILL a worker process while it runs a tile group: the nanny restarts it, the
    scheduler re-runs its tasks, and the image is still bit-identical to the local one."""
    import codermind_ref as ref
    from codermind_harness.cluster import Cluster
    with Cluster(cluster, progress=False) as cl:
        pids = cl.client.run(os.getpid)
        killed: dict = {}

        def kill_a_busy_worker():
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline and not killed:
                busy = {w: keys for w, keys in cl.client.processing().items() if keys}
                if busy:
                    worker, keys = next(iter(busy.items()))
                    killed.update(worker=worker, keys=list(keys))
                    os.kill(pids[worker], signal.SIGKILL)
                time.sleep(0.02)

        killer = threading.Thread(target=kill_a_busy_worker)
        killer.start()
        remote = ref.render(page4, "clean", SEED, COMPLEXITY, rect=RECT,
                            tile_map=functools.partial(cl.tile_map, per_task=1))
        killer.join()
        assert cl.submitted == TILES
        assert killed, "no worker was busy to kill"
        # the scheduler sent at least one of the killed worker's tasks out twice
        runs = [sum(1 for s in cl.client.story(k) if s[0] == "scheduler" and s[2] == "processing")
                for k in killed["keys"]]
        assert max(runs) >= 2, runs
        cl.client.wait_for_workers(2, timeout=60)      # the nanny's restart, for later tests
    _same_image(remote, local_render)


#: the sweeps of the cluster test: Mitsuba on the workers (with a variant switch in fresnel),
#: random draws as generator states (perlin) and drawn on the client (zone_scale), renders
#: of the port; the slow ones (blob_neck, blinnphong's chi2) are left out
QUICK_SWEEPS = ["perlin_float32", "fresnel", "thin_lens", "zone_scale", "tone_curve",
                "auto_exposure"]


def _records(text: str) -> list[dict]:
    """stability.json's records without the times (those of wherever the points ran)."""
    records = json.loads(text)
    for r in records:
        r.pop("seconds")
    return records


def test_stability_quick_run_on_the_cluster_gives_the_local_records(cluster, tmp_path):
    """One point per task: the records and figures of the points run one after another here
    (in this process) equal those of `codermind stability --cluster`."""
    from codermind_harness import stability
    local = stability.run(QUICK_SWEEPS, quick=True)
    stability.write_report(local, tmp_path / "here", "test")
    there = run_cli("stability", "--quick", "--only", *QUICK_SWEEPS, "-o", tmp_path / "there",
                    "--cluster", cluster, timeout=300)
    assert there.returncode == 0, there.stderr[-2000:]
    a = _records(stability.to_json(local))
    b = _records((tmp_path / "there" / "stability.json").read_text())
    assert [r["name"] for r in a] == QUICK_SWEEPS and all(r["passed"] and r["checks"] for r in a)
    assert a == b
    for name in QUICK_SWEEPS:   # the curves and pictures too (the JSON leaves them out)
        assert (tmp_path / "here" / f"{name}.png").read_bytes() == \
            (tmp_path / "there" / f"{name}.png").read_bytes(), name
    tasks = int(there.stderr.split("cluster: ")[-1].split("/")[0])
    assert tasks > 10 * len(QUICK_SWEEPS), there.stderr[-500:]  # points, not sweeps, per task


@pytest.fixture
def plan_sweeps(monkeypatch):
    """Sweeps made of points computed by math.sqrt (importable on any worker): one in two
    rounds (the second needs the first's results), one whose point raises."""
    fake_sweeps.install(monkeypatch)


def test_sweep_plans_in_two_rounds_and_a_crashed_point_on_the_cluster(cluster, plan_sweeps):
    from codermind_harness import stability
    from codermind_harness.cluster import open_runner
    local = stability.run()
    with open_runner(cluster, progress=False) as cl:
        remote = stability.run(runner=cl)
        assert cl.submitted == 3 + 1 + 2            # both rounds and the crashing sweep
    for results in (local, remote):
        two, crashed = results
        assert two.table == [{"first": [1.0, 2.0, 3.0], "second": [6.0 ** 0.5]}]
        assert two.threshold_value == 6.0 ** 0.5 and two.passed
        assert not crashed.passed
        assert crashed.checks[0].detail == "ValueError: math domain error"
