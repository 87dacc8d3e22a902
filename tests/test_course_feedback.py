"""What a student reads when an answer is wrong: the case, the entries that differ, no traceback into labkit.

The your-turn checks of the lessons (:mod:`labkit.course`), the visible checks of the exercises
(:func:`labkit.grading.run_checks`), the grader's verdicts and Validate in the students' lab
(:mod:`labkit.grading.lab_validate`), and the lab's own configuration (:mod:`labkit.grading.lab`).
Fast: no kernel, no server, no sandbox (the browser test walks the same path in JupyterLab).
"""

from __future__ import annotations

import html
import json
import os
import sys

import numpy as np
import pytest

from labkit.course import Case, Feedback, YourTurnError, check, student_frames
from labkit.grading import run_checks
from labkit.grading.checks import ChecksFailed


def _error(student, cases) -> YourTurnError:
    with pytest.raises(YourTurnError) as raised:
        check(student, cases, fallback=None)
    return raised.value


def test_a_wrong_boolean_array_lists_the_entries_that_differ():
    """Not `[False False False ... ]`: the indices, what came back and what was expected there."""
    ranges = np.linspace(0.5, 5.0, 40)
    expected = ranges >= 2.0
    got = ranges > 2.0 + 0.2  # wrong at the entries from 2.0 m to 2.2 m
    wrong = [int(i) for i in np.flatnonzero(got != expected)]
    message = str(_error(lambda r: r > 2.2, [Case((ranges,), expected, hint="at least 2 m")]))
    assert f"differs at {len(wrong)} of 40 entries" in message, message
    for index in wrong:
        assert f"[{index}] is False, expected True" in message, message
    assert "..." not in message.split("returned", 1)[1], message
    assert message.endswith("Hint: at least 2 m")


def test_many_differences_are_counted_and_the_first_ones_shown():
    message = str(_error(lambda n: np.zeros(n), [Case((100,), np.arange(100.0), hint="h")]))
    assert "differs at 99 of 100 entries: [1] is 0.0, expected 1.0; [2] is 0.0, expected 2.0" in message
    assert "(and 93 more)" in message


def test_a_wrong_shape_is_said_as_such():
    message = str(_error(lambda n: np.zeros(n - 1), [Case((5,), np.zeros(5), hint="one per beam")]))
    assert "an array of shape (4,), expected shape (5,)" in message, message


def test_floats_within_the_tolerance_are_not_listed():
    expected = np.array([1.0, 2.0, 3.0])
    message = str(_error(lambda: expected + [1e-12, 0.5, 0.0], [Case((), expected, hint="h", atol=1e-9)]))
    assert "differs at 1 of 3 entries: [1] is 2.5, expected 2.0" in message, message


def test_an_error_in_the_students_function_says_where_in_their_code():
    def segment(ranges):
        first = ranges[0]
        return ranges[len(ranges) + first]

    message = str(_error(segment, [Case((np.arange(3),), np.arange(3), hint="h")]))
    assert "raised IndexError" in message and "in segment: return ranges[len(ranges) + first]" in message, message
    assert "course.py" not in message


def test_feedback_renders_in_ipython_as_its_message_alone():
    """IPython asks an exception for _render_traceback_ before it formats its frames."""
    error = _error(lambda x: x + 1, [Case((1,), 3, hint="twice x")])
    assert isinstance(error, Feedback) and isinstance(error, AssertionError)  # pytest and nbclient still see it
    lines = error._render_traceback_()
    assert len(lines) == 1 and lines[0].endswith("returned 2, expected 3. Hint: twice x")
    assert "YourTurnError" in lines[0] and "labkit" not in lines[0] and "File" not in lines[0]


def test_student_frames_leave_out_labkit_and_installed_packages():
    def student(values):
        return np.linalg.inv(values)  # raises in numpy's own code, whose frames are left out

    try:
        student(np.zeros((2, 2)))
    except ValueError as raised:
        assert "numpy" in "".join(str(f.filename) for f in __import__("traceback").extract_tb(raised.__traceback__))
        frames = student_frames(raised)
    assert "in student: return np.linalg.inv(values)" in frames
    assert "site-packages" not in frames and "_raise_linalgerror" not in frames and "test_student_frames" in frames


def test_visible_checks_raise_one_message_with_each_failure_and_its_line(capsys):
    def check_double(rng):
        assert 2 * 2 == 4

    def check_half(rng):
        got = np.array([1, 1, 2])
        assert np.array_equal(got, [1, 1, 1]), f"expected [1, 1, 1], got {got!r}. Hint: floor division"

    def check_third(rng):
        {}["missing"]

    with pytest.raises(ChecksFailed) as raised:
        run_checks(double=check_double, half=check_half, third=check_third)
    assert capsys.readouterr().out.splitlines() == ["double: passed", "half: FAILED", "third: FAILED"]
    message = str(raised.value)
    assert "half: AssertionError: expected [1, 1, 1], got array([1, 1, 2]). Hint: floor division" in message
    assert "in check_half: assert np.array_equal(got, [1, 1, 1])" in message
    assert "third: KeyError: 'missing'" in message and "in check_third: {}[\"missing\"]" in message
    assert raised.value._render_traceback_()[0].count("\n") == message.count("\n")  # the message, nothing more


