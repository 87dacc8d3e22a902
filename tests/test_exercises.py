"""The nbgrader course in ``exercises/``: every exercise's source, spec and release, graded by the real grader.

An exercise is its source notebook (``exercises/source/<name>/<name>.ipynb``: the solution, the
visible checks, and in its metadata the functions students write with their points and the packages
the worker masks), its grading spec (``exercises/grading/<name>.py``: the hidden tests and the spec's
proof -- ``DELEGATE``, a submission that gets the right answers from labkit, and ``MISTAKES``,
plausible wrong answers) and the generated release. The tests find them
all, so adding an exercise needs no edit here. Per exercise:

- the source is well formed and agrees with its spec and release (the grader's own checks run);
- graded by :mod:`labkit.grading` (student code in the sandboxed worker, tests on the trusted
  side), the instructor's solution scores full marks, the release's blank stubs 0, ``DELEGATE`` 0;
- every mistake costs its own function's share of the same cells whatever the student's inputs
  (three seeds), one of them hidden, with feedback that shows no hidden value; a blank function
  costs its own points (and those of the functions that call it). These run the trusted tests in
  this process against the student's code run here (:class:`tests.grading_course.LocalSession`);
- the hidden tests pass the instructor's solution for many seeds (every student gets other inputs);
- the committed release is what ``nbgrader generate_assignment`` writes, and leaks nothing.
"""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from labkit.grading.exercises import Course
from labkit.grading.notebook import student_cells
from labkit.grading.runner import Job, grade_submission, run_cells, seed_for
from tests.grading_course import (
    EXERCISES,
    LocalSession,
    cell_source,
    cells_by_grade_id,
    copy_course,
    grade_id,
    names,
    notebook_with,
    once_per_session,
    read_notebook,
    release_notebook,
    solutions,
    source_notebook,
    submit,
    with_mistake,
)

NAMES = names()
COURSE = Course(EXERCISES)
MISTAKES = [pytest.param(name, mistake, id=f"{name}: {mistake}")
            for name in NAMES for mistake in COURSE.exercise(name).module.MISTAKES]
MARKERS = ("### BEGIN SOLUTION", "### END SOLUTION", "### BEGIN HIDDEN TESTS", "### END HIDDEN TESTS")
SEEDS = 4  # per exercise: the hidden tests must pass the solution whatever the student's inputs
MISTAKE_SEEDS = 3  # per mistake: the same cells lost for every student


@pytest.fixture(scope="module")
def course(tmp_path_factory) -> Path:
    return copy_course(tmp_path_factory.mktemp("course") / "course")


def graded(course: Path, name: str, student: str, notebook: dict):
    path = submit(course, student, name, notebook)
    return grade_submission(Job(str(course), name, student, str(path), b"test secret"))


def lost(result) -> set[str]:
    return {cell.grade_id for cell in result.cells if cell.points != cell.max_points}


# ---------------------------------------------------------------------------- the course
def test_every_exercise_has_a_spec_and_a_release():
    folders = sorted(p.name for p in (EXERCISES / "source").iterdir() if p.is_dir() and not p.name.startswith("."))
    assert folders == NAMES, "every exercises/source/<name>/ must hold <name>.ipynb"
    specs = sorted(p.stem for p in (EXERCISES / "grading").glob("*.py"))
    assert specs == NAMES, "every exercise needs its grading spec exercises/grading/<name>.py, and back"
    releases = sorted(p.name for p in (EXERCISES / "release").iterdir() if p.is_dir() and not p.name.startswith("."))
    assert releases == NAMES, "exercises/release/ does not match source/: run `make release`"


