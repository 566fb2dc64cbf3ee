"""``--cluster ADDRESS``: the fan-out of ``codermind reference``, ``compare``, ``chart`` and
``stability`` on a Dask ``distributed`` cluster instead of this machine's processes.

``ADDRESS`` is a scheduler (``tcp://host:8786``: a ``distributed.Client`` connects to it) or
``local:N`` (a ``LocalCluster`` of N single-threaded worker processes on 127.0.0.1). Without
the option :func:`open_runner` gives the in-process :class:`~codermind_harness.runner.Runner`
and ``distributed`` is never imported (only :class:`Cluster` imports it).

:class:`Cluster` is a :class:`~codermind_harness.runner.RemoteRunner`: each unit of work is a
Dask task; the client collects the results in order and alone writes the outputs, atomically
as without a cluster:

* the port: groups of consecutive tiles of sub-sample rows (``tile_map``, given to
  ``codermind_ref.render``); the job (scene, cube-map faces, world) is sent once per render
  (:meth:`Cluster.share`); the client sums the tiles in tile order, so the image is
  bit-identical to a local render whatever the grouping, the cluster or the worker that ran
  a tile;
* the Mitsuba side of compare: one scene/grid/seed per task (``sides.render_mitsuba``); the
  XML travels as a :class:`~codermind_harness.bundle.Bundle`; each worker process sets its
  variant once and keeps its loaded scenes;
* the chart: one point per task; a chart's ``MitsubaRunner`` pickles as its bundle and
  becomes a per-worker runner with its own scene cache;
* the stability sweeps: one point per task (``stability.Plan``: every sweep's points are
  submitted at once; the client assembles each sweep from its points' results).

A worker that dies mid-task has its task re-run by the scheduler; since a task's result
depends only on its inputs, the outputs are unchanged.
"""

from __future__ import annotations

import contextlib
import re
import sys
import threading
import warnings
from typing import Callable, Iterable, Iterator

from codermind.errors import CodermindError

from .progress import PortProgress
from .runner import RemoteRunner, Runner
from .sides import HarnessError

_LOCAL = re.compile(r"local:(\d+)")
_REMOTE = re.compile(r"(tcp|tls|ucx)://[^\s/:]+:\d+")
CONNECT_TIMEOUT_S = 15


class ClusterError(HarnessError, CodermindError):
    """A bad ``--cluster`` value or an unreachable scheduler: one line, exit 2, in every
    command (the CLI prints CodermindError, compare and chart HarnessError)."""


def parse_address(text: str) -> tuple[str, str | int]:
    """("local", N) or ("remote", address); HarnessError (one line) for anything else."""
    m = _LOCAL.fullmatch(text.strip())
    if m:
        n = int(m[1])
        if not 1 <= n <= 256:
            raise ClusterError(f"--cluster {text}: local:N needs 1 <= N <= 256")
        return "local", n
    if _REMOTE.fullmatch(text.strip()):
        return "remote", text.strip()
    raise ClusterError(f"--cluster {text!r}: expected a scheduler address tcp://HOST:PORT or "
                       "local:N (N worker processes)")


def _connect(distributed, address: str, value: str):
    """``distributed.Client(value)`` within CONNECT_TIMEOUT_S whatever the endpoint does:
    the Client's own timeout does not hold for an address that accepts TCP connections and
    never answers (it waits in the handshake for minutes), so the connection is made in a
    daemon thread given the same time; past it, one line."""
    box: dict = {}

    def connect():
        try:
            box["client"] = distributed.Client(value, timeout=CONNECT_TIMEOUT_S)
        except BaseException as e:      # handed to the caller's thread
            box["error"] = e

    thread = threading.Thread(target=connect, name="cluster-connect", daemon=True)
    thread.start()
    thread.join(CONNECT_TIMEOUT_S)
    if thread.is_alive():
        raise ClusterError(f"--cluster {address}: no answer from the scheduler within "
                           f"{CONNECT_TIMEOUT_S} s (something accepts connections there, but "
                           "not a Dask scheduler that responds)")
    if "error" in box:
        raise box["error"]
    return box["client"]


def _identity(x):
    return x


class Cluster(RemoteRunner):
    """A connected ``distributed.Client`` with one progress line over every task submitted."""

    def __init__(self, address: str, progress: bool = True):
        super().__init__()
        kind, value = parse_address(address)
        import distributed      # heavy and optional (the cluster extra): only with --cluster
        self.address, self._cluster = address, None
        try:
            if kind == "local":
                self._cluster = distributed.LocalCluster(
                    n_workers=value, threads_per_worker=1, processes=True, host="127.0.0.1",
                    dashboard_address=None, silence_logs=40)
                self.client = distributed.Client(self._cluster)
            else:
                self.client = _connect(distributed, address, value)
        except (OSError, TimeoutError) as e:
            self.close()
            raise ClusterError(f"--cluster {address}: cannot connect: {e}") from None
        self._lock = threading.Lock()
        self.submitted = self.done = 0
        self._bar = PortProgress("cluster") if progress else None

    def close(self) -> None:
        for part in ("client", "_cluster"):
            obj = getattr(self, part, None)
            if obj is not None:
                with contextlib.suppress(Exception):
                    obj.close()
                setattr(self, part, None)

    @property
    def workers(self) -> int:
        return len(self.client.scheduler_info().get("workers", {}))

    # the one progress line
    def _count(self, futures: list) -> list:
        with self._lock:
            self.submitted += len(futures)
        for f in futures:
            f.add_done_callback(self._finished)
        return futures

    def _finished(self, _future) -> None:
        with self._lock:
            self.done += 1
            if self._bar:
                self._bar(self.done, self.submitted)

    def submit_all(self, fn: Callable, calls: Iterable[tuple]) -> list:
        return self._count([self.client.submit(fn, *args, pure=False) for args in calls])

    def results(self, handles: list) -> Iterator:
        for f in handles:
            yield f.result()
            f.release()

    def share(self, obj):
        """A future of ``obj`` for the arguments of many tasks: sent to the cluster once (as
        the argument of a task that returns it, not by ``scatter``: data scattered to a worker
        that dies is gone, a task's result is computed again). Release it when done."""
        with warnings.catch_warnings():     # "Sending large graph": the job (cube faces)
            warnings.simplefilter("ignore", UserWarning)
            return self.client.submit(_identity, obj, pure=False)

    def release(self, shared) -> None:
        shared.release()


@contextlib.contextmanager
def open_runner(address: str | None, progress: bool = True) -> Iterator[Runner]:
    """The runner of a command's ``--cluster``: ``address``'s :class:`Cluster` for the
    duration of the command, or this process's :class:`Runner` (None: nothing imported)."""
    if address is None:
        yield Runner()
        return
    cluster = Cluster(address, progress)
    try:
        yield cluster
    finally:
        cluster.close()
        if progress and cluster.submitted:
            print(f"cluster: {cluster.done}/{cluster.submitted} tasks on {address}",
                  file=sys.stderr, flush=True)
