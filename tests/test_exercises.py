"""The nbgrader course in ``exercises/``: release generation, autograding, and ``labkit.grading``.

The slow tests copy ``exercises/`` into a temporary folder and run nbgrader there in a
subprocess (``python -m nbgrader``), so they never write into the repository. nbgrader 0.9
runs the ``alembic`` executable when it creates a gradebook, so the subprocesses get this
interpreter's ``bin/`` folder on ``PATH``; user-level Jupyter configuration is kept out with an
empty ``JUPYTER_CONFIG_DIR``.
"""

from __future__ import annotations

import csv
import json
import os
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
    calls_into,
    forbid_package_calls,
    random_beams,
    record_package_calls,
)

REPO = Path(__file__).resolve().parents[1]
EXERCISES = REPO / "exercises"
ASSIGNMENT = "ex00_polar_to_cartesian"
NOTEBOOK = f"{ASSIGNMENT}.ipynb"
SOURCE_NOTEBOOK = EXERCISES / "source" / ASSIGNMENT / NOTEBOOK

SOLUTION_CELL = "beams_to_points"
GUARD_CELL = "test_own_work"
POINTS = {"test_visible": 2, "test_hidden_random": 4, "test_hidden_edges": 2, GUARD_CELL: 2}
TOTAL = sum(POINTS.values())
CELL_TIMEOUT_S = 10  # c.Execute.timeout in exercises/nbgrader_config.py

MARKERS = {
    "solution": ("### BEGIN SOLUTION", "### END SOLUTION"),
    "hidden": ("### BEGIN HIDDEN TESTS", "### END HIDDEN TESTS"),
}

CHEATER_SOLUTION = '''
import labkit


def beams_to_points(ranges, angles, range_min, range_max):
    scan = labkit.Scan(ranges=ranges, angles=angles, range_min=range_min, range_max=range_max)
    return scan.xy, scan.valid_indices
'''

LOOPER_SOLUTION = '''
def beams_to_points(ranges, angles, range_min, range_max):
    while True:
        pass
'''


