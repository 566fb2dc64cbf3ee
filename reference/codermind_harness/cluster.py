"""``--cluster ADDRESS``: the fan-out of ``codermind reference``, ``compare``, ``chart`` and
``stability`` on a Dask ``distributed`` cluster instead of this machine's processes.

``ADDRESS`` is a scheduler (``tcp://host:8786``: a ``distributed.Client`` connects to it) or
``local:N`` (a ``LocalCluster`` of N single-threaded worker processes on 127.0.0.1). Without
the option nothing here runs and ``distributed`` is never imported (only :func:`open_cluster`
and the :class:`Cluster` it returns import it).

Units of work (each a Dask task; the client collects the results in order and alone writes the
outputs, atomically as without a cluster):

* the port: groups of consecutive tiles of sub-sample rows (:meth:`Cluster.tile_map`, given to
  ``codermind_ref.render``); the job (scene, cube-map faces, world) is scattered once per
  render; the client sums the tiles in tile order, so the image is bit-identical to a local
  render whatever the grouping, the cluster or the worker that ran a tile;
* the Mitsuba side of compare: one scene/grid/seed per task (:meth:`Cluster.render_mitsuba`);
  the converted XML travels as text with the files it names (:class:`Bundle`); each worker
  process sets its variant once and keeps its loaded scenes (keyed by the bundle's digest,
  the crop and the ``-D`` overrides);
* the chart: one point (one method at one setting, one repeat round) per task
  (:meth:`Cluster.run_calls`); a chart's ``MitsubaRunner`` pickles as its bundle and becomes a
  per-worker runner with its own scene cache;
* the stability sweeps: one point per task (``stability.Plan``: every sweep's points are
  submitted at once; the client assembles each sweep from its points' results).

No shared filesystem: everything a task reads travels with it (or is scattered). A worker that
dies mid-task has its task re-run by the scheduler; since a task's result depends only on its
inputs, the outputs are unchanged.
"""

from __future__ import annotations

import atexit
import contextlib
import copyreg
import hashlib
import os
import re
import shutil
import sys
import tempfile
import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np

from .sides import Grid, HarnessError, SideImage

#: Port tiles (of up to ``codermind_ref.driver.TILE_RAYS`` rays) per task: a page-4 tile
#: already costs several times a task's overhead (benchmarks/bench_cluster.py, docs/cluster.md).
TILES_PER_TASK = 2
_LOCAL = re.compile(r"local:(\d+)")
_REMOTE = re.compile(r"(tcp|tls|ucx)://[^\s/:]+:\d+")
CONNECT_TIMEOUT_S = 15


def _error_base():
    from codermind.errors import CodermindError
    return CodermindError


class ClusterError(HarnessError, _error_base()):
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


# -- inputs that travel ----------------------------------------------------------------------

#: ``<string name="..." value="FILE"/>`` values that name a file next to the XML (cube-map
#: faces, bitmaps, meshes) travel with the bundle.
_STRING = re.compile(r'(<string\s+name="[^"]+"\s+value=")([^"]+)(")')


@dataclass(frozen=True)
class Bundle:
    """A Mitsuba XML and the files it names, as bytes: what a worker needs to load it."""
    name: str                       #: the XML's file name
    text: str                       #: the XML, its file references renamed into ``inputs/``
    files: tuple                    #: ((relative name, bytes), ...)
    digest: str

    @classmethod
    def of(cls, xml: str | os.PathLike) -> "Bundle":
        xml = Path(xml)
        text = xml.read_text(encoding="utf-8")
        files: dict[Path, str] = {}

        def rename(m: re.Match) -> str:
            path = Path(m[2]) if Path(m[2]).is_absolute() else xml.parent / m[2]
            if not path.is_file():
                return m[0]
            key = path.resolve()
            if key not in files:
                files[key] = f"inputs/{len(files)}-{path.name}"
            return m[1] + files[key] + m[3]

        text = _STRING.sub(rename, text)
        payload = tuple((name, path.read_bytes()) for path, name in files.items())
        h = hashlib.sha256(text.encode())
        for name, data in payload:
            h.update(name.encode() + b"\0" + data)
        return cls(xml.name, text, payload, h.hexdigest())

    def materialize(self) -> Path:
        """The XML written (once per process) into a private folder of this machine."""
        path = _WORKER["folders"].get(self.digest)
        if path is None:
            folder = Path(tempfile.mkdtemp(prefix="codermind-cluster-"))
            atexit.register(shutil.rmtree, folder, True)
            for name, data in self.files:
                (folder / name).parent.mkdir(parents=True, exist_ok=True)
                (folder / name).write_bytes(data)
            path = folder / self.name
            path.write_text(self.text, encoding="utf-8")
            _WORKER["folders"][self.digest] = path
        return path


