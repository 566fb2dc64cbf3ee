"""The ``codermind`` command line: one sub-command per module in :mod:`codermind_cli.commands`.

User errors (bad files, bad parameters) are printed as one line
``codermind: error: ...`` and exit with status 2, without a traceback. SIGINT and SIGTERM
(:mod:`codermind_cli.signals`) print one line ``codermind: interrupted`` and exit with status
130, whatever the command was doing.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from . import commands, signals

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


def _command_modules():
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        if not info.name.startswith("_"):
            yield importlib.import_module(f"{commands.__name__}.{info.name}")


class _Parser(argparse.ArgumentParser):
    """Usage errors on one line, as every other error of the command line (exit status 2)."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="codermind",
        description="The Codermind ray-tracing tutorial in Mitsuba 3, and its standalone port.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in _command_modules():
        p = sub.add_parser(module.NAME, help=module.HELP, description=module.__doc__)
        module.add_arguments(p)
        p.set_defaults(run=module.run)
    return parser


#: Top-level modules of the ``harness`` extra (compare, chart, stability need them).
HARNESS_MODULES = ("matplotlib", "flip_evaluator")


def main(argv: list[str] | None = None) -> int:
    with signals.installed():   # first: an interrupt while Mitsuba imports is one line too
        try:
            return _run(argv)
        except BaseException as e:
            # Mitsuba and Dr.Jit may turn an interrupt into another error on its way out (a
            # plugin interrupted while the scene loads fails the load): a signal decides.
            if not (isinstance(e, KeyboardInterrupt) or signals.received() is not None):
                raise
            detail = f": {e}" if isinstance(e, signals.Interrupted) and str(e) else ""
            print(f"codermind: interrupted{detail}", file=sys.stderr)
            return EXIT_INTERRUPTED


def _run(argv: list[str] | None) -> int:
    from codermind.errors import CodermindError, one_line
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except CodermindError as e:
        print(f"codermind: error: {one_line(str(e))}", file=sys.stderr)
        return EXIT_USAGE
    except ModuleNotFoundError as e:
        if e.name not in HARNESS_MODULES:
            raise
        print(f"codermind: error: this command needs {e.name}, from the package's 'harness' "
              f"extra: pip install 'codermind-mitsuba[harness]'", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