# ---------------------------------------------------------------------------- helpers
def read_notebook(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


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


def source_solution(grade: str = SOLUTION_CELL) -> str:
    """The instructor's answer: the solution cell of the source without its marker lines."""
    cell = cells_by_grade_id(read_notebook(SOURCE_NOTEBOOK))[grade]
    markers = set(MARKERS["solution"])
    return "\n".join(line for line in cell_source(cell).splitlines() if line.strip() not in markers)


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


def run_nbgrader(course: Path, *args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env["JUPYTER_CONFIG_DIR"] = str(course / ".jupyter-config")  # no user-level nbgrader config
    proc = subprocess.run(
        [sys.executable, "-m", "nbgrader", *args],
        cwd=course,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert proc.returncode == 0, f"nbgrader {' '.join(args)} failed:\n{proc.stdout}\n{proc.stderr}"
    return proc


def files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def notebooks_under(folder: Path) -> dict[str, Path]:
    return {str(p.relative_to(folder)): p for p in sorted(folder.rglob("*.ipynb"))}


def write_submission(course: Path, student: str, notebook: dict) -> None:
    folder = course / "submitted" / student / ASSIGNMENT
    folder.mkdir(parents=True)
    (folder / NOTEBOOK).write_text(json.dumps(notebook, indent=1), encoding="utf-8")


def with_solution(release: dict, code: str) -> dict:
    notebook = json.loads(json.dumps(release))
    cell = cells_by_grade_id(notebook)[SOLUTION_CELL]
    cell["source"] = textwrap.dedent(code).strip("\n")
    return notebook


@pytest.fixture(scope="module")
def generated_course(tmp_path_factory: pytest.TempPathFactory) -> Path:
    course = copy_course(tmp_path_factory.mktemp("ex") / "course")
    run_nbgrader(course, "generate_assignment", ASSIGNMENT, "--force")
    return course


# ---------------------------------------------------------------------------- the source notebook
def test_source_notebook_points_and_cells():
    cells = cells_by_grade_id(read_notebook(SOURCE_NOTEBOOK))
    graded = {
        name: cell["metadata"]["nbgrader"]["points"]
        for name, cell in cells.items()
        if cell["metadata"]["nbgrader"]["grade"]
    }
    assert graded == POINTS
    assert cells[SOLUTION_CELL]["metadata"]["nbgrader"]["solution"] is True
    for name in POINTS:
        assert cells[name]["metadata"]["nbgrader"]["locked"] is True, name
    # the guard is its own graded cell, and the only one that forbids calls into labkit
    users = [name for name, cell in cells.items() if "forbid_package_calls" in cell_source(cell)]
    assert users == [GUARD_CELL]
    for cell in read_notebook(SOURCE_NOTEBOOK)["cells"]:
        assert cell.get("outputs", []) == [] and cell.get("execution_count") is None, "stored with outputs"


def test_source_solution_matches_reference_and_does_its_own_work():
    namespace = {"np": np}
    exec(source_solution(), namespace)
    beams_to_points = namespace["beams_to_points"]
    rng = np.random.default_rng(7)
    for n_beams in [0, 1, 2, None, None, None]:
        beams = random_beams(rng, n_beams)
        scan = labkit.Scan(**beams)
        result = forbid_package_calls("labkit", beams_to_points, **beams)
        assert_beams_result(result, scan.xy, scan.valid_indices)
    with pytest.raises(ValueError, match="ranges and angles"):
        beams_to_points([1.0], [0.0, 1.0], 0.0, 1.0)


def test_cheater_solution_is_correct_but_caught():
    namespace: dict = {}
    exec(CHEATER_SOLUTION, namespace)
    beams = random_beams(np.random.default_rng(8))
    scan = labkit.Scan(**beams)
    assert_beams_result(namespace["beams_to_points"](**beams), scan.xy, scan.valid_indices)
    with pytest.raises(AssertionError, match=r"labkit\.scan\.Scan"):
        forbid_package_calls("labkit", namespace["beams_to_points"], **beams)


# ---------------------------------------------------------------------------- release generation
@pytest.mark.slow
def test_release_has_stubs_and_no_solutions_or_hidden_tests(generated_course: Path):
    release = read_notebook(generated_course / "release" / ASSIGNMENT / NOTEBOOK)
    source = read_notebook(SOURCE_NOTEBOOK)
    release_cells = cells_by_grade_id(release)
    assert [grade_id(c) for c in release["cells"]] == [grade_id(c) for c in source["cells"]]
    text = json.dumps(release)
    for begin, end in MARKERS.values():
        assert begin not in text and end not in text

    n_marked = 0
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
            n_marked += bool(inside)
        if cell["metadata"]["nbgrader"].get("solution"):
            assert "# YOUR CODE HERE" in released and "raise NotImplementedError()" in released
            assert "def beams_to_points(ranges, angles, range_min, range_max):" in released
    assert n_marked == 4  # one solution cell, three cells with hidden tests
    for cell in release["cells"]:
        assert cell.get("outputs", []) == []


@pytest.mark.slow
def test_committed_release_is_what_the_generator_writes(generated_course: Path):
    committed_root = EXERCISES / "release"
    generated_root = generated_course / "release"
    committed_files = files_under(committed_root)
    generated_files = files_under(generated_root)
    stale = "exercises/release/ is stale: regenerate it with `make release` (never edit it by hand)"
    assert committed_files == generated_files, stale
    for name, generated in notebooks_under(generated_root).items():
        committed = read_notebook(committed_root / name)
        fresh = read_notebook(generated)
        assert [(c["cell_type"], cell_source(c)) for c in committed["cells"]] == [
            (c["cell_type"], cell_source(c)) for c in fresh["cells"]
        ], f"{name}: {stale}"
    for name in generated_files:
        if not name.endswith(".ipynb"):
            assert (committed_root / name).read_bytes() == (generated_root / name).read_bytes(), stale


# ---------------------------------------------------------------------------- autograding
def per_cell_scores(course: Path, students: list[str]) -> dict[str, dict[str, float]]:
    script = textwrap.dedent(
        f"""
        import json
        from nbgrader.api import Gradebook
        scores = {{}}
        with Gradebook("sqlite:///gradebook.db", "labkit") as gradebook:
            for student in {students!r}:
                notebook = gradebook.find_submission_notebook({ASSIGNMENT!r}, {ASSIGNMENT!r}, student)
                scores[student] = {{grade.name: grade.score for grade in notebook.grades}}
        print(json.dumps(scores))
        """
    )
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    proc = subprocess.run(
        [sys.executable, "-c", script], cwd=course, env=env, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def error_names(notebook: dict) -> dict[str, list[str]]:
    return {
        grade_id(cell): [out["ename"] for out in cell.get("outputs", []) if out["output_type"] == "error"]
        for cell in notebook["cells"]
        if grade_id(cell) is not None
    }


@pytest.mark.slow
def test_autograde_and_export(tmp_path: Path):
    course = copy_course(tmp_path / "course")
    run_nbgrader(course, "generate_assignment", ASSIGNMENT, "--force")
    release = read_notebook(course / "release" / ASSIGNMENT / NOTEBOOK)
    submissions = {
        "solution": with_solution(release, source_solution()),
        "blank": release,
        "cheater": with_solution(release, CHEATER_SOLUTION),
        "looper": with_solution(release, LOOPER_SOLUTION),
    }
    for student, notebook in submissions.items():
        write_submission(course, student, notebook)

    start = time.perf_counter()
    run_nbgrader(course, "autograde", ASSIGNMENT, "--force")
    seconds = time.perf_counter() - start
    print(f"autograde of {len(submissions)} submissions: {seconds:.1f} s")
    run_nbgrader(course, "export")

    with open(course / "grades.csv", newline="", encoding="utf-8") as f:
        rows = {row["student_id"]: row for row in csv.DictReader(f) if row["assignment"] == ASSIGNMENT}
    assert sorted(rows) == sorted(submissions)  # every student was added and graded
    scores = {student: float(row["score"]) for student, row in rows.items()}
    assert {student: float(row["max_score"]) for student, row in rows.items()} == dict.fromkeys(rows, TOTAL)
    assert scores == {"solution": TOTAL, "blank": 0.0, "cheater": TOTAL - POINTS[GUARD_CELL], "looper": 0.0}

    cells = per_cell_scores(course, sorted(submissions))
    assert cells["solution"] == {name: float(p) for name, p in POINTS.items()}
    assert cells["cheater"] == {name: float(p) for name, p in POINTS.items()} | {GUARD_CELL: 0.0}
    assert cells["blank"] == cells["looper"] == dict.fromkeys(POINTS, 0.0)

    autograded = course / "autograded"
    graded = {student: read_notebook(autograded / student / ASSIGNMENT / NOTEBOOK) for student in submissions}
    # the looper hit the per-cell timeout in every graded cell (each calls its function), and the
    # students after it were still graded (asserted above: autograde goes in alphabetical order)
    # (nbgrader records the KeyboardInterrupt of the interrupted kernel and its CellTimeoutError)
    timed_out = {name for name, names in error_names(graded["looper"]).items() if "CellTimeoutError" in names}
    assert timed_out == set(POINTS)
    assert seconds < len(POINTS) * CELL_TIMEOUT_S + 120, "the per-cell timeout did not bound the loop"
    assert all(names == [] for names in error_names(graded["solution"]).values())
    # a value shown by a graded cell would be read as partial credit: the cells show none
    for cell in graded["solution"]["cells"]:
        assert all(out["output_type"] != "execute_result" for out in cell.get("outputs", [])), grade_id(cell)
    guard_errors = error_names(graded["cheater"])
    assert guard_errors[GUARD_CELL] == ["AssertionError"]
    assert all(names == [] for name, names in guard_errors.items() if name != GUARD_CELL)
    assert set(error_names(graded["blank"])[SOLUTION_CELL]) == set()
    assert all(error_names(graded["blank"])[name] == ["NotImplementedError"] for name in POINTS)


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
