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
