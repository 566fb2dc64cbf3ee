"""Progress line of a port render, shared by ``codermind reference`` and the harness."""

from __future__ import annotations

import sys
import time


class PortProgress:
    """The port's progress line (``progress=`` of :func:`codermind_ref.render`, called with
    tiles done and total): a bar with ETA on a terminal, a line every 5 s otherwise."""

    def __init__(self, label: str):
        self.label, self.start, self.last = label, time.monotonic(), -1.0
        self.tty = sys.stderr.isatty()

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if done < total and now - self.last < (0.2 if self.tty else 5.0):
            return
        self.last = now
        elapsed = now - self.start
        eta = elapsed * (total - done) / done if done else 0.0
        bar = "#" * (30 * done // total)
        line = f"{self.label}: [{bar:<30}] {100 * done // total:3d}% {elapsed:5.1f}s ETA {eta:5.1f}s"
        print(("\r" if self.tty else "") + line, end="" if self.tty and done < total else "\n",
              file=sys.stderr, flush=True)
