"""Our own corpus of hostile inputs (``tests/cli/hostile/``: each file's first line says what
it attacks): non-finite and absurd numbers, huge sizes, broken syntax, undecodable bytes,
files outside the scene, an XML entity bomb. Every command that reads them (``reference``,
``convert``, then ``render`` of what ``convert`` wrote; ``render`` of the XML files) must
end within a minute with exit 0 or 2, print no traceback, print exactly one error line when
it refuses, and leave either a whole output set or none. Evidence: the commands' own
behaviour; nothing is compared."""

from __future__ import annotations

import contextlib
import io
import json
import signal
from pathlib import Path

import pytest

from codermind_cli.main import main
from codermind_cli.outputs import check_set

CORPUS = Path(__file__).parent / "hostile"
FILES = sorted(p for p in CORPUS.iterdir() if p.suffix in (".txt", ".xml"))
#: Seconds a command may take on any of these files.
LIMIT_S = 60


class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang()


def run(*argv) -> tuple[int, str]:
    """``codermind ARGV`` in this process: (exit status, standard error)."""
    err = io.StringIO()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(LIMIT_S)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                rc = main([str(a) for a in argv])
            except SystemExit as e:     # argparse
                rc = e.code
    except Hang:
        pytest.fail(f"codermind {' '.join(map(str, argv))} ran past {LIMIT_S} s")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return rc, err.getvalue()


def check_ending(rc: int, err: str, argv: str) -> None:
    assert rc in (0, 2), f"{argv}: exit {rc}\n{err}"
    assert "Traceback" not in err, f"{argv}\n{err}"
    errors = [ln for ln in err.splitlines() if ln.startswith("codermind: error:")]
    if rc == 2:
        assert len(errors) == 1, f"{argv}: {len(errors)} error lines\n{err}"
        assert "see above" not in errors[0], err
    else:
        assert not errors, err


def check_outputs(base: Path, rc: int) -> None:
    """Exit 0: a whole set at ``base`` (its manifest's files, hashes included); otherwise
    nothing. Never a temporary file."""
    left = sorted(p.name for p in base.parent.iterdir())
    assert not [n for n in left if n.startswith(".")], left
    if rc == 0:
        assert check_set(base) == [], left
    else:
        assert left == [], left


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_a_hostile_input_is_refused_in_one_line_or_handled(path, tmp_path):
    runs = []
    if path.suffix == ".txt":
        (tmp_path / "ref").mkdir()
        runs.append(("reference", path, "-o", tmp_path / "ref" / "out"))
        xml = tmp_path / "conv" / "out.xml"
        xml.parent.mkdir()
        rc, err = run("convert", path, "-o", xml)
        check_ending(rc, err, f"convert {path.name}")
        if path.stem.startswith("valid"):
            assert rc == 0, err
        if rc == 0:
            (tmp_path / "render").mkdir()
            runs.append(("render", xml, "-o", tmp_path / "render" / "out", "--spp", "2"))
    else:
        (tmp_path / "render").mkdir()
        runs.append(("render", path, "-o", tmp_path / "render" / "out", "--spp", "2"))
    for argv in runs:
        rc, err = run(*argv)
        check_ending(rc, err, f"{argv[0]} {path.name}")
        check_outputs(Path(argv[3]), rc)
        if path.stem.startswith("valid"):       # the baselines must not merely be refused
            assert rc == 0, err
