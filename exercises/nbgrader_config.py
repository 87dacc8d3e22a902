"""nbgrader configuration of the labkit course (``exercises/``).

nbgrader reads this file when it is started from this folder, so run every nbgrader command
here (``cd exercises``; ``make release`` does). The course root is this file's folder whatever
the working directory, so ``source/``, ``release/``, ``submitted/``, ``autograded/``,
``feedback/`` and ``gradebook.db`` all live next to it.
"""

import os

c = get_config()  # noqa: F821 -- provided by traitlets when nbgrader loads this file

c.CourseDirectory.course_id = "labkit"
c.CourseDirectory.root = os.path.dirname(os.path.abspath(__file__))
# The gradebook (SQLite) beside this file; `nbgrader export` writes grades.csv to the cwd.
c.CourseDirectory.db_url = "sqlite:///" + os.path.join(c.CourseDirectory.root, "gradebook.db")

# Students who are not in the gradebook yet are added when their submission is autograded
# (nbgrader's default, stated here because the course relies on it).
c.Autograde.create_student = True

# Per-cell time limit (seconds) when autograding: a cell still running after that is
# interrupted, scores 0, and grading goes on with the next cell and the next student. Every
# exercise cell runs in well under a second, so an endless loop costs 10 s per graded cell.
c.Execute.timeout = 10
c.Execute.interrupt_on_timeout = True
