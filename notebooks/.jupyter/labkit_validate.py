"""nbgrader's Validate for the students' JupyterLab, refusing lesson notebooks.

nbgrader's Validate button is on every notebook's toolbar, and on a notebook without graded cells (a
lesson) it says "Success! Your notebook passes all the tests", which a student reads as a verdict on
their work. This server extension takes the place of nbgrader's ``validate_assignment`` extension
(same routes, see jupyter_server_config.py): a notebook with nbgrader cells is validated by nbgrader as
before; any other gets an answer that says it is a lesson and where the exercises are.
"""

import json
from pathlib import Path

from jupyter_server.utils import url_path_join
from nbgrader.server_extensions.validate_assignment.handlers import (
    NbGraderVersionHandler,
    ValidateAssignmentHandler,
)

NOT_AN_EXERCISE = (
    "{path} is a lesson notebook, not an exercise: it has no graded cells, so there is nothing to "
    "validate. Validate checks the exercises (the notebooks of exercises/release/, or the copies you "
    "were given); a lesson's own checks are its cells, run top to bottom."
)


def is_exercise(path: Path) -> bool:
    """True when the notebook has a cell with nbgrader metadata (an nbgrader assignment)."""
    try:
        cells = json.loads(path.read_text(encoding="utf-8")).get("cells", [])
    except (OSError, ValueError):
        return True  # let nbgrader report what is wrong with the file
    return any("nbgrader" in cell.get("metadata", {}) for cell in cells)


class LessonAwareValidateHandler(ValidateAssignmentHandler):
    def validate_notebook(self, path):
        root = Path(self.root_dir).resolve()
        target = (root / path).resolve()
        if target.is_relative_to(root) and target.is_file() and not is_exercise(target):
            return {"success": False, "value": NOT_AN_EXERCISE.format(path=path)}
        return super().validate_notebook(path)


def _jupyter_server_extension_points():
    return [{"module": "labkit_validate"}]


def _load_jupyter_server_extension(server_app):
    web_app = server_app.web_app
    web_app.settings["root_dir"] = server_app.root_dir
    base_url = web_app.settings["base_url"]
    web_app.add_handlers(".*$", [
        (url_path_join(base_url, "assignments/validate"), LessonAwareValidateHandler),
        (url_path_join(base_url, "nbgrader_version"), NbGraderVersionHandler),
    ])
    server_app.log.info("labkit_validate: nbgrader's Validate, refusing lesson notebooks")
