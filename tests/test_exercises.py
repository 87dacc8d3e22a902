"""The nbgrader course in ``exercises/``: every exercise, its release, its grading, and ``labkit.grading``.

Each exercise is described by a spec module in ``tests/exercise_specs/`` (found automatically):
adding an exercise takes a source folder, a spec and ``make release``, not an edit here. Per
exercise, the fast tests run the source notebook's code cells in this process -- hidden tests
included, as the autograder runs them -- with the instructor's solution, a cheater that
delegates to labkit, the release's blank stubs and plausible mistakes, and check which graded
cells pass. Every graded cell calls the student's functions through ``labkit.grading.own_work``,
so the cheater fails every one of them and scores 0. The slow tests generate the release with
nbgrader and autograde real submissions.

The slow tests copy ``exercises/`` into a temporary folder and run nbgrader there in a
subprocess (``python -m nbgrader``), so they never write into the repository. nbgrader 0.9
runs the ``alembic`` executable when it creates a gradebook, so the subprocesses get this
interpreter's ``bin/`` folder on ``PATH``; user-level Jupyter configuration is kept out with an
empty ``JUPYTER_CONFIG_DIR``.
"""

from __future__ import annotations

import ast
import csv
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import labkit
from labkit.grading import (
    assert_beams_result,
    assert_labels_result,
    assert_line_result,
    calls_into,
    forbid_package_calls,
    own_work,
    random_beams,
    random_wall_beams,
    record_package_calls,
)
from tests.exercise_specs import ExerciseSpec, load_specs

REPO = Path(__file__).resolve().parents[1]
EXERCISES = REPO / "exercises"
CELL_TIMEOUT_S = 10  # c.Execute.timeout in exercises/nbgrader_config.py

SPECS = load_specs()
BY_SPEC = [pytest.param(spec, id=spec.name) for spec in SPECS]
BY_MISTAKE = [
    pytest.param(spec, mistake, id=f"{spec.name}: {mistake}") for spec in SPECS for mistake in spec.mistakes
]

MARKERS = {
    "solution": ("### BEGIN SOLUTION", "### END SOLUTION"),
    "hidden": ("### BEGIN HIDDEN TESTS", "### END HIDDEN TESTS"),
}


