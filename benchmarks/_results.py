"""Writes the generated sections of the pages in docs/results/ (not a benchmark itself).

A results page is a short hand-written introduction (what is measured, what kind of
evidence it is) followed by one or more generated sections, each between the markers

    <!-- begin SCRIPT SECTION -->
    ...
    <!-- end SCRIPT SECTION -->

and each opened by the same lines: the command that regenerates it, the date, the machine
and the commit it ran on. A benchmark calls :func:`write` with its section's Markdown; the
section is replaced in place (or appended to the page), the rest of the page is kept.

Every benchmark that feeds a page takes ``--write-results [PATH]`` (:func:`add_argument`):
without PATH it writes its page in docs/results/, with PATH a copy (a quick run checks the
writer without touching the page).

Benchmarks import this module as ``import _results``: a script's own folder is the first
entry of ``sys.path`` when Python runs it, so nothing is added to the path.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import os
import platform
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
TUTORIAL = Path(os.environ.get("CODERMIND_TUTORIAL", ROOT.parent / "shared" / "tutorial"))

_STARTED = time.time()
_LOAD = os.getloadavg()[0] if hasattr(os, "getloadavg") else None


def add_argument(parser: argparse.ArgumentParser, page: str) -> None:
    """``--write-results [PATH]``: write the section into docs/results/PAGE (or into PATH)."""
    parser.add_argument("--write-results", nargs="?", const=str(RESULTS / page), default=None,
                        metavar="PATH",
                        help=f"write the results into docs/results/{page} (or into PATH, "
                             "a copy of that page)")


def machine() -> str:
    """A short machine line: CPU model and logical cores."""
    model = ""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
        model = next((line.split(":", 1)[1].strip() for line in out.splitlines()
                      if line.startswith("Model name")), "")
    except OSError:
        pass
    model = model or platform.processor() or platform.machine()
    return f"{model}, {os.cpu_count()} cores"


def commit() -> str:
    """The checkout's commit, marked when the code that measures (plugins/, reference/,
    benchmarks/, scenes/) has uncommitted changes."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True,
                              check=False).stdout.strip()
    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + (" with uncommitted changes" if git("status", "--porcelain", "--untracked-files=no", "--", "plugins", "reference",
                   "benchmarks", "scenes")
                   else "")


def command(argv: list[str] | None = None) -> str:
    """The command line that ran this benchmark, as a reader would type it."""
    argv = sys.argv if argv is None else argv
    script = Path(argv[0])
    try:
        script = script.resolve().relative_to(ROOT)
    except ValueError:
        pass
    args = [a for a in argv[1:]]
    # a temporary PATH after --write-results is not part of the command that makes the page
    for i, a in enumerate(args):
        if a == "--write-results" and i + 1 < len(args) and not args[i + 1].startswith("-"):
            del args[i + 1]
            break
        if a.startswith("--write-results="):
            args[i] = "--write-results"
            break
    return " ".join(["python", script.as_posix(), *map(shlex.quote, args)])


def header(cmd: str, seconds: float | None = None) -> str:
    """The lines that open a generated section."""
    date = datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    wall = "" if seconds is None else f"; wall time {_duration(seconds)}"
    load = "" if _LOAD is None else f" (load average {_LOAD:.1f} at the start)"
    return (f"Command: `{cmd}`\n\n"
            f"Date: {date}; machine: {machine()}{load}; commit {commit()}{wall}\n")


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def section_text(script: str, name: str, body: str, cmd: str, seconds: float | None) -> str:
    return (f"<!-- begin {script} {name} -->\n"
            + header(cmd, seconds) + "\n" + body.strip("\n") + "\n"
            + f"<!-- end {script} {name} -->\n")


def write(path: str | Path, body: str, *, section: str = "results", title: str = "",
          cmd: str | None = None, seconds: float | None = None,
          script: str | None = None) -> Path:
    """Replace (or append) this script's section ``section`` of the page at ``path``.

    ``body`` is the section's Markdown (its own ``##`` heading first, if it has one);
    ``title`` is the page's heading when the page does not exist yet. A PATH outside
    docs/results starts as a copy of the page of the same name there."""
    path = Path(path)
    script = script or Path(sys.argv[0]).name
    cmd = cmd or command()
    seconds = time.time() - _STARTED if seconds is None else seconds
    if path.exists():
        text = path.read_text(encoding="utf-8")
    elif (RESULTS / path.name).exists():
        text = (RESULTS / path.name).read_text(encoding="utf-8")
    else:
        text = f"# {title or path.stem}\n"
    block = section_text(script, section, body, cmd, seconds)
    pattern = re.compile(rf"<!-- begin {re.escape(script)} {re.escape(section)} -->\n.*?"
                         rf"<!-- end {re.escape(script)} {re.escape(section)} -->\n", re.S)
    if pattern.search(text):
        text = pattern.sub(lambda _: block, text, count=1)
    else:
        text = text.rstrip("\n") + "\n\n" + block
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    print(f"wrote {path}", file=sys.stderr)
    return path


def table(head: list[str], rows: list[list]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(head) + " |", "| " + " | ".join("---" for _ in head) + " |"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def tests_module(name: str):
    """A helper module of the tests, ``support.NAME`` (tests/support/NAME.py): the package
    ``support`` is loaded from its folder, since benchmarks do not put tests/ on
    ``sys.path``."""
    if "support" not in sys.modules:
        init = ROOT / "tests" / "support" / "__init__.py"
        spec = importlib.util.spec_from_file_location(
            "support", init, submodule_search_locations=[str(init.parent)])
        package = importlib.util.module_from_spec(spec)
        sys.modules["support"] = package        # dataclasses look their module up there
        spec.loader.exec_module(package)
    return importlib.import_module(f"support.{name}")
