"""JupyterLab's Validate in the students' lab (``labkit lab``): the same sandboxed check as ``labkit grade --check``.

nbgrader's Validate button is on every notebook's toolbar. nbgrader's own server extension runs the notebook in
an ordinary kernel, with labkit importable, and says "Success! Your notebook passes all the tests" for an answer
that calls ``labkit.segment_labels`` (which grading gives 0) and for a lesson notebook without graded cells. This
server extension takes the place of nbgrader's ``validate_assignment`` extension (same routes, see
``jupyter/jupyter_server_config.json``):

- a notebook with nbgrader cells is checked by ``python -m labkit.grading --check NOTEBOOK --json`` in a process
  of its own, in the folder the lab serves: the student's code runs in the grading sandbox (bubblewrap: no labkit,
  no network, no files), the checks in that process, as ``labkit grade --check`` does; this server runs none of
  the notebook's code. Without the sandbox the check fails and says how to install it; it never falls back to
  running the code outside;
- any other notebook gets an answer that says it is a lesson and where the exercises are.

The answer has the shape nbgrader's JupyterLab extension shows: ``{"success": true, "value": {}}`` when every
visible test passed (its dialog says "Success!"), ``value: {"failed": [...]}`` with each graded cell that lost
points, the failing function and why, and ``success: false`` with the reason when the check could not run. The
dialog puts a failure's ``error`` into the page as HTML: everything in it is escaped here (a student's exception
message is text, never markup).
"""

from __future__ import annotations

import asyncio
import html
import json
import sys
from pathlib import Path
from typing import Any

__all__ = ["is_exercise", "validate_answer", "CHECK_TIMEOUT_S"]

#: The longest a Validate may take (the check itself limits each call of the student's functions to seconds).
CHECK_TIMEOUT_S = 600.0

NOT_AN_EXERCISE = (
    "{path} is a lesson notebook, not an exercise: it has no graded cells, so there is nothing to "
    "validate. Validate checks the exercises (the notebooks of exercises/release/, or the copies you "
    "were given); a lesson's own checks are its cells, run top to bottom."
)


def is_exercise(path: Path) -> bool:
    """Tell whether a notebook is an exercise: a cell of it has nbgrader metadata.

    Parameters
    ----------
    path : Path
        The notebook.

    Returns
    -------
    bool
        True for an nbgrader assignment."""
    try:
        cells = json.loads(path.read_text(encoding="utf-8")).get("cells", [])
    except (OSError, ValueError, AttributeError):
        return True  # let the check report what is wrong with the file
    return any("nbgrader" in cell.get("metadata", {}) for cell in cells if isinstance(cell, dict))


def validate_answer(summary: dict) -> dict[str, Any]:
    """Turn the summary of ``labkit grade --check --json`` into nbgrader's Validate answer.

    Parameters
    ----------
    summary : dict
        What :func:`labkit.grading.command.check_summary` returns.

    Returns
    -------
    dict
        The answer nbgrader's Validate dialog shows, its text HTML-escaped."""
    if summary.get("invalid"):
        return {"success": False, "value": f"labkit grade --check: invalid notebook: {summary['invalid']}"}
    failed = []
    notes = "".join(f"note: {html.escape(note)}\n" for note in summary.get("notes", []))
    for cell in summary.get("cells", []):
        if cell["passed"]:
            continue
        earned = cell["earned"] or 0
        lines = [f"{part['function']}: {part['points']:g} of {part['max_points']:g} points: "
                 + ("passed" if part["verdict"] == "passed" else part["verdict"]) for part in cell["parts"]]
        lines += [f"first failure: {where}" for where in cell.get("where", [])]
        failed.append({"source": f"{cell['grade_id']}: {earned:g} of {cell['points']:g} points "
                                 "(the visible tests, run the way your notebook will be graded)",
                       "error": notes + html.escape("\n".join(lines))})
        notes = ""
    if failed:
        failed[-1]["error"] += html.escape("\n\nsome visible tests failed: fix them before you hand in "
                                           f"(the same check: labkit grade --check {summary.get('exercise', '')})")
        return {"success": True, "value": {"failed": failed}}
    if not summary.get("passed", False):  # not a cell's verdict (cannot happen with a summary of check_summary)
        return {"success": False, "value": summary.get("report", "the check did not pass")}
    return {"success": True, "value": {}}


async def _check(notebook: Path, folder: Path) -> dict[str, Any]:
    """Run ``labkit grade --check NOTEBOOK --json`` in ``folder``, in a process of its own; the Validate answer."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "labkit.grading", "--check", str(notebook), "--json", cwd=folder,
        stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    try:
        out, err = await asyncio.wait_for(process.communicate(), CHECK_TIMEOUT_S)
    except TimeoutError:
        process.kill()
        await process.wait()
        return {"success": False, "value": f"labkit grade --check took more than {CHECK_TIMEOUT_S:.0f} s: stopped"}
    try:
        summary = json.loads(out.decode("utf-8", "replace").strip().splitlines()[-1])
    except (ValueError, IndexError):
        why = err.decode("utf-8", "replace").strip() or f"it ended with status {process.returncode} and no verdict"
        return {"success": False, "value": f"labkit grade --check could not check {notebook.name}:\n{why[-3000:]}"}
    return validate_answer(summary)


def _handler() -> type:
    """The handler of nbgrader's Validate route (built here: jupyter_server is imported when the lab loads this)."""
    from jupyter_server.base.handlers import JupyterHandler
    from tornado import web

    class LabkitValidateHandler(JupyterHandler):
        """POST ``assignments/validate`` with ``path``: nbgrader's route, answered by ``labkit grade --check``."""

        @web.authenticated
        async def post(self) -> None:
            try:
                path = self.get_argument("path")
            except web.MissingArgumentError:
                path = (self.get_json_body() or {}).get("path", "")
            root = Path(self.settings["labkit_root_dir"]).expanduser().resolve()
            target = (root / path).resolve()
            if not target.is_relative_to(root):
                raise web.HTTPError(403, "Access denied: path outside allowed directory")
            if not target.is_file():
                answer = {"success": False, "value": f"no notebook {path}"}
            elif not is_exercise(target):
                answer = {"success": False, "value": NOT_AN_EXERCISE.format(path=path)}
            else:
                answer = await _check(target, root)
            self.finish(json.dumps(answer))

    return LabkitValidateHandler


def _jupyter_server_extension_points() -> list[dict[str, str]]:
    return [{"module": "labkit.grading.lab_validate"}]


def _load_jupyter_server_extension(server_app: Any) -> None:
    from jupyter_server.utils import url_path_join
    from nbgrader.server_extensions.validate_assignment.handlers import NbGraderVersionHandler

    web_app = server_app.web_app
    base_url = web_app.settings["base_url"]
    web_app.settings["labkit_root_dir"] = server_app.root_dir
    web_app.add_handlers(".*$", [
        (url_path_join(base_url, "assignments/validate"), _handler()),
        (url_path_join(base_url, "nbgrader_version"), NbGraderVersionHandler),
    ])
    server_app.log.info("labkit.grading.lab_validate: Validate runs labkit grade --check (sandboxed)")
