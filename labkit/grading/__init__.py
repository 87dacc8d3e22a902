"""Grading the nbgrader course in ``exercises/``: student code isolated from the tests that grade it.

A student's notebook is graded in two processes that share nothing but plain data:

- the *worker* (:mod:`labkit.grading.worker`) runs the submission's code cells in a bubblewrap
  sandbox (:mod:`labkit.grading.sandbox`): an unprivileged user, no network, no files of the
  course, resource limits, and no labkit (nor the packages an exercise masks), so delegating the
  exercise to labkit is impossible rather than detected;
- the *trusted* side (:mod:`labkit.grading.runner`) runs the instructor's tests -- the visible
  tests from the source notebook, the hidden tests from the exercise's spec in
  ``exercises/grading/`` -- and calls the student's functions through proxies: plain arguments
  out, plain results back (:mod:`labkit.grading.protocol`), so nothing the student's code builds
  can change what a test compares.

``labkit grade <exercise|all>`` (:mod:`labkit.grading.command`) grades a class into nbgrader's
gradebook and ``grades.csv``; ``labkit grade --check my.ipynb`` runs one notebook's visible tests
the same way.

The helpers the tests use live here too: :func:`run_checks` runs a notebook's visible checks (one per
function a student writes); :func:`random_beams` and :func:`random_wall_beams` draw inputs;
:func:`assert_beams_result`, :func:`assert_labels_result` and :func:`assert_line_result` compare
answers in words a student can act on, without the expected values.
"""

from .checks import Moved, assert_beams_result, assert_labels_result, assert_line_result, run_checks
from .command import add_grade_parser, check, grade, main, run_grade
from .inputs import (
    random_arc,
    random_band_segment,
    random_beams,
    random_iepf_trace,
    random_shape,
    random_threshold_case,
    random_wall_beams,
)

__all__ = [
    "run_checks",
    "random_beams",
    "random_wall_beams",
    "random_iepf_trace",
    "random_threshold_case",
    "random_shape",
    "random_arc",
    "random_band_segment",
    "assert_beams_result",
    "assert_labels_result",
    "assert_line_result",
    "Moved",
    "grade",
    "check",
    "add_grade_parser",
    "run_grade",
    "main",
]
