"""Where the harness's units of work run: the one object through which ``compare``,
``chart``, ``stability`` and ``reference`` fan out, built by the command line from its
options and handed down (nothing reads it from a global).

* :class:`Runner`: here, in this process, one unit after another (the default);
* :class:`PoolRunner`: N local worker processes;
* :class:`codermind_harness.cluster.Cluster`: a Dask cluster (``--cluster ADDRESS``).

Units: the port's tiles (:meth:`RemoteRunner.tile_map`), the Mitsuba side of a compare
(``sides.render_mitsuba``), a chart point, a stability sweep point. A unit's result depends
only on its inputs, so the outputs do not depend on the runner (tests/harness/test_runner.py,
tests/harness/test_cluster.py). A runner that is not :class:`Runner` itself pickles what it sends
(module-level functions, picklable arguments) and runs its units together.
"""

from __future__ import annotations

import functools
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

from .bundle import Bundle, check_inside, roots

#: Port tiles (of up to ``codermind_ref.driver.TILE_RAYS`` rays) per task: a page-4 tile
#: already costs several times a task's overhead (benchmarks/bench_cluster.py, docs/cluster.md).
TILES_PER_TASK = 2


def _call(fn: Callable) -> Any:
    return fn()


def _trace_tiles(job, tiles) -> list:
    return [job.trace(tile) for tile in tiles]


class Runner:
    """Runs every unit here, in this process, in order, when its result is asked for."""

    #: where the units run (chart.json's ``cluster``); None: this process
    address: str | None = None
    #: whether units leave this process (pickled) and run together
    remote: bool = False
    #: ``codermind_ref.render``'s ``tile_map`` (None: the port's own worker processes)
    tile_map: Callable | None = None

    def submit_all(self, fn: Callable, calls: Iterable[tuple]) -> list:
        """Start ``fn(*args)`` for each ``args``; handles for :meth:`results`."""
        return [functools.partial(fn, *args) for args in calls]

    def results(self, handles: list) -> Iterator:
        """The handles' results in order (a unit's exception is raised here)."""
        for h in handles:
            yield h()

    def map(self, fn: Callable, items: Iterable) -> Iterator:
        """fn(item) for each item, results in order."""
        return self.results(self.submit_all(fn, [(item,) for item in items]))

    def call(self, fn: Callable, *args) -> Any:
        """``fn(*args)`` as one unit."""
        return next(self.results(self.submit_all(fn, [args])))

    def run_calls(self, calls: list[Callable]) -> Iterator:
        """Zero-argument callables (chart points) as units, results in order."""
        return self.map(_call, calls)

    def ship(self, xml: str | os.PathLike) -> Path | Bundle:
        """What a unit receives for the Mitsuba XML ``xml``: the path here."""
        return Path(xml)

    def close(self) -> None:
        pass

    def __enter__(self) -> "Runner":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


#: The default: this process.
LOCAL = Runner()


class RemoteRunner(Runner):
    """Units in other processes: the XML travels as a :class:`Bundle`, the port's tiles in
    groups of consecutive tiles (the image is bit-identical whatever the grouping)."""

    remote = True

    def __init__(self, allow: Iterable[str | os.PathLike] = ()) -> None:
        self._bundles: dict = {}
        #: folders besides a scene's own whose files may travel (``--allow-files``)
        self.allow = tuple(allow)

    def share(self, obj):
        """``obj`` for the arguments of many units (here: sent with each)."""
        return obj

    def release(self, shared) -> None:
        pass

    def tile_map(self, job, tiles: list, per_task: int = TILES_PER_TASK) -> Iterator:
        """``codermind_ref.render``'s ``tile_map``: the job shared once, groups of
        ``per_task`` consecutive tiles per unit, the tiles' results in tile order. The job's
        cube-map faces must lie inside the scene's folder or :attr:`allow`."""
        scene = job.scene
        allowed = roots(Path(scene.path).parent, self.allow)
        for face, path in scene.cubemap.paths.items():
            line = scene.line_of("Scene", f"Cubemap.{face}")
            check_inside(path, allowed, f"{scene.path}:{line}")
        shared = self.share(job)
        groups = [tiles[i:i + per_task] for i in range(0, len(tiles), per_task)]
        try:
            for group in self.results(self.submit_all(_trace_tiles,
                                                      [(shared, g) for g in groups])):
                yield from group
        finally:
            self.release(shared)

    def ship(self, xml: str | os.PathLike) -> Bundle:
        path = Path(xml).resolve()
        key = (path, path.stat().st_mtime_ns)
        if key not in self._bundles:
            self._bundles[key] = Bundle.of(path, self.allow)
        return self._bundles[key]


class PoolRunner(RemoteRunner):
    """``workers`` local processes (started fresh: a fork would copy Dr.Jit's threads)."""

    def __init__(self, workers: int, allow: Iterable[str | os.PathLike] = ()) -> None:
        super().__init__(allow)
        self.address = f"pool:{workers}"
        self._pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))

    def submit_all(self, fn: Callable, calls: Iterable[tuple]) -> list:
        return [self._pool.submit(fn, *args) for args in calls]

    def results(self, handles: list) -> Iterator:
        for f in handles:
            yield f.result()

    def close(self) -> None:
        self._pool.shutdown(cancel_futures=True)
