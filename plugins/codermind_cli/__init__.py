"""The ``codermind`` command line, the top layer: it imports the harness
(:mod:`codermind_harness`), the plugins (:mod:`codermind`) and the port
(:mod:`codermind_ref`); none of them imports it. One module per sub-command in
:mod:`codermind_cli.commands`; :mod:`codermind_cli.args` holds the argument types they share.
"""