# ---------------------------------------------------------------------------- helpers
def read_notebook(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def source_notebook(spec: ExerciseSpec) -> dict:
    return read_notebook(EXERCISES / "source" / spec.name / spec.notebook)


def cell_source(cell: dict) -> str:
    source = cell["source"]
    return source if isinstance(source, str) else "".join(source)


def grade_id(cell: dict) -> str | None:
    return cell.get("metadata", {}).get("nbgrader", {}).get("grade_id")


def cells_by_grade_id(notebook: dict) -> dict[str, dict]:
    return {grade_id(c): c for c in notebook["cells"] if grade_id(c) is not None}


def split_marked(source: str, kind: str) -> tuple[list[str], list[str]]:
    """Lines strictly between the ``kind`` markers, and the lines outside them."""
    begin, end = MARKERS[kind]
    inside, outside, depth = [], [], 0
    for line in source.splitlines():
        stripped = line.strip()
        if stripped == begin:
            depth += 1
        elif stripped == end:
            depth -= 1
        elif depth:
            inside.append(line)
        else:
            outside.append(line)
    assert depth == 0, f"unbalanced {kind} markers"
    return inside, outside


def source_solutions(spec: ExerciseSpec) -> dict[str, str]:
    """The instructor's answer: each solution cell of the source without its marker lines."""
    cells = cells_by_grade_id(source_notebook(spec))
    markers = set(MARKERS["solution"])
    return {
        name: "\n".join(line for line in cell_source(cells[name]).splitlines() if line.strip() not in markers)
        for name in spec.solutions
    }


def committed_stubs(spec: ExerciseSpec) -> dict[str, str]:
    """What a student starts from: the solution cells of the committed release."""
    cells = cells_by_grade_id(read_notebook(EXERCISES / "release" / spec.name / spec.notebook))
    return {name: cell_source(cells[name]) for name in spec.solutions}


def with_mistake(spec: ExerciseSpec, mistake: str) -> dict[str, str]:
    old, new = spec.mistakes[mistake]
    solutions = source_solutions(spec)
    found = sum(code.count(old) for code in solutions.values())
    assert found == 1, f"{spec.name}, mistake {mistake!r}: {old!r} occurs {found} times in the solution, not once"
    return {name: code.replace(old, new) for name, code in solutions.items()}


def run_in_process(spec: ExerciseSpec, answers: dict[str, str]) -> dict[str, str | None]:
    """Run the source notebook's code cells in this process, as the autograder runs them.

    The solution cells are replaced by ``answers``; the graded cells keep their hidden tests
    (the markers are comments). Returns, per graded cell, None when it passed or the error
    (``"Type: message"``) when it raised. Another cell that raises fails the test.
    """
    namespace: dict = {"__name__": f"exercise_{spec.name}"}
    outcome: dict[str, str | None] = {}
    for cell in source_notebook(spec)["cells"]:
        if cell["cell_type"] != "code":
            continue
        name = grade_id(cell)
        code = textwrap.dedent(answers[name]) if name in answers else cell_source(cell)
        try:
            exec(compile(code, f"<{spec.name}:{name}>", "exec"), namespace)
        except Exception as error:  # noqa: BLE001 -- a failing graded cell is a result, not a test error
            if name not in spec.points:
                raise
            outcome[name] = f"{type(error).__name__}: {error}"
        else:
            if name in spec.points:
                outcome[name] = None
    return outcome


def student_functions(spec: ExerciseSpec) -> list[str]:
    """Names of the functions the student writes, from the ``def`` lines of the spec."""
    return [name for lines in spec.solutions.values() for name in re.findall(r"^def (\w+)\(", lines, re.M)]


def unguarded_uses(source: str, functions: list[str]) -> list[str]:
    """Uses of a student's function in ``source`` that are not the argument of ``own_work(...)``."""
    tree = ast.parse(source)
    wrapped = {
        id(arg)
        for node in ast.walk(tree)
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "own_work"
        for arg in node.args[:1]
    }
    return [
        f"line {node.lineno}: {node.id}"
        for node in ast.walk(tree)
        if isinstance(node, ast.Name) and node.id in functions and id(node) not in wrapped
    ]


def score(spec: ExerciseSpec, outcome: dict[str, str | None]) -> int:
    return sum(points for name, points in spec.points.items() if outcome[name] is None)


def copy_course(destination: Path) -> Path:
    """Copy exercises/ without the instructor's working state and without release/."""
    shutil.copytree(
        EXERCISES,
        destination,
        ignore=shutil.ignore_patterns(
            "gradebook.db", "submitted", "autograded", "feedback", "release", "source_with_tests",
            "*.csv", ".ipynb_checkpoints", "__pycache__",
        ),
    )
    return destination


def nbgrader_env(course: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env["JUPYTER_CONFIG_DIR"] = str(course / ".jupyter-config")  # no user-level nbgrader config
    return env


def run_nbgrader(course: Path, *args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [sys.executable, "-m", "nbgrader", *args],
        cwd=course,
        env=nbgrader_env(course),
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert proc.returncode == 0, f"nbgrader {' '.join(args)} failed:\n{proc.stdout}\n{proc.stderr}"
    return proc


def files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def write_submission(course: Path, student: str, spec: ExerciseSpec, notebook: dict) -> None:
    folder = course / "submitted" / student / spec.name
    folder.mkdir(parents=True)
    (folder / spec.notebook).write_text(json.dumps(notebook, indent=1), encoding="utf-8")


def with_answers(release: dict, answers: dict[str, str]) -> dict:
    notebook = json.loads(json.dumps(release))
    cells = cells_by_grade_id(notebook)
    for name, code in answers.items():
        cells[name]["source"] = textwrap.dedent(code).strip("\n")
    return notebook


@pytest.fixture(scope="module")
def generated_course(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the course with release/ generated for every assignment.

    ``--no-db`` writes the same release (byte for byte) without creating gradebook.db, which
    takes most of the time; the autograding test generates its own course with the gradebook.
    """
    course = copy_course(tmp_path_factory.mktemp("ex") / "course")
    run_nbgrader(course, "generate_assignment", "*", "--force", "--no-db")
    return course


# ---------------------------------------------------------------------------- the course
def test_every_exercise_has_a_spec_and_a_release():
    sources = sorted(p.name for p in (EXERCISES / "source").iterdir() if p.is_dir() and not p.name.startswith("."))
    releases = sorted(p.name for p in (EXERCISES / "release").iterdir() if p.is_dir() and not p.name.startswith("."))
    specs = [spec.name for spec in SPECS]
    assert sources == specs, "every exercises/source/<name>/ needs a tests/exercise_specs/<name>.py, and back"
    assert releases == sources, "exercises/release/ does not match source/: run `make release`"
    for name in sources:
        assert (EXERCISES / "source" / name / f"{name}.ipynb").is_file(), f"source/{name}/ must hold {name}.ipynb"


# ---------------------------------------------------------------------------- the source notebooks
@pytest.mark.parametrize("spec", BY_SPEC)
def test_source_points_and_cells(spec: ExerciseSpec):
    notebook = source_notebook(spec)
    cells = cells_by_grade_id(notebook)
    assert len(cells) == len(notebook["cells"]), "every cell needs nbgrader metadata with a grade_id"
    graded = {
        name: c["metadata"]["nbgrader"]["points"] for name, c in cells.items() if c["metadata"]["nbgrader"]["grade"]
    }
    assert graded == dict(spec.points)
    solutions = [name for name, c in cells.items() if c["metadata"]["nbgrader"]["solution"]]
    assert solutions == list(spec.solutions), "solution cells (in notebook order) differ from the spec"
    for name, cell in cells.items():
        meta = cell["metadata"]["nbgrader"]
        assert meta["locked"] is (name not in spec.solutions), f"{name}: only solution cells are unlocked"
        assert cell.get("id") == name, f"cell {name}: give the cell the id of its grade_id"
        assert cell.get("outputs", []) == [] and cell.get("execution_count") is None, f"{name} stored with outputs"
        if name in spec.solutions:
            for line in spec.solutions[name].splitlines():
                assert line in cell_source(cell), f"{name} must contain {line!r}"
    # the guard is its own graded cell, and the only one that forbids calls into labkit with forbid_package_calls
    users = [name for name, cell in cells.items() if "forbid_package_calls" in cell_source(cell)]
    assert users == [spec.guard]
    # ... every other graded cell calls the student's functions only through own_work, so that a
    # submission that delegates to labkit fails every graded cell
    functions = student_functions(spec)
    assert functions, f"{spec.name}: the spec's solution lines name no function"
    for name in spec.points:
        if name == spec.guard:
            continue
        source = cell_source(cells[name])
        assert unguarded_uses(source, functions) == [], f"{name} calls a student's function without own_work"
        for function in functions:
            assert f"own_work({function}" in source, f"{name} must wrap {function} in own_work"
    # solutions and hidden tests sit where the spec says; graded cells end in no bare expression
    for name, cell in cells.items():
        source = cell_source(cell)
        assert bool(split_marked(source, "solution")[0]) is (name in spec.solutions), f"{name}: solution markers"
        assert bool(split_marked(source, "hidden")[0]) is (name in spec.hidden), f"{name}: hidden test markers"
        if name in spec.points:
            last = ast.parse(source).body[-1]
            shows_nothing = not isinstance(last, ast.Expr) or (
                isinstance(last.value, ast.Call) and getattr(last.value.func, "id", None) == "print"
            )
            assert shows_nothing, f"{name} ends in a bare expression: nbgrader would read a number it shows as credit"


@pytest.mark.parametrize("spec", BY_SPEC)
def test_source_solution_earns_every_point_and_does_its_own_work(spec: ExerciseSpec):
    outcome = run_in_process(spec, source_solutions(spec))
    assert outcome == dict.fromkeys(spec.points), outcome  # the guard cell passing is the own-work proof
    assert score(spec, outcome) == spec.total


@pytest.mark.parametrize("spec", BY_SPEC)
def test_cheater_is_correct_but_caught_in_every_graded_cell(spec: ExerciseSpec, monkeypatch: pytest.MonkeyPatch):
    outcome = run_in_process(spec, dict(spec.cheater))
    failed = {name: error for name, error in outcome.items() if error is not None}
    assert set(failed) == set(spec.points), f"the cheater should fail every graded cell: {outcome}"
    for name, error in failed.items():
        assert error.startswith("AssertionError: "), (name, error)
        assert "calls labkit's own implementation" in error, (name, error)
        assert re.search(r"\(labkit\.", error), (name, error)
    assert re.search(spec.caught, failed[spec.guard]), failed[spec.guard]
    assert score(spec, outcome) == 0

    # ... although its answers are right: with own_work switched off (the functions called
    # directly) it passes every graded cell but the own-work cell, which uses forbid_package_calls
    monkeypatch.setattr(labkit.grading, "own_work", lambda func, *args, **kwargs: func)
    outcome = run_in_process(spec, dict(spec.cheater))
    errors = {name: error for name, error in outcome.items() if error is not None}
    assert list(errors) == [spec.guard], f"called directly, the cheater should fail the guard only: {errors}"
    assert errors[spec.guard].startswith("AssertionError: ")
    assert re.search(spec.caught, errors[spec.guard]), errors[spec.guard]
    assert score(spec, outcome) == spec.total - spec.points[spec.guard]


@pytest.mark.parametrize("spec", BY_SPEC)
def test_blank_stubs_earn_nothing(spec: ExerciseSpec):
    outcome = run_in_process(spec, committed_stubs(spec))
    assert all(error is not None and error.startswith("NotImplementedError") for error in outcome.values()), outcome


@pytest.mark.parametrize(("spec", "mistake"), BY_MISTAKE)
def test_hidden_tests_catch_a_plausible_mistake(spec: ExerciseSpec, mistake: str):
    outcome = run_in_process(spec, with_mistake(spec, mistake))
    failed = {name for name, error in outcome.items() if error is not None}
    assert failed & spec.hidden, f"no hidden test caught the mistake {mistake!r}: {outcome}"
    # ... as a wrong answer: the mistake still does its own work
    assert not any("own implementation" in error for error in outcome.values() if error is not None), outcome


# ---------------------------------------------------------------------------- release generation
@pytest.mark.slow
@pytest.mark.parametrize("spec", BY_SPEC)
def test_release_has_stubs_and_no_solutions_or_hidden_tests(spec: ExerciseSpec, generated_course: Path):
    release = read_notebook(generated_course / "release" / spec.name / spec.notebook)
    source = source_notebook(spec)
    release_cells = cells_by_grade_id(release)
    assert [grade_id(c) for c in release["cells"]] == [grade_id(c) for c in source["cells"]]
    text = json.dumps(release)
    for begin, end in MARKERS.values():
        assert begin not in text and end not in text

    for name, cell in cells_by_grade_id(source).items():
        released = cell_source(release_cells[name])
        released_lines = {line.strip() for line in released.splitlines()}
        for kind in MARKERS:
            inside, outside = split_marked(cell_source(cell), kind)
            shared = {line.strip() for line in outside}  # also visible on purpose
            leaked = [
                line for line in inside if line.strip() and line.strip() not in shared
                and line.strip() in released_lines
            ]
            assert not leaked, f"{kind} text of cell {name} leaked into the release: {leaked}"
        if name in spec.solutions:
            assert "# YOUR CODE HERE" in released and "raise NotImplementedError()" in released, name
            for line in spec.solutions[name].splitlines():
                assert line in released, f"the release of {name} lost {line!r}"
        if name in spec.points:
            assert release_cells[name]["metadata"]["nbgrader"]["points"] == spec.points[name]
    for cell in release["cells"]:
        assert cell.get("outputs", []) == []


@pytest.mark.slow
@pytest.mark.parametrize("spec", BY_SPEC)
def test_committed_release_is_what_the_generator_writes(spec: ExerciseSpec, generated_course: Path):
    committed_root = EXERCISES / "release" / spec.name
    generated_root = generated_course / "release" / spec.name
    stale = "exercises/release/ is stale: regenerate it with `make release` (never edit it by hand)"
    assert files_under(committed_root) == files_under(generated_root), stale
    for name in files_under(generated_root):
        committed, generated = committed_root / name, generated_root / name
        if name.endswith(".ipynb"):
            assert [(c["cell_type"], cell_source(c)) for c in read_notebook(committed)["cells"]] == [
                (c["cell_type"], cell_source(c)) for c in read_notebook(generated)["cells"]
            ], f"{name}: {stale}"
        else:
            assert committed.read_bytes() == generated.read_bytes(), stale


# ---------------------------------------------------------------------------- autograding
def per_cell_scores(course: Path, pairs: list[tuple[str, str]]) -> dict[tuple[str, str], dict[str, float]]:
    """Score of every graded cell, per (assignment, student), from the gradebook."""
    script = textwrap.dedent(
        """
        import json, sys
        from nbgrader.api import Gradebook
        scores = []
        with Gradebook("sqlite:///gradebook.db", "labkit") as gradebook:
            for assignment, student in json.loads(sys.argv[1]):
                notebook = gradebook.find_submission_notebook(assignment, assignment, student)
                scores.append({grade.name: grade.score for grade in notebook.grades})
        print(json.dumps(scores))
        """
    )
    proc = subprocess.run(
        [sys.executable, "-c", script, json.dumps(pairs)], cwd=course, env=nbgrader_env(course),
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    return dict(zip(pairs, json.loads(proc.stdout), strict=True))


def error_names(notebook: dict) -> dict[str, list[str]]:
    return {
        grade_id(cell): [out["ename"] for out in cell.get("outputs", []) if out["output_type"] == "error"]
        for cell in notebook["cells"]
        if grade_id(cell) is not None
    }


@pytest.mark.slow
def test_autograde_and_export(tmp_path: Path):
    """Every exercise autograded: solution full marks, blank 0, cheater 0 (caught in every graded cell), looper 0."""
    course = copy_course(tmp_path / "course")
    run_nbgrader(course, "generate_assignment", "*", "--force")  # the release, and the assignments in gradebook.db
    submitted: dict[tuple[str, str], dict] = {}
    for spec in SPECS:
        release = read_notebook(course / "release" / spec.name / spec.notebook)
        students = {
            "solution": with_answers(release, source_solutions(spec)),
            "blank": release,
            "cheater": with_answers(release, dict(spec.cheater)),
        }
        if spec.looper is not None:
            students["looper"] = with_answers(release, dict(spec.looper))
        for student, notebook in students.items():
            write_submission(course, student, spec, notebook)
            submitted[spec.name, student] = notebook

    start = time.perf_counter()
    run_nbgrader(course, "autograde", "*", "--force")
    seconds = time.perf_counter() - start
    loopers = [spec for spec in SPECS if spec.looper is not None]
    print(f"autograde of {len(submitted)} submissions ({len(loopers)} endless loops): {seconds:.1f} s")
    run_nbgrader(course, "export")

    with open(course / "grades.csv", newline="", encoding="utf-8") as f:
        rows = {(row["assignment"], row["student_id"]): row for row in csv.DictReader(f)}
    assert set(submitted) <= set(rows), "a submission is missing from grades.csv"
    cells = per_cell_scores(course, sorted(submitted))
    for spec in SPECS:
        full = {name: float(p) for name, p in spec.points.items()}
        expected = {"solution": spec.total, "blank": 0, "cheater": 0}
        expected_cells = {"solution": full, "blank": dict.fromkeys(full, 0.0), "cheater": dict.fromkeys(full, 0.0)}
        if spec.looper is not None:
            expected["looper"] = 0
            expected_cells["looper"] = dict.fromkeys(full, 0.0)
        scores = {student: float(rows[spec.name, student]["score"]) for student in expected}
        assert scores == expected, f"{spec.name}: {scores}"
        for student in expected:
            assert float(rows[spec.name, student]["max_score"]) == spec.total, (spec.name, student)
            assert cells[spec.name, student] == expected_cells[student], (spec.name, student)

        graded = {
            student: read_notebook(course / "autograded" / student / spec.name / spec.notebook) for student in expected
        }
        assert all(names == [] for names in error_names(graded["solution"]).values()), spec.name
        # a value shown by a graded cell would be read as partial credit: the cells show none
        for cell in graded["solution"]["cells"]:
            assert all(out["output_type"] != "execute_result" for out in cell.get("outputs", [])), grade_id(cell)
        cheater_errors = error_names(graded["cheater"])
        assert all(cheater_errors[name] == [] for name in spec.solutions), cheater_errors
        assert all(cheater_errors[name] == ["AssertionError"] for name in spec.points), cheater_errors
        for cell in graded["cheater"]["cells"]:
            if grade_id(cell) in spec.points:
                (error,) = [out for out in cell["outputs"] if out["output_type"] == "error"]
                assert "calls labkit's own implementation" in error["evalue"], (spec.name, grade_id(cell), error)
        blank_errors = error_names(graded["blank"])
        assert all(blank_errors[name] == [] for name in spec.solutions), blank_errors
        assert all(blank_errors[name] == ["NotImplementedError"] for name in spec.points), blank_errors
        if spec.looper is not None:
            # the looper hit the per-cell timeout in every graded cell (each calls its function), and the
            # students after it were still graded (nbgrader records the kernel's KeyboardInterrupt and
            # its CellTimeoutError)
            timed_out = {name for name, names in error_names(graded["looper"]).items() if "CellTimeoutError" in names}
            assert timed_out == set(spec.points), spec.name
    looper_cells = sum(len(spec.points) for spec in loopers)
    budget = looper_cells * CELL_TIMEOUT_S + 10 * len(submitted) + 60
    assert seconds < budget, f"autograde took {seconds:.0f} s (> {budget} s): did the per-cell timeout bound the loop?"


# ---------------------------------------------------------------------------- labkit.grading
def numpy_only(ranges, angles):
    r = np.asarray(ranges, dtype=np.float64)
    a = np.asarray(angles, dtype=np.float64)
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def via_polar_to_cartesian(ranges, angles):
    return labkit.polar_to_cartesian(ranges, angles)


def test_calls_into_catches_polar_to_cartesian():
    assert calls_into("labkit", via_polar_to_cartesian, [1.0, 2.0], [0.0, 1.0])
    record = record_package_calls("labkit", via_polar_to_cartesian, [1.0], [0.0])
    assert record.calls == ("labkit.scan.polar_to_cartesian",)
    assert not record.tampered and not record.clean
    np.testing.assert_allclose(record.result, [[1.0, 0.0]])


def test_numpy_only_function_is_not_caught():
    record = record_package_calls("labkit", numpy_only, [1.0, 2.0], [0.0, np.pi / 2])
    assert record.clean and record.calls == ()
    assert not calls_into("labkit", numpy_only, [1.0], [0.0])
    np.testing.assert_allclose(forbid_package_calls("labkit", numpy_only, [2.0], [0.0]), [[2.0, 0.0]])


def test_scan_properties_and_dataclass_init_are_caught():
    def via_scan(ranges, angles):
        return labkit.Scan(ranges=ranges, angles=angles).xy

    calls = record_package_calls("labkit", via_scan, [1.0, 2.0], [0.0, 1.0]).calls
    assert "labkit.scan.Scan.__post_init__" in calls and "labkit.scan.Scan.xy" in calls
    assert "labkit.scan.Scan.__init__" in calls  # generated by dataclasses, filename "<string>"


def test_indirect_calls_are_caught():
    import functools

    assert calls_into("labkit", functools.partial(labkit.polar_to_cartesian, [1.0]), [0.0])
    assert calls_into("labkit", labkit.polar_to_cartesian, [1.0], [0.0])  # the function itself
    assert calls_into("labkit", lambda: labkit.geometry.wrap_angle(4.0))
    assert calls_into("labkit", lambda: list(map(labkit.wrap_angle, [4.0])))  # called from C


def test_calls_from_threads_the_function_starts_are_caught():
    def in_a_thread(ranges, angles):
        out = []
        worker = threading.Thread(target=lambda: out.append(labkit.polar_to_cartesian(ranges, angles)))
        worker.start()
        worker.join()
        return out[0]

    calls = record_package_calls("labkit", in_a_thread, [1.0], [0.0]).calls
    assert calls == ("labkit.scan.polar_to_cartesian",)


def test_switching_the_profiler_off_is_caught_and_reported():
    def sneaky(ranges, angles):
        sys.setprofile(None)
        return labkit.polar_to_cartesian(ranges, angles)

    record = record_package_calls("labkit", sneaky, [1.0], [0.0])
    assert record.tampered and not record.clean
    with pytest.raises(AssertionError, match="sys.setprofile"):
        forbid_package_calls("labkit", sneaky, [1.0], [0.0])


def test_grading_helpers_themselves_are_not_counted():
    rng = np.random.default_rng(0)
    assert not calls_into("labkit", random_beams, rng, 5)
    assert not calls_into("labkit", assert_beams_result, (np.zeros((0, 2)), np.zeros(0, int)), [], [])


def test_forbid_names_the_function_and_the_calls():
    with pytest.raises(AssertionError, match=r"via_polar_to_cartesian calls labkit's own implementation"):
        forbid_package_calls("labkit", via_polar_to_cartesian, [1.0], [0.0])


def test_profiler_is_restored_after_return_and_after_an_exception():
    events = []

    def previous(frame, event, arg):
        events.append(event)

    def fails():
        raise KeyError("student bug")

    sys.setprofile(previous)
    try:
        record_package_calls("labkit", numpy_only, [1.0], [0.0])
        assert sys.getprofile() is previous
        with pytest.raises(KeyError, match="student bug"):
            record_package_calls("labkit", fails)
        assert sys.getprofile() is previous
    finally:
        sys.setprofile(None)
    assert threading.getprofile() is None


def test_own_work_passes_an_honest_function_through():
    checked = own_work(numpy_only)
    assert checked.__name__ == "numpy_only" and checked.__wrapped__ is numpy_only
    np.testing.assert_allclose(checked([2.0], [0.0]), [[2.0, 0.0]])
    np.testing.assert_allclose(checked(ranges=[1.0], angles=[np.pi / 2]), [[0.0, 1.0]], atol=1e-12)
    assert sys.getprofile() is None and threading.getprofile() is None


def test_own_work_fails_a_delegating_function_on_every_call():
    checked = own_work(via_polar_to_cartesian)
    for _ in range(2):
        with pytest.raises(AssertionError, match=r"via_polar_to_cartesian calls labkit's own implementation "
                                                 r"\(labkit\.scan\.polar_to_cartesian\)"):
            checked([1.0], [0.0])
    assert sys.getprofile() is None


def test_own_work_reports_the_call_even_when_the_package_raises():
    checked = own_work(via_polar_to_cartesian)
    with pytest.raises(AssertionError, match="own implementation") as caught:
        checked([1.0, 2.0], [0.0])  # labkit raises ValueError for the different lengths
    assert caught.value.__cause__ is None and caught.value.__suppress_context__


def test_own_work_lets_the_students_own_errors_through():
    def stub(ranges, angles):
        raise NotImplementedError()

    def checks_lengths(ranges, angles):
        raise ValueError("ranges and angles must have the same length")

    with pytest.raises(NotImplementedError):
        own_work(stub)([1.0], [0.0])
    with pytest.raises(ValueError, match="ranges and angles"):
        own_work(checks_lengths)([1.0], [0.0, 1.0])
    assert sys.getprofile() is None


def test_own_work_watches_further_packages_in_one_pass():
    def via_numpy_testing(x):
        import numpy.testing

        numpy.testing.assert_array_equal(x, x)
        return x

    assert own_work(via_numpy_testing)([1.0]) == [1.0]
    with pytest.raises(AssertionError, match=r"numpy's own implementation \(numpy\.testing"):
        own_work(via_numpy_testing, also=("numpy",))([1.0])
    with pytest.raises(AssertionError, match=r"own implementation \(labkit\.scan"):
        own_work(via_polar_to_cartesian, also=("numpy",))([1.0], [0.0])
    with pytest.raises(ValueError, match="package"):
        own_work(numpy_only, also=("no_such_package_xyz",))


def test_own_work_catches_switching_the_profiler_off():
    def sneaky(ranges, angles):
        sys.setprofile(None)
        return labkit.polar_to_cartesian(ranges, angles)

    with pytest.raises(AssertionError, match="sys.setprofile"):
        own_work(sneaky)([1.0], [0.0])
    assert sys.getprofile() is None


def test_own_work_costs_little_per_call():
    checked = own_work(numpy_only)
    start = time.perf_counter()
    for _ in range(2000):
        checked([1.0], [0.0])
    assert time.perf_counter() - start < 2.0


def test_arguments_named_like_the_helpers_parameters_pass_through():
    record = record_package_calls("labkit", lambda **kw: kw, package="p", func="f")
    assert record.result == {"package": "p", "func": "f"}


@pytest.mark.parametrize("package", ["", ".labkit", "no_such_package_xyz"])
def test_unknown_package_is_a_value_error(package):
    with pytest.raises(ValueError, match="package"):
        record_package_calls(package, numpy_only, [1.0], [0.0])


def test_random_beams_is_reproducible_and_accepted_by_scan():
    first = random_beams(np.random.default_rng(42))
    second = random_beams(np.random.default_rng(42))
    assert first["ranges"].tobytes() == second["ranges"].tobytes()
    assert first["angles"].tobytes() == second["angles"].tobytes()
    assert (first["range_min"], first["range_max"]) == (second["range_min"], second["range_max"])
    rng = np.random.default_rng(1)
    for n_beams in [0, 1, 2, 3, None, None, None, None]:
        beams = random_beams(rng, n_beams)
        scan = labkit.Scan(**beams)  # angles strictly increasing, span <= 2 pi, limits ordered
        if n_beams is None:
            assert 2 <= scan.n_beams <= 720
        else:
            assert scan.n_beams == n_beams


def test_random_beams_injects_every_kind_of_invalid_reading():
    rng = np.random.default_rng(3)
    seen = dict.fromkeys(["nan", "inf", "-inf", "zero", "negative", "at_max", "beyond_max", "below_min",
                          "at_min_valid"], 0)
    for _ in range(40):
        beams = random_beams(rng, 200, invalid_fraction=0.5)
        r, lo, hi = beams["ranges"], beams["range_min"], beams["range_max"]
        with np.errstate(invalid="ignore"):
            seen["nan"] += int(np.isnan(r).sum())
            seen["inf"] += int(np.isposinf(r).sum())
            seen["-inf"] += int(np.isneginf(r).sum())
            seen["zero"] += int((r == 0).sum())
            seen["negative"] += int((np.isfinite(r) & (r < 0)).sum())
            seen["at_max"] += int((r == hi).sum())
            seen["beyond_max"] += int((np.isfinite(r) & (r > hi)).sum())
            seen["below_min"] += int(((r > 0) & (r < lo)).sum())
            seen["at_min_valid"] += int(((r == lo) & (lo > 0)).sum())
    assert all(count > 0 for count in seen.values()), seen


def test_random_beams_invalid_fraction_extremes():
    rng = np.random.default_rng(5)
    for _ in range(10):
        assert labkit.Scan(**random_beams(rng, 50, invalid_fraction=0.0)).valid.all()
        assert not labkit.Scan(**random_beams(rng, 50, invalid_fraction=1.0)).valid.any()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_beams": -1}, "n_beams"),
        ({"n_beams": 2.5}, "n_beams"),
        ({"invalid_fraction": 1.5}, "invalid_fraction"),
        ({"max_beams": 1}, "max_beams"),
    ],
)
def test_random_beams_rejects_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        random_beams(np.random.default_rng(0), **kwargs)
    with pytest.raises(ValueError, match="rng"):
        random_beams(0)


@pytest.mark.parametrize(
    ("result", "match"),
    [
        ([np.zeros((1, 2)), np.array([0])], "tuple"),
        ((np.zeros((1, 2)),), "tuple"),
        (([[1.0, 0.0]], np.array([0])), "points must be a numpy array"),
        ((np.zeros((1, 3)), np.array([0])), r"shape \(1, 2\)"),
        ((np.array([[1, 0]]), np.array([0])), "float64"),
        ((np.array([[1.0, 0.0]]), np.array([0.0])), "integers"),
        ((np.array([[1.0, 0.0]]), np.array([1])), "position 0 should be beam 0"),
        ((np.array([[1.0, 1e-6]]), np.array([0])), "row 0"),
    ],
)
def test_assert_beams_result_says_what_is_wrong(result, match):
    assert_beams_result((np.array([[1.0, 0.0]]), np.array([0])), [[1.0, 0.0]], [0])
    with pytest.raises(AssertionError, match=match):
        assert_beams_result(result, [[1.0, 0.0]], [0])


def test_random_wall_beams_is_reproducible_partial_and_accepted_by_scan():
    first = random_wall_beams(np.random.default_rng(42))
    second = random_wall_beams(np.random.default_rng(42))
    assert first["ranges"].tobytes() == second["ranges"].tobytes()
    assert first["angles"].tobytes() == second["angles"].tobytes()
    rng = np.random.default_rng(1)
    for n_beams in [0, 1, 2, 3, 4, 5, *[None] * 200]:
        beams = random_wall_beams(rng, n_beams)
        scan = labkit.Scan(**beams)  # angles strictly increasing, span <= 2 pi
        assert not scan.is_full_circle  # first and last beams are never neighbours
        if n_beams is None:
            assert 2 <= scan.n_beams <= 720
        else:
            assert scan.n_beams == n_beams


def test_random_wall_beams_has_walls_clutter_and_every_invalid_reading():
    rng = np.random.default_rng(3)
    seen = dict.fromkeys(["nan", "inf", "-inf", "zero", "negative"], 0)
    longest, n_segments = [], []
    for _ in range(100):
        beams = random_wall_beams(rng, 500)
        r = beams["ranges"]
        seen["nan"] += int(np.isnan(r).sum())
        seen["inf"] += int(np.isposinf(r).sum())
        seen["-inf"] += int(np.isneginf(r).sum())
        seen["zero"] += int((r == 0).sum())
        seen["negative"] += int((np.isfinite(r) & (r < 0)).sum())
        labels = labkit.segment_labels(labkit.Scan(**beams), 0.1, min_points=1)
        sizes = np.bincount(labels[labels >= 0])
        longest.append(sizes.max(initial=0))
        n_segments.append(sizes.size)
    assert all(count > 0 for count in seen.values()), seen
    assert np.median(longest) >= 20, "walls should give long runs of neighbouring points"
    assert np.median(n_segments) >= 5, "jumps, clutter and invalid readings should cut the scan"
    for _ in range(10):
        assert not labkit.Scan(**random_wall_beams(rng, 50, invalid_fraction=1.0)).valid.any()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"n_beams": -1}, "n_beams"), ({"invalid_fraction": -0.1}, "invalid_fraction"), ({"max_beams": 1}, "max_beams")],
)
def test_random_wall_beams_rejects_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        random_wall_beams(np.random.default_rng(0), **kwargs)
    with pytest.raises(ValueError, match="rng"):
        random_wall_beams(np.random.default_rng)


@pytest.mark.parametrize(
    ("result", "match"),
    [
        ([0, 0, -1], "numpy array"),
        (np.array([0, 0]), r"shape \(3,\)"),
        (np.array([0.0, 0.0, -1.0]), "integers"),
        (np.array([0, 1, -1]), r"beam 1 should be 0, got 1"),
    ],
)
def test_assert_labels_result_says_what_is_wrong(result, match):
    assert_labels_result(np.array([0, 0, -1], dtype=np.int32), [0, 0, -1])
    with pytest.raises(AssertionError, match=match):
        assert_labels_result(result, [0, 0, -1])


def test_assert_labels_result_shows_the_neighbourhood_of_a_long_scan():
    expected = np.zeros(100, dtype=int)
    wrong = expected.copy()
    wrong[50] = 3
    with pytest.raises(AssertionError, match=r"beam 50 should be 0, got 3 \(expected around beams 47..53"):
        assert_labels_result(wrong, expected)


@pytest.mark.parametrize(
    ("result", "match"),
    [
        ([2.0, 0.0], "tuple"),
        ((2.0,), "tuple"),
        ((np.array([2.0]), 0.0), "r must be a number"),
        ((2.0, True), "alpha must be a number"),
        ((np.nan, 0.0), "finite"),
        ((-2.0, np.pi), "r must be >= 0"),
        ((2.0, -np.pi), r"alpha must be in \(-pi, pi\]"),
        ((2.0, 3 * np.pi / 2), r"alpha must be in \(-pi, pi\]"),
        ((2.1, 0.0), "r is wrong"),
        ((2.0, 0.01), "alpha is wrong"),
    ],
)
def test_assert_line_result_says_what_is_wrong(result, match):
    assert_line_result((2.0, np.float64(1e-9)), 2.0, 0.0)
    assert_line_result((1.0, np.pi), 1.0, -np.pi + 1e-9)  # close across the wrap
    with pytest.raises(AssertionError, match=match):
        assert_line_result(result, 2.0, 0.0)