@pytest.mark.parametrize("name", NAMES)
def test_source_cells_and_spec_agree(name):
    exercise = COURSE.exercise(name)  # the grader's own checks: functions, hidden tests, release not stale
    notebook = source_notebook(name)
    cells = cells_by_grade_id(notebook)
    assert len(cells) == len(notebook["cells"]), "every cell needs nbgrader metadata with a grade_id"
    for gid, cell in cells.items():
        meta = cell["metadata"]["nbgrader"]
        assert cell.get("id") == gid, f"cell {gid}: give the cell the id of its grade_id"
        assert meta["locked"] is not meta["solution"], f"{gid}: solution cells are unlocked, the others locked"
        assert cell.get("outputs", []) == [] and cell.get("execution_count") is None, f"{gid} stored with outputs"
        text = cell_source(cell)
        assert ("### BEGIN SOLUTION" in text) is bool(meta["solution"]), f"{gid}: solution markers"
        assert "### BEGIN HIDDEN TESTS" not in text, f"{gid}: hidden tests belong in exercises/grading/{name}.py"
        if cell["cell_type"] == "code":
            assert "own_work(" not in text and "forbid_package_calls" not in text, f"{gid}: the old own-work guard"
    graded_cells = {cell.grade_id: cell for cell in exercise.cells}
    assert set(graded_cells) == {gid for gid, c in cells.items() if c["metadata"]["nbgrader"]["grade"]}
    assert sum(cell.points for cell in exercise.cells) == 10, "every exercise is worth 10 points"
    assert sum(exercise.points.values()) == 10, "the functions' points add up to the exercise's"
    for cell in exercise.cells:
        assert cell.visible or cell.hidden, f"{cell.grade_id} tests nothing: it would give its points away"
        assert sum(cell.shares.values()) == pytest.approx(cell.points)
        if not cell.visible:  # a hidden cell: every function has its own tests there
            assert {test.function for test in cell.hidden} == set(exercise.functions), cell.grade_id
    assert set(exercise.module.DELEGATE) == {gid for gid, c in cells.items() if c["metadata"]["nbgrader"]["solution"]}
    assert exercise.module.MISTAKES, f"{name}: give the spec plausible MISTAKES (they prove its hidden tests)"


def test_the_functions_a_run_checks_call_names():
    """The grader reads which functions a visible cell checks from its ``run_checks(...)`` keywords. A ``**mapping``
    names none: it is kept as written (so the cell is refused for checking other functions than its own), not as
    None, which made ``sorted`` raise TypeError beside a named one."""
    from labkit.grading.exercises import _checked

    assert _checked("x = 1\nrun_checks(f=check_f, g=check_g)") == ["f", "g"]
    assert _checked("run_checks(f=check_f, **more)") == ["f", "**more"]
    assert _checked("print(run_checks)") is None


# ---------------------------------------------------------------------------- graded by the grader
@pytest.mark.parametrize("name", NAMES)
def test_solution_earns_every_point(course, name):
    result = graded(course, name, "solution", notebook_with(name, solutions(name)))
    assert (result.status, result.score, result.cell_errors) == ("graded", 10.0, []), result.detail


@pytest.mark.parametrize("name", NAMES)
def test_blank_stubs_earn_nothing(course, name):
    result = graded(course, name, "blank", release_notebook(name))
    assert (result.status, result.score) == ("graded", 0.0)
    assert all("NotImplementedError" in cell.verdict for cell in result.cells), [c.verdict for c in result.cells]


def delegating(code: str) -> set[str]:
    """The functions of ``code`` that call what it imports from labkit (directly or through another function)."""
    tree = ast.parse(code)
    names = {alias.asname or alias.name.partition(".")[0] for node in tree.body if isinstance(node, ast.Import)
             for alias in node.names if alias.name.partition(".")[0] == "labkit"}
    names |= {alias.asname or alias.name for node in tree.body if isinstance(node, ast.ImportFrom)
              and (node.module or "").partition(".")[0] == "labkit" for alias in node.names}
    uses = {node.name: {n.id for n in ast.walk(node) if isinstance(n, ast.Name)} for node in tree.body
            if isinstance(node, ast.FunctionDef)}
    found = {f for f, used in uses.items() if used & names}
    while grown := {f for f, used in uses.items() if used & found} - found:
        found |= grown
    return found


