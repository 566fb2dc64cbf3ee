"""The ``codermind`` command line: one sub-command per module in :mod:`codermind.commands`.

User errors (bad files, bad parameters) are printed as one line
``codermind: error: ...`` and exit with status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import re
import sys

from . import commands
from .errors import CodermindError

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


def _command_modules():
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        if not info.name.startswith("_"):
            yield importlib.import_module(f"{commands.__name__}.{info.name}")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="codermind",
        description="The Codermind ray-tracing tutorial in Mitsuba 3, and its standalone port.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in _command_modules():
        p = sub.add_parser(module.NAME, help=module.HELP, description=module.__doc__)
        module.add_arguments(p)
        p.set_defaults(run=module.run)
    return parser


_PREFIX = re.compile(r"^\[[\w.]+:\d+\]\s*")
_UNREFERENCED = re.compile(
    r'While loading (?P<file>.+?) \(line (?P<line>\d+), col (?P<col>\d+)\): Found \d+ unreferenced '
    r'propert(?:y|ies) in (?P<kind>\w+) plugin of type "(?P<type>[^"]+)":\s*-\s*\w+ "(?P<name>[^"]+)"')


# A Python traceback that Mitsuba embeds when a Python plugin's constructor raises: keep
# only the exception line that follows it (e.g. "ValueError: tutorial: 'power' ...").
_TRACEBACK = re.compile(r"Traceback \(most recent call last\):\n(?:[ \t]+.*\n)*")


def one_line(message: str) -> str:
    """Condense a (possibly multi-line, Mitsuba-prefixed) error message into one line."""
    message = _TRACEBACK.sub("", str(message).strip())
    m = _UNREFERENCED.search(message)
    if m:
        return (f'{m["file"]}:{m["line"]}:{m["col"]}: unknown parameter "{m["name"]}" '
                f'for {m["kind"]} plugin "{m["type"]}"')
    lines = [_PREFIX.sub("", line).strip() for line in message.splitlines()]
    return "; ".join(line for line in lines if line)


#: Top-level modules of the ``harness`` extra (compare, chart, stability need them).
HARNESS_MODULES = ("matplotlib", "flip_evaluator")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except CodermindError as e:
        print(f"codermind: error: {one_line(str(e))}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("codermind: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ModuleNotFoundError as e:
        if e.name not in HARNESS_MODULES:
            raise
        print(f"codermind: error: this command needs {e.name}, from the package's 'harness' "
              f"extra: pip install 'codermind-mitsuba[harness]'", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