def test_a_check_without_a_message_still_says_what_failed():
    """A hidden test's bare `assert` used to reach the student as a bare "AssertionError"."""
    from labkit.grading.exercises import GradedCell
    from labkit.grading.runner import _failure

    cell = GradedCell("test_own_work", 2.0, "")
    for part in ("visible", "hidden"):
        output, verdict = _failure(cell, "segment", AssertionError(), part)
        assert verdict != "segment failed (hidden): AssertionError", verdict
        assert "a check of segment failed without saying why" in verdict, verdict
        assert output["evalue"], output


# ---------------------------------------------------------------------------- Validate in the students' lab
def _summary(**cell) -> dict:
    base = {"grade_id": "test_visible", "points": 2.0, "earned": 1.0, "hidden_only": False, "passed": False,
            "where": [], "parts": [{"function": "segment", "points": 0.0, "max_points": 1.0,
                                    "verdict": "segment failed (visible): ValueError: <b>bold</b>"},
                                   {"function": "adaptive_threshold", "points": 1.0, "max_points": 1.0,
                                    "verdict": "passed"}]}
    return {"exercise": "ex01", "passed": False, "report": "", "invalid": "", "notes": [], "cells": [{**base, **cell}]}


def test_validate_answers_in_the_shape_nbgrader_shows_and_escapes_what_the_student_wrote():
    from labkit.grading.lab_validate import validate_answer

    answer = validate_answer(_summary(where=["segment, in the visible checks, line 3: x = <i>"]))
    assert answer["success"] is True and len(answer["value"]["failed"]) == 1
    failed = answer["value"]["failed"][0]
    assert failed["source"].startswith("test_visible: 1 of 2 points")
    assert "<b>" not in failed["error"] and "<i>" not in failed["error"]  # nbgrader puts `error` in as HTML
    text = html.unescape(failed["error"])
    assert "segment: 0 of 1 points: segment failed (visible): ValueError: <b>bold</b>" in text
    assert "adaptive_threshold: 1 of 1 points: passed" in text and "line 3: x = <i>" in text
    passed = {**_summary(passed=True, earned=2.0), "passed": True}
    assert validate_answer(passed) == {"success": True, "value": {}}  # nbgrader's "Success!"
    hidden_only = _summary(hidden_only=True, passed=True, earned=0.0)
    assert validate_answer({**hidden_only, "passed": True}) == {"success": True, "value": {}}
    invalid = validate_answer({**_summary(), "invalid": "not JSON"})
    assert invalid["success"] is False and "not JSON" in invalid["value"]


def test_validate_never_says_success_for_a_summary_that_did_not_pass():
    from labkit.grading.lab_validate import validate_answer

    answer = validate_answer({**_summary(passed=True, earned=2.0), "passed": False, "report": "why"})
    assert answer == {"success": False, "value": "why"}


def test_is_exercise_tells_an_exercise_from_a_lesson(tmp_path):
    from labkit.grading.lab_validate import is_exercise

    lesson, exercise, broken = tmp_path / "l.ipynb", tmp_path / "e.ipynb", tmp_path / "b.ipynb"
    lesson.write_text(json.dumps({"cells": [{"cell_type": "code", "metadata": {}, "source": "1"}]}))
    exercise.write_text(json.dumps({"cells": [{"cell_type": "code", "metadata": {"nbgrader": {}}, "source": ""}]}))
    broken.write_text("{")
    assert not is_exercise(lesson) and is_exercise(exercise) and is_exercise(broken)


def test_the_students_lab_configuration(tmp_path):
    """labkit lab: its configuration first on JUPYTER_CONFIG_PATH, the instructor plugins off, Validate labkit's."""
    from labkit.grading.lab import CONFIG_DIR, lab_command, lab_environment

    env = lab_environment({"PATH": "/usr/bin", "JUPYTER_CONFIG_PATH": "/mine"})
    assert env["JUPYTER_CONFIG_PATH"] == f"{CONFIG_DIR}{os.pathsep}/mine"
    assert env["RERUN_NOTEBOOK_ASSET"] == "serve-local"
    assert env["PATH"].split(os.pathsep)[0] == os.path.dirname(sys.executable)
    disabled = json.loads((CONFIG_DIR / "labconfig" / "page_config.json").read_text())["disabledExtensions"]
    assert {f"@jupyter/nbgrader:{p}" for p in ("formgrader", "create-assignment", "menu", "course-list")} <= {
        name for name, off in disabled.items() if off}
    extensions = json.loads((CONFIG_DIR / "jupyter_server_config.json").read_text())["ServerApp"]["jpserver_extensions"]
    assert extensions["labkit.grading.lab_validate"] is True
    assert not extensions["nbgrader.server_extensions.validate_assignment"]
    assert not extensions["nbgrader.server_extensions.formgrader"]
    command = lab_command(tmp_path)
    assert command[1:4] == ["-m", "jupyter", "lab"] and f"--ServerApp.root_dir={tmp_path.resolve()}" in command
    with pytest.raises(FileNotFoundError, match="no such folder"):
        lab_command(tmp_path / "missing")
    with pytest.raises(FileNotFoundError, match="no such notebook"):
        lab_command(tmp_path, open_path="missing.ipynb")


def test_labkit_lab_is_on_the_command_line(labkit_cli, tmp_path):
    done = labkit_cli("lab", "--help")
    assert done.returncode == 0 and "labkit lab ~/labkit-exercises" in " ".join(done.stdout.split())
    done = labkit_cli("lab", tmp_path / "missing")
    assert done.returncode != 0 and "no such folder" in done.stderr
