"""The ``codermind`` command line, the top layer: it imports the harness
(:mod:`codermind_harness`), the plugins (:mod:`codermind`) and the port
(:mod:`codermind_ref`); none of them imports it. One module per sub-command in
:mod:`codermind_cli.commands`; :mod:`codermind_cli.args` holds the argument types they share.
"""

import os as _os
import signal as _signal
import sys as _sys


def _interrupted_early(signum: int, frame) -> None:
    """SIGINT or SIGTERM before :func:`codermind_cli.main.main` installs its handlers: nothing
    has been started or written yet, so say so in main's one line and leave at once."""
    _os.write(2, b"codermind: interrupted\n")
    _os._exit(130)


# Only when this package is the program (the ``codermind`` script, ``python -m
# codermind_cli``), never for a process that merely imports it.
if _os.path.basename(_sys.argv[0]) == "codermind" or _sys.argv[0] == "-m":
    for _s in (_signal.SIGINT, _signal.SIGTERM):
        _signal.signal(_s, _interrupted_early)