# -- what runs on a worker -------------------------------------------------------------------

#: Per worker process: materialized bundles, loaded Mitsuba scenes, chart runners.
_WORKER: dict = {"folders": {}, "scenes": {}, "runners": {}}


def _variant(name: str | None) -> None:
    """Set the Mitsuba variant in this process (once: a no-op when it is already set)."""
    import mitsuba as mi
    if name is None or mi.variant() != name:
        from codermind.variants import set_variant
        set_variant(name)
    import codermind  # noqa: F401  (registers the plugins)


def _identity(x):
    return x


def _trace_tiles(job, tiles) -> list:
    return [job.trace(tile) for tile in tiles]


def _mitsuba_task(bundle: Bundle, grid: Grid, spp: int, seed: int, exposure, defines: dict,
                  variance: bool, variant: str | None, exposure_seeds=(),
                  iid: bool = False) -> SideImage:
    """``sides.render_mitsuba`` on a worker, the loaded scene kept for the next task."""
    from codermind.tutorial.render import light_scenes, probe_exposure, render_linear
    from .sides import encode_mitsuba, load_mitsuba, mitsuba_dof
    t0 = time.perf_counter()
    _variant(variant)
    key = (bundle.digest, grid, tuple(sorted(defines.items())), variant, iid)
    if key not in _WORKER["scenes"]:
        scene, settings = load_mitsuba(bundle.materialize(), grid, dict(defines), iid)
        scenes = light_scenes(scene) if settings.lights == "sum" else scene
        _WORKER["scenes"][key] = (scenes, settings)
    scenes, settings = _WORKER["scenes"][key]
    t1 = time.perf_counter()
    mean, var, done, times = render_linear(scenes, spp, seed, variance=variance)
    t2 = time.perf_counter()
    exposures = None
    if settings.page == 4 and len(exposure_seeds):
        exposures = [probe_exposure(scenes, settings, int(s)) for s in exposure_seeds]
    linear = grid.take(mean.astype(np.float64))
    var = grid.take(var.astype(np.float64)) if var is not None else np.zeros_like(linear)
    return SideImage("mitsuba", linear, var, encode_mitsuba(linear, settings, exposure),
                     done, t2 - t0, t1 - t0, exposures, time.perf_counter() - t2,
                     mitsuba_dof(variance, times))


def _runner_on_worker(bundle: Bundle, width: int, height: int, page: int):
    """A chart ``MitsubaRunner`` unpickled on a worker: one per bundle and process."""
    from .chart import MitsubaRunner
    runner = _WORKER["runners"].get(bundle.digest)
    if runner is None:
        runner = MitsubaRunner(bundle.materialize(), width, height, page)
        _WORKER["runners"][bundle.digest] = runner
    return runner


def _call(fn: Callable):
    return fn()


# -- the client ------------------------------------------------------------------------------

