"""SIGINT (Ctrl-C) and SIGTERM (``timeout``, batch schedulers, containers) mean the same to
every command: stop, say so in one line, exit with status 130.

:func:`installed` makes both raise ``KeyboardInterrupt`` and remembers that one arrived, so that
:mod:`codermind_cli.main` reports an interrupt even where Mitsuba or Dr.Jit turned it into
another error on the way out (a plugin constructor interrupted while the scene loads fails
the load with a message blaming the scene). :func:`stop_requests` lets a render finish its
current pass first; :func:`deferred` holds both signals while an output set is committed or
rolled back, steps that must not be cut in the middle.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from typing import Callable, Iterator

SIGNALS = (signal.SIGINT, signal.SIGTERM)

_received: list[int] = []


class Interrupted(KeyboardInterrupt):
    """An interrupt with what it left behind, e.g. "nothing written, the previous run.* kept"."""


def _raise(signum: int, frame) -> None:
    _received.append(signum)
    raise KeyboardInterrupt


@contextlib.contextmanager
def _handled_by(handler: Callable) -> Iterator[None]:
    """SIGINT and SIGTERM go to ``handler`` in the body; the previous handlers come back."""
    previous = {s: signal.signal(s, handler) for s in SIGNALS}
    try:
        yield
    finally:
        for s, old in previous.items():
            signal.signal(s, old)


@contextlib.contextmanager
def installed() -> Iterator[None]:
    """SIGINT and SIGTERM raise KeyboardInterrupt in the body (main's first step); the
    previous handlers come back after it, for callers of main() in a longer process."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _received.clear()
    with _handled_by(_raise):
        yield


def received() -> int | None:
    """The last signal that arrived since :func:`installed`, or None."""
    return _received[-1] if _received else None


def describe(signum: int | None) -> str:
    return "SIGTERM" if signum == signal.SIGTERM else "Ctrl-C"


@contextlib.contextmanager
def stop_requests(what: str = "stopping after the current pass") -> Iterator[Callable[[], bool]]:
    """Yield ``should_stop()``: the first signal only sets it (and says so in one line), a
    second one raises KeyboardInterrupt."""
    requested: list[int] = []

    def on_signal(signum: int, frame) -> None:
        _received.append(signum)
        if requested:
            raise KeyboardInterrupt
        requested.append(signum)
        print(f"\ncodermind: {describe(signum)}: {what} (again to abort without writing)",
              file=sys.stderr, flush=True)

    with _handled_by(on_signal):
        yield lambda: bool(requested)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM for the body; one that arrived is raised (as
    KeyboardInterrupt) when the body has finished."""
    if threading.current_thread() is not threading.main_thread():
        yield                 # signals reach the main thread only
        return
    pending: list[int] = []

    def hold(signum: int, frame) -> None:
        _received.append(signum)
        pending.append(signum)

    with _handled_by(hold):
        yield
    if pending:
        raise KeyboardInterrupt


@contextlib.contextmanager
def spared_children() -> Iterator[None]:
    """Processes started in the body (a local Dask cluster's workers) ignore SIGINT: a Ctrl-C
    reaches the whole process group, and each worker would print its tracebacks; this
    process stops them when it stops. Only an ignored disposition survives the workers'
    exec, so a Ctrl-C while they start (the body, about a second) is ignored here too."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
