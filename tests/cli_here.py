"""The ``labkit`` command line run by its ``main`` in the test's own process.

A process of its own costs seconds of imports per call; tests that check what a command computes and
says use this, and what only a process shows (Ctrl-C, pipes, the installed script, another user or
folder) is tested with real processes.
"""

from __future__ import annotations

import contextlib
import io
import subprocess
import warnings


def in_process(*args) -> subprocess.CompletedProcess:
    """``labkit -q ARGS``: the exit status and what it printed, with Python's default warning filters (as
    in a process of its own; the test run turns warnings into errors)."""
    from labkit.app.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        warnings.simplefilter("default")
        try:
            code = main(["-q", *map(str, args)])
        except SystemExit as exc:  # argparse refusing the command line
            code = exc.code if isinstance(exc.code, int) else 2
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())
