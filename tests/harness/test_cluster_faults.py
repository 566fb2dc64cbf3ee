"""Cluster faults: an address that accepts TCP connections and never answers fails in one
line within the documented connect time (docs/cluster.md), instead of hanging in
``distributed.Client``."""

from __future__ import annotations

import socket
import threading
import time

import pytest

from support import run_cli

pytest.importorskip("distributed")


def test_a_silent_endpoint_fails_in_one_line_within_the_connect_time(tmp_path):
    from codermind_harness.cluster import CONNECT_TIMEOUT_S
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(16)
    port = server.getsockname()[1]
    held = []

    def accept():                     # accept and never answer
        while True:
            try:
                held.append(server.accept()[0])
            except OSError:
                return

    threading.Thread(target=accept, daemon=True).start()
    scene = tmp_path / "s.txt"
    scene.write_text("Scene { Version.Major = 1; Version.Minor = 0; Image.Width = 4;\n"
                     "Image.Height = 4; }\n")
    try:
        t0 = time.monotonic()
        r = run_cli("reference", scene, "-o", tmp_path / "o", "--cluster",
                    f"tcp://127.0.0.1:{port}", cwd=tmp_path, timeout=120)
        elapsed = time.monotonic() - t0
    finally:
        server.close()
        for c in held:
            c.close()
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "no answer from the scheduler within" in lines[0], r.stderr
    assert elapsed < CONNECT_TIMEOUT_S + 10       # the command's start-up included
    assert held, "the command never connected"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args):
    import os
    import subprocess
    import sys
    dask = os.path.join(os.path.dirname(sys.executable), "dask")
    return subprocess.Popen([dask, *args, "--no-dashboard"], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def _scheduler():
    port = _free_port()
    proc = _dask("scheduler", "--host", "127.0.0.1", "--port", str(port))
    address = f"tcp://127.0.0.1:{port}"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return proc, address
        time.sleep(0.2)
    proc.kill()
    pytest.skip("a dask scheduler did not start within 30 s")


def test_a_lost_scheduler_is_one_error_and_no_false_progress(monkeypatch):
    from codermind_harness.cluster import Cluster, ClusterError
    scheduler, address = _scheduler()
    worker = _dask("worker", address, "--nthreads", "1")
    try:
        cluster = Cluster(address, progress=False)
        cluster.client.wait_for_workers(1, timeout=60)
        handles = cluster.submit_all(time.sleep, [(0.3,)] * 10)
        results = cluster.results(handles)
        next(results)
        scheduler.kill()
        with pytest.raises(ClusterError) as e:
            list(results)
        assert "lost the scheduler" in str(e.value) and "/10 tasks done" in str(e.value)
        assert cluster.failed and cluster.done < cluster.submitted
        cluster.close()
    finally:
        scheduler.kill()
        worker.kill()


def test_with_no_worker_left_the_wait_is_bounded_and_said_in_one_line(tmp_path, monkeypatch):
    scheduler, address = _scheduler()         # a scheduler without workers
    scene = tmp_path / "s.txt"
    scene.write_text("Scene { Version.Major = 1; Version.Minor = 0; Image.Width = 4;\n"
                     "Image.Height = 4; }\n")
    monkeypatch.setenv("CODERMIND_CLUSTER_WAIT", "2")
    try:
        t0 = time.monotonic()
        r = run_cli("reference", scene, "-o", tmp_path / "o", "--cluster", address,
                    cwd=tmp_path, timeout=120)
        elapsed = time.monotonic() - t0
    finally:
        scheduler.kill()
    assert r.returncode == 2, r.stderr
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("codermind: error:")]
    assert len(errors) == 1 and "no worker left for 2 s (0/" in errors[0], r.stderr
    assert "waiting up to 2 s" in r.stderr
    assert "Traceback" not in r.stderr and "tasks on" not in r.stderr
    assert elapsed < 60
    assert not list(tmp_path.glob("o*"))
