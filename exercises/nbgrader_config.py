"""nbgrader configuration of the labkit course (``exercises/``).

nbgrader reads this file when it is started from this folder, so run nbgrader here (``cd
exercises``; ``make release`` does). The course root is this file's folder whatever the working
directory, so ``source/``, ``release/``, ``submitted/``, ``autograded/``, ``feedback/`` and
``gradebook.db`` all live next to it.

The course is *graded* with ``labkit grade`` (see README.md here), not ``nbgrader autograde``:
the hidden tests live in ``grading/``, outside the notebooks, so ``nbgrader autograde`` would run
the visible tests only and give every student the hidden tests' points. It is therefore refused
below. nbgrader's other commands (``generate_assignment``, ``zip_collect``, ``generate_feedback``,
``export``, the formgrader) work on what ``labkit grade`` writes.
"""

import os

from nbgrader.preprocessors import NbGraderPreprocessor

c = get_config()  # noqa: F821 -- provided by traitlets when nbgrader loads this file

c.CourseDirectory.course_id = "labkit"
c.CourseDirectory.root = os.path.dirname(os.path.abspath(__file__))
# The gradebook (SQLite) beside this file; `nbgrader export` writes grades.csv to the cwd.
c.CourseDirectory.db_url = "sqlite:///" + os.path.join(c.CourseDirectory.root, "gradebook.db")


class GradeWithLabkit(NbGraderPreprocessor):
    """Stops ``nbgrader autograde``, which cannot see the hidden tests, and says what to run instead."""

    def preprocess(self, nb, resources):
        raise RuntimeError(
            "this course is graded with `labkit grade <exercise|all>` (run it from the repository root): the"
            " hidden tests live in exercises/grading/, so `nbgrader autograde` would give their points away"
        )


c.Autograde.sanitize_preprocessors = [GradeWithLabkit]