class Cluster:
    """A connected ``distributed.Client`` with one progress line over every task submitted."""

    def __init__(self, address: str, progress: bool = True):
        kind, value = parse_address(address)
        import distributed
        self.address, self._cluster = address, None
        try:
            if kind == "local":
                self._cluster = distributed.LocalCluster(
                    n_workers=value, threads_per_worker=1, processes=True, host="127.0.0.1",
                    dashboard_address=None, silence_logs=40)
                self.client = distributed.Client(self._cluster)
            else:
                self.client = distributed.Client(value, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError) as e:
            self.close()
            raise ClusterError(f"--cluster {address}: cannot connect: {e}") from None
        self._lock = threading.Lock()
        self.submitted = self.done = 0
        self._bar = _bar("cluster") if progress else None
        self._bundles: dict = {}
        copyreg.pickle(_runner_class(), self._reduce_runner)

    def close(self) -> None:
        copyreg.dispatch_table.pop(_runner_class(), None)
        for part in ("client", "_cluster"):
            obj = getattr(self, part, None)
            if obj is not None:
                with contextlib.suppress(Exception):
                    obj.close()
                setattr(self, part, None)

    def __enter__(self) -> "Cluster":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

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

    @staticmethod
    def results(futures: list) -> Iterator:
        """The futures' results in order (a task's exception is raised here)."""
        for f in futures:
            yield f.result()
            f.release()

    def map(self, fn: Callable, items: Iterable) -> list:
        """[fn(item) for item in items], one task per item, results in order."""
        return list(self.results(self.submit_all(fn, [(item,) for item in items])))

    def run_calls(self, calls: list[Callable]) -> list:
        """Run zero-argument callables (chart points, closures pickled by value) as tasks."""
        return list(self.results(self.submit_all(_call, [(c,) for c in calls])))

    def share(self, obj):
        """A future of ``obj`` for the arguments of many tasks: sent to the cluster once (as
        the argument of a task that returns it, not by ``scatter``: data scattered to a worker
        that dies is gone, a task's result is computed again). Release it when done."""
        with warnings.catch_warnings():     # "Sending large graph": the job (cube faces)
            warnings.simplefilter("ignore", UserWarning)
            return self.client.submit(_identity, obj, pure=False)

    def tile_map(self, job, tiles: list, per_task: int = TILES_PER_TASK) -> Iterator:
        """``codermind_ref.render``'s ``tile_map``: the job sent once, groups of ``per_task``
        consecutive tiles per task, the tiles' results yielded in tile order (the job goes
        through :meth:`share`)."""
        shared = self.share(job)
        groups = [tiles[i:i + per_task] for i in range(0, len(tiles), per_task)]
        try:
            for group in self.results(self.submit_all(_trace_tiles,
                                                      [(shared, g) for g in groups])):
                yield from group
        finally:
            shared.release()

    def render_mitsuba(self, xml: Path, grid: Grid, spp: int, seed: int, exposure,
                       defines: dict | None = None, variance: bool = True,
                       variant: str | None = None, exposure_seeds=(),
                       iid: bool = False) -> SideImage:
        if variant is None:
            import mitsuba as mi
            variant = mi.variant()          # the client's, set by the command
        [f] = self.submit_all(_mitsuba_task, [(self.bundle(xml), grid, spp, seed, exposure,
                                               dict(defines or {}), variance, variant,
                                               tuple(exposure_seeds), iid)])
        return next(self.results([f]))

    def bundle(self, xml: Path) -> Bundle:
        path = Path(xml).resolve()
        key = (path, path.stat().st_mtime_ns)
        if key not in self._bundles:
            self._bundles[key] = Bundle.of(path)
        return self._bundles[key]

    def _reduce_runner(self, runner):
        return _runner_on_worker, (self.bundle(runner.xml), runner.width, runner.height,
                                   runner.page)


def _runner_class():
    from .chart import MitsubaRunner
    return MitsubaRunner


def _bar(label: str):
    from .progress import PortProgress      # the port's own progress line
    return PortProgress(label)


# -- the session's cluster -------------------------------------------------------------------

_CURRENT: Cluster | None = None


def current() -> Cluster | None:
    """The cluster of the running command (None: work runs on this machine)."""
    return _CURRENT


@contextlib.contextmanager
def open_cluster(address: str | None, progress: bool = True) -> Iterator[Cluster | None]:
    """The cluster of ``address`` for the duration of a command (None: no cluster, nothing
    imported)."""
    global _CURRENT
    if address is None:
        yield None
        return
    cluster = Cluster(address, progress)
    _CURRENT = cluster
    try:
        yield cluster
    finally:
        _CURRENT = None
        cluster.close()
        if progress and cluster.submitted:
            print(f"cluster: {cluster.done}/{cluster.submitted} tasks on {address}",
                  file=sys.stderr, flush=True)
