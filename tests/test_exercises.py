"""The nbgrader course in ``exercises/``: every exercise's source, spec and release, graded by the real grader.

An exercise is its source notebook (``exercises/source/<name>/<name>.ipynb``), its grading spec
(``exercises/grading/<name>.py``: the hidden tests, the functions students write, the packages the
worker masks, and the spec's proof -- ``DELEGATE``, a submission that gets the right answers from
labkit, and ``MISTAKES``, plausible wrong answers) and the generated release. The tests find them
all, so adding an exercise needs no edit here. Per exercise:

- the source is well formed and agrees with its spec and release (the grader's own checks run);
- graded by :mod:`labkit.grading` (student code in the sandboxed worker, tests on the trusted
  side), the instructor's solution scores full marks, the release's blank stubs 0, ``DELEGATE`` 0,
  and every mistake fails a hidden test;
- the hidden tests pass the instructor's solution for many seeds (every student gets other inputs);
- the committed release is what ``nbgrader generate_assignment`` writes, and leaks nothing.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from labkit.grading.course import Course
from labkit.grading.runner import Job, grade_submission
from tests.grading_course import (
    EXERCISES,
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
    for cell in exercise.cells:
        assert cell.visible or cell.hidden, f"{cell.grade_id} tests nothing: it would give its points away"
    assert set(exercise.module.DELEGATE) == {gid for gid, c in cells.items() if c["metadata"]["nbgrader"]["solution"]}
    assert exercise.module.MISTAKES, f"{name}: give the spec plausible MISTAKES (they prove its hidden tests)"


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


@pytest.mark.parametrize("name", NAMES)
def test_delegating_to_labkit_earns_nothing(course, name):
    result = graded(course, name, "delegate", notebook_with(name, COURSE.exercise(name).module.DELEGATE))
    assert (result.status, result.score) == ("graded", 0.0), result.detail
    said = [e["message"] for e in result.cell_errors] + [cell.verdict for cell in result.cells]
    assert any("is not available when your notebook is graded" in text for text in said), said


@pytest.mark.parametrize(("name", "mistake"), MISTAKES)
def test_hidden_tests_catch_a_plausible_mistake(course, name, mistake):
    old, new = COURSE.exercise(name).module.MISTAKES[mistake]
    result = graded(course, name, "mistake", notebook_with(name, with_mistake(name, old, new)))
    hidden = {cell.grade_id for cell in COURSE.exercise(name).cells if cell.hidden}
    assert result.status == "graded"
    assert lost(result) & hidden, f"no hidden test caught {mistake!r}: {[c.verdict for c in result.cells]}"


@pytest.mark.parametrize("name", NAMES)
def test_hidden_tests_pass_the_solution_for_every_student(name):
    """The instructor's solution, run here, against the spec's hidden tests with many seeds."""
    exercise = COURSE.exercise(name)
    namespace = {"np": np}
    for code in solutions(name).values():
        exec(compile(code, f"<{name} solution>", "exec"), namespace)
    for cell in exercise.cells:
        exec(compile(cell.code, f"<{cell.grade_id}>", "exec"), dict(namespace))  # as in the student's Jupyter
        for seed in range(SEEDS) if cell.hidden else ():
            rng = np.random.default_rng(seed)
            cell.hidden(**{p: rng if p == "rng" else namespace[p] for p in cell.parameters})


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