@pytest.mark.parametrize("name", NAMES)
def test_delegating_to_labkit_earns_nothing(course, name):
    """Every function the spec's DELEGATE computes with labkit scores 0, and says why; a function it writes with
    numpy alone (ex06's bounds, by np.searchsorted) earns its own points."""
    answers = COURSE.exercise(name).module.DELEGATE
    result = graded(course, name, "delegate", notebook_with(name, answers))
    cheats = set().union(*(delegating(code) for code in answers.values()))
    assert result.status == "graded" and cheats, result.detail
    earned = {part.function for cell in result.cells for part in cell.parts if part.points}
    assert not earned & cheats, result.detail
    assert result.score == sum(COURSE.exercise(name).points[f] for f in earned)
    said = [e["message"] for e in result.cell_errors] + [cell.verdict for cell in result.cells]
    assert any("is not available when your notebook is graded" in text for text in said), said


def graded_here(name: str, answers: dict[str, str], seed: int, functions=None):
    """The cells of ``name`` graded in this process on the notebook with ``answers``: run_cells with the spec's
    tests, the student's code run here (trusted code only) and the seeds of student ``seed``."""
    exercise = COURSE.exercise(name)
    notebook = notebook_with(name, answers)
    code = student_cells({"cells": [{**c, "source": cell_source(c)} for c in notebook["cells"]]}, exercise.test_cells)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return run_cells(exercise, LocalSession(code), seeds=lambda cell, part: seed_for(
            b"test secret", name, f"student{seed}", cell, part), functions=functions)


def lost_parts(cells) -> set[tuple[str, str]]:
    return {(cell.grade_id, part.function) for cell in cells for part in cell.parts if part.points != part.max_points}


def defining(name: str, text: str) -> str:
    """The function of the solution whose code holds ``text``."""
    for code in solutions(name).values():
        for node in ast.parse(code).body:
            if isinstance(node, ast.FunctionDef) and text in ast.get_source_segment(code, node):
                return node.name
    raise AssertionError(f"{name}: no function of the solution holds {text!r}")


@pytest.mark.parametrize(("name", "mistake"), MISTAKES)
def test_a_plausible_mistake_costs_its_functions_points_whatever_the_inputs(name, mistake):
    """A mistake in one function loses that function's share of some cells, one of them hidden, and the same
    cells for every student: the points of a partial answer do not depend on the student's seed. (Only that
    function's tests run: the functions that call it in the solution lose with it, see the blank test below.)"""
    old, new = COURSE.exercise(name).module.MISTAKES[mistake]
    function = defining(name, old)
    answers = with_mistake(name, old, new)
    lost = [{gid for gid, f in lost_parts(graded_here(name, answers, seed, functions=(function,))) if f == function}
            for seed in range(MISTAKE_SEEDS)]
    hidden = {cell.grade_id for cell in COURSE.exercise(name).cells if cell.hidden}
    assert lost[0] & hidden, f"no hidden test caught {mistake!r}"
    assert all(cells == lost[0] for cells in lost), f"the cells lost depend on the seed: {lost}"


def callers(name: str, function: str) -> set[str]:
    """The functions of the solution that call ``function``, directly or through another."""
    calls = {}
    for code in solutions(name).values():
        for node in ast.parse(code).body:
            if isinstance(node, ast.FunctionDef):
                calls[node.name] = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
    found, changed = {function}, True
    while changed:
        grown = found | {f for f, names in calls.items() if names & found}
        changed, found = grown != found, grown
    return found - {function}


BLANKS = [pytest.param(name, f, id=f"{name}: {f}") for name in NAMES for f in COURSE.exercise(name).functions
          if len(COURSE.exercise(name).functions) > 1]


@pytest.mark.parametrize(("name", "function"), BLANKS)
def test_a_blank_function_costs_its_own_points(name, function):
    """One function left as released: it loses its points, and the functions that call it theirs; the others
    keep every point (the points per function of the notebook's metadata)."""
    answers = dict(solutions(name))
    for gid, code in answers.items():
        for node in ast.parse(code).body:
            if isinstance(node, ast.FunctionDef) and node.name == function:
                stub = f"def {function}(*args, **kwargs):\n    raise NotImplementedError()"
                answers[gid] = code.replace(ast.get_source_segment(code, node), stub)
    cells = graded_here(name, answers, 0)
    exercise = COURSE.exercise(name)
    lost = {function} | callers(name, function)
    assert sum(cell.points for cell in cells) == pytest.approx(exercise.total - sum(exercise.points[f] for f in lost))
    assert {f for _, f in lost_parts(cells)} == lost


