"""``labkit lab [FOLDER]``: the students' JupyterLab, on any folder (the course, or ``~/labkit-exercises``).

It is ``jupyter lab`` with labkit's configuration (the folder ``jupyter/`` beside this module, first on
``JUPYTER_CONFIG_PATH`` for that server only, never written to the user's ``~/.jupyter``):

- nbgrader's instructor tools are hidden (the formgrader and course-list server extensions off; the Formgrader,
  Create Assignment, nbgrader menu and course-list lab plugins disabled): students see Validate, nothing else;
- Validate runs ``labkit grade --check`` on the notebook (:mod:`labkit.grading.lab_validate`): the student's code
  in the grading sandbox, the same verdicts as when the notebook is graded;
- the inline rerun viewers load their code from the installed package (``RERUN_NOTEBOOK_ASSET=serve-local``),
  not from the internet;
- this Python's ``bin`` comes first on ``PATH`` (nbgrader runs ``alembic`` from there).

:func:`lab_command` and :func:`lab_environment` build the command and its environment (the browser test starts
its server with them); :func:`run_lab` runs it for ``labkit lab`` (:mod:`labkit.app.cli`).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

__all__ = ["CONFIG_DIR", "lab_command", "lab_environment", "run_lab"]

#: labkit's Jupyter configuration for the students' lab (JSON, read by Jupyter, never imported): the server's
#: extensions in jupyter_server_config.json (nbgrader's formgrader, course list and Validate off, labkit's Validate
#: on), the lab plugins turned off in labconfig/page_config.json (Formgrader, Create Assignment, nbgrader's menu,
#: the course list).
CONFIG_DIR = Path(__file__).resolve().with_name("jupyter")


def lab_environment(environ: Mapping[str, str] | None = None) -> dict[str, str]:
    """Return the environment the students' JupyterLab runs in.

    That is ``environ`` with labkit's lab configuration first on ``JUPYTER_CONFIG_PATH``, the offline
    rerun viewer and this Python's ``bin`` first on ``PATH``.

    Parameters
    ----------
    environ : mapping of str to str, optional
        The environment to start from (default: this process's).

    Returns
    -------
    dict of str to str
        The lab's environment."""
    env = dict(os.environ if environ is None else environ)
    env["JUPYTER_CONFIG_PATH"] = os.pathsep.join(filter(None, [str(CONFIG_DIR), env.get("JUPYTER_CONFIG_PATH")]))
    env["RERUN_NOTEBOOK_ASSET"] = "serve-local"
    env["PATH"] = os.pathsep.join(filter(None, [str(Path(sys.executable).parent), env.get("PATH")]))
    return env


def lab_command(folder: Path | str = ".", *, open_path: str | None = None,
                extra: tuple[str, ...] | list[str] = ()) -> list[str]:
    """Build the command that serves ``folder`` in the students' JupyterLab.

    Run it with the environment of :func:`lab_environment`.

    Parameters
    ----------
    folder : Path or str
        The folder the lab serves.
    open_path : str, optional
        A notebook (relative to ``folder``) the lab opens first.
    extra : sequence of str
        More ``jupyter lab`` options.

    Returns
    -------
    list of str
        The command line.
    """
    root = Path(folder).expanduser()
    if not root.is_dir():
        raise FileNotFoundError(f"{folder}: no such folder (labkit lab serves a folder: the course or your "
                                "exercises, e.g. labkit lab ~/labkit-exercises)")
    command = [sys.executable, "-m", "jupyter", "lab", f"--ServerApp.root_dir={root.resolve()}"]
    if os.geteuid() == 0:
        command.append("--allow-root")
    command += list(extra)
    if open_path:
        if not (root / open_path).exists():
            raise FileNotFoundError(f"{root / open_path}: no such notebook to open")
        command.append(open_path)
    return command


def run_lab(folder: Path | str = ".", *, open_path: str | None = None,
            extra: tuple[str, ...] | list[str] = ()) -> int:
    """Serve ``folder`` in the students' JupyterLab until it stops.

    Ctrl-C: JupyterLab asks, or a second one stops it, and its kernels with it.

    Parameters
    ----------
    folder : Path or str
        The folder the lab serves.
    open_path : str, optional
        A notebook (relative to ``folder``) the lab opens first.
    extra : sequence of str
        More ``jupyter lab`` options.

    Returns
    -------
    int
        JupyterLab's exit status."""
    process = subprocess.Popen(lab_command(folder, open_path=open_path, extra=extra), env=lab_environment())
    while True:
        try:
            return process.wait()
        except KeyboardInterrupt:  # JupyterLab got the same Ctrl-C: it asks, or shuts its kernels down and ends
            continue
