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
depends only on its inputs, the outputs are unchanged. With no worker left, the client waits
``CODERMIND_CLUSTER_WAIT`` seconds (default :data:`NO_WORKER_WAIT_S`) for one to join, then
stops in one line; a lost scheduler is one line too (:class:`ClusterError`), and
``distributed``'s own log lines are kept off the terminal while the cluster is open.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import re
import sys
import threading
import time
import warnings
from concurrent.futures import CancelledError
from typing import Callable, Iterable, Iterator

from codermind.errors import CodermindError

from .progress import PortProgress
from .runner import RemoteRunner, Runner
from .sides import HarnessError

_LOCAL = re.compile(r"local:(\d+)")
_REMOTE = re.compile(r"(tcp|tls|ucx)://[^\s/:]+:\d+")
CONNECT_TIMEOUT_S = 15
#: Seconds the client waits, with no worker on the cluster, before it gives up.
NO_WORKER_WAIT_S = 60.0
WAIT_ENV = "CODERMIND_CLUSTER_WAIT"
#: Seconds between looks at the cluster while a task's result is awaited.
_POLL_S = 1.0


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


def no_worker_wait() -> float:
    """Seconds to wait for a worker when none is left (``CODERMIND_CLUSTER_WAIT``)."""
    text = os.environ.get(WAIT_ENV)
    if not text:
        return NO_WORKER_WAIT_S
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 < value < math.inf:
        raise ClusterError(f"{WAIT_ENV}={text!r}: expected a number of seconds > 0")
    return value


def _lost_scheduler(error: BaseException) -> bool:
    """Whether a result's exception is the connection to the scheduler failing, not the
    task's own error (which the worker raised and the client re-raises as it was)."""
    from distributed.comm.core import CommClosedError
    return isinstance(error, (CommClosedError, CancelledError, ConnectionError))


class Cluster(RemoteRunner):
    """A connected ``distributed.Client`` with one progress line over every task submitted."""

    def __init__(self, address: str, progress: bool = True,
                 allow: Iterable[str | os.PathLike] = ()):
        super().__init__(allow)
        kind, value = parse_address(address)
        self.wait = no_worker_wait()
        import distributed      # heavy and optional (the cluster extra): only with --cluster
        self.address, self._cluster = address, None
        self.failed = False     #: the cluster failed (lost scheduler, no worker): no summary
        self._quiet = _Quiet()
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
        except BaseException:
            self.close()
            raise
        self._lock = threading.Lock()
        self.submitted = self.done = 0
        self._bar = PortProgress("cluster") if progress else None

    def close(self) -> None:
        for part in ("client", "_cluster"):
            obj = getattr(self, part, None)
            if obj is not None:
                with contextlib.suppress(Exception):
                    obj.close(timeout=5) if part == "client" else obj.close()
                setattr(self, part, None)
        quiet = getattr(self, "_quiet", None)
        if quiet is not None and not getattr(self, "failed", False):
            quiet.restore()

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

    def _finished(self, future) -> None:
        if future.status != "finished":     # cancelled or lost: not progress
            return
        with self._lock:
            self.done += 1
            if self._bar and not self.failed:
                self._bar(self.done, self.submitted)

    def submit_all(self, fn: Callable, calls: Iterable[tuple]) -> list:
        return self._count([self.client.submit(fn, *args, pure=False) for args in calls])

    def results(self, handles: list) -> Iterator:
        for f in handles:
            yield self._result(f)
            f.release()

    def _result(self, future):
        """``future``'s result; ClusterError (one line) when the scheduler is lost or no worker
        is left for ``self.wait`` seconds. A task's own exception is raised as it is."""
        alone_since = None
        while True:
            try:
                return future.result(timeout=_POLL_S)
            except TimeoutError:
                pass
            except Exception as e:
                if future.status == "error" or not _lost_scheduler(e):
                    raise
                self._fail(f"lost the scheduler ({self._tally()})")
            try:
                workers = self.workers
            except Exception:               # the scheduler does not answer
                self._fail(f"lost the scheduler ({self._tally()})")
            if workers:
                alone_since = None
                continue
            now = time.monotonic()
            if alone_since is None:
                alone_since = now
                print(f"cluster: no worker on {self.address}; waiting up to {self.wait:g} s for "
                      f"one ({WAIT_ENV})", file=sys.stderr, flush=True)
            elif now - alone_since >= self.wait:
                self._fail(f"no worker left for {self.wait:g} s ({self._tally()})")

    def _tally(self) -> str:
        return f"{self.done}/{self.submitted} tasks done"

    def _fail(self, what: str):
        self.failed = True
        raise ClusterError(f"--cluster {self.address}: {what}")

    def share(self, obj):
        """A future of ``obj`` for the arguments of many tasks: sent to the cluster once (as
        the argument of a task that returns it, not by ``scatter``: data scattered to a worker
        that dies is gone, a task's result is computed again). Release it when done."""
        with warnings.catch_warnings():     # "Sending large graph": the job (cube faces)
            warnings.simplefilter("ignore", UserWarning)
            return self.client.submit(_identity, obj, pure=False)

    def release(self, shared) -> None:
        shared.release()


class _Quiet:
    """``distributed``'s loggers held above CRITICAL while a cluster is open, and for the rest
    of the process once it failed (the client's reconnect loop logs on after ``close``): a
    lost scheduler or worker is reported by the command in one line, not by log records."""

    ROOTS = ("distributed", "tornado", "asyncio")

    def __init__(self) -> None:
        names = [n for n in logging.root.manager.loggerDict
                 if n.split(".")[0] in self.ROOTS] + list(self.ROOTS)
        self.levels = {n: logging.getLogger(n).level for n in set(names)}
        for n in self.levels:
            logging.getLogger(n).setLevel(logging.CRITICAL + 1)

    def restore(self) -> None:
        for n, level in self.levels.items():
            logging.getLogger(n).setLevel(level)
        self.levels = {}


@contextlib.contextmanager
def open_runner(address: str | None, progress: bool = True,
                allow: Iterable[str | os.PathLike] = ()) -> Iterator[Runner]:
    """The runner of a command's ``--cluster``: ``address``'s :class:`Cluster` for the
    duration of the command, or this process's :class:`Runner` (None: nothing imported).
    ``allow``: folders besides each scene's own whose files may travel to the workers."""
    if address is None:
        yield Runner()
        return
    cluster = Cluster(address, progress, allow)
    try:
        yield cluster
    finally:
        cluster.close()
        if progress and cluster.submitted and not cluster.failed:
            print(f"cluster: {cluster.done}/{cluster.submitted} tasks on {address}",
                  file=sys.stderr, flush=True)