@pytest.mark.parametrize("name", NAMES)
def test_hidden_tests_pass_the_solution_for_every_student(name):
    """The instructor's solution, run here, against the visible checks and the spec's hidden tests, many seeds."""
    for seed in range(SEEDS):
        cells = graded_here(name, solutions(name), seed)
        assert not lost_parts(cells), [cell.verdict for cell in cells if cell.verdict != "passed"]


HIDDEN_VALUES = re.compile(r"\d\.\d{2,}|\d{7,}")


@pytest.mark.parametrize("name", NAMES)
def test_hidden_feedback_names_the_property_not_the_values(name):
    """What a student reads about a failing hidden test holds no decimal number and no long integer (no input,
    no expected value), for every plausible mistake of the exercise."""
    for mistake, (old, new) in COURSE.exercise(name).module.MISTAKES.items():
        cells = graded_here(name, with_mistake(name, old, new), 0, functions=(defining(name, old),))
        said = [part.verdict for cell in cells for part in cell.parts if "(hidden)" in part.verdict]
        said += [line for cell in cells if cell.grade_id != "test_visible" for output in cell.outputs
                 for line in output.get("traceback", [])]
        leaked = [text for text in said if HIDDEN_VALUES.search(text)]
        assert not leaked, f"{mistake}: {leaked[:3]}"


# ---------------------------------------------------------------------------- the release
def generate_release(folder: Path) -> Path:
    course = copy_course(folder / "course")
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""),
               JUPYTER_CONFIG_DIR=str(course / ".jupyter-config"))
    proc = subprocess.run([sys.executable, "-m", "nbgrader", "generate_assignment", "*", "--force", "--no-db"],
                          cwd=course, env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return course


@pytest.fixture(scope="module")
def generated_course(tmp_path_factory) -> Path:
    """A copy of the course with release/ generated for every assignment (``--no-db``: no gradebook)."""
    return once_per_session(tmp_path_factory, "release", generate_release)


def files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_release_has_stubs_and_no_solutions(name, generated_course):
    release = read_notebook(generated_course / "release" / name / f"{name}.ipynb")
    source = source_notebook(name)
    assert [grade_id(c) for c in release["cells"]] == [grade_id(c) for c in source["cells"]]
    text = json.dumps(release)
    assert not any(marker in text for marker in MARKERS)
    released = cells_by_grade_id(release)
    for gid, cell in cells_by_grade_id(source).items():
        if not cell["metadata"]["nbgrader"]["solution"]:
            assert cell_source(released[gid]) == cell_source(cell), f"{gid} must be released as it is"
            continue
        stub = cell_source(released[gid])
        assert "# YOUR CODE HERE" in stub and "raise NotImplementedError()" in stub, gid
        inside, outside, depth = set(), set(), 0
        for line in cell_source(cell).splitlines():
            depth += {MARKERS[0]: 1, MARKERS[1]: -1}.get(line.strip(), 0)
            (inside if depth and line.strip() not in MARKERS else outside).add(line.strip())
        leaked = {line for line in inside - outside if line} & {line.strip() for line in stub.splitlines()}
        assert not leaked, f"the solution of {gid} leaked into the release: {leaked}"
        for function in COURSE.exercise(name).functions:
            signature = next((line for line in outside if line.startswith(f"def {function}(")), None)
            assert signature is None or signature in stub, f"the release of {gid} lost {signature!r}"
    assert not (generated_course / "release" / name / "grading").exists()
    assert files_under(generated_course / "release" / name) == [f"{name}.ipynb"], "the spec must never be released"


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_committed_release_is_what_the_generator_writes(name, generated_course):
    committed, generated = EXERCISES / "release" / name, generated_course / "release" / name
    stale = "exercises/release/ is stale: regenerate it with `make release` (never edit it by hand)"
    assert files_under(committed) == files_under(generated), stale
    for file in files_under(generated):
        assert [(c["cell_type"], cell_source(c)) for c in read_notebook(committed / file)["cells"]] == [
            (c["cell_type"], cell_source(c)) for c in read_notebook(generated / file)["cells"]
        ], f"{file}: {stale}"
