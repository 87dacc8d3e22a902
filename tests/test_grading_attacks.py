"""The attack suite: a class of honest, broken and cheating submissions graded in one ``labkit grade`` run.

Every attack the grading issue lists (adapted to the sandboxed grader) and more get their own
student. Each must score exactly what its own code earns -- 0 for the cheats, full marks for an
honest answer wrapped in a disruption (a fork bomb, a memory bomb, 50 MB of output, killing its
parent) -- while the honest solution graded in the same run scores full marks and every student
gets a verdict. The run's gradebook, ``grades.csv``, records and autograded notebooks are checked
afterwards, and ``nbgrader export`` and ``generate_feedback`` run on them.

The attacks know the real paths of the course, the gradebook, the repository and the other
students' submissions (they are formatted into their code), so "unreachable" is tested, not
assumed.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from labkit.grading import grade
from labkit.grading.exercises import Course
from labkit.grading.protocol import clean_text
from labkit.grading.records import Records
from labkit.grading.sandbox import worker_uid
from tests.grading_course import (
    REPO,
    cell_source,
    copy_course,
    grade_id,
    notebook_with,
    once_per_session,
    read_notebook,
    release_notebook,
    solutions,
    submit,
)

pytestmark = pytest.mark.slow

EX0, EX1, EX2, EX4 = "ex00_polar_to_cartesian", "ex01_range_segmentation", "ex02_weighted_line_fit", "ex06_dbscan1d"
FULL = 10.0
HALF = FULL / 2  # points are per function: an attack on ex01's segment leaves the instructor's adaptive_threshold,
#                  which earns its own half; the attacked function earns 0 in every cell


class AtMost(float):
    """The expected score of an attack that races the grader: its honest functions' points at most (its own forged
    frames may crash the calls of those too), never a point for the function it cheats with."""
SLOT = 10  # this run's students are uids worker_uid(10) and worker_uid(11): no other test uses them

WRONG_SEGMENT = '''
def segment(ranges, angles, threshold_m, min_points):
    return np.zeros(len(ranges), dtype=np.int64)
'''


def solution(name: str) -> str:
    """The instructor's first solution cell: the function the attacks below wrap or replace (the
    exercise's other solution cells, such as ex01's adaptive threshold, keep the instructor's answer)."""
    return next(iter(solutions(name).values()))


def wrapped_segment(guard: str) -> str:
    """The instructor's segment, renamed, behind a function that first runs ``guard``."""
    body = textwrap.indent(textwrap.dedent(guard).strip(), "    ")
    return (solution(EX1).replace("def segment(", "def _segment(")
            + f"\n\n\ndef segment(ranges, angles, threshold_m, min_points):\n{body}\n"
            + "    return _segment(ranges, angles, threshold_m, min_points)\n")


# ---------------------------------------------------------------------------- the class
# student -> (exercise, code of the solution cell, extra cells before it, expected score, expected status)
CHEATS = {  # each earns 0 for the function it cheats with, and what its honest functions earn
    # calling labkit (or switching the old own-work profiler off first): labkit is not in the sandbox
    "delegate": (EX1, "DELEGATE", [], 0.0, "graded"),
    "delegate_guard_off": (EX1, "DELEGATE", ["""
        import sys
        sys.setprofile(None)
        import labkit.grading
        labkit.grading.own_work = lambda f, *args, **kwargs: f
    """], 0.0, "graded"),
    "delegate_raw_thread": (EX1, '''
        import _thread
        import time

        def segment(ranges, angles, threshold_m, min_points):
            box = []

            def work():
                try:
                    import labkit
                    box.append(labkit.segment_labels(labkit.Scan(ranges=ranges, angles=angles), threshold_m,
                                                     min_points=min_points))
                except BaseException:
                    box.append(np.zeros(len(ranges), dtype=np.int64))

            _thread.start_new_thread(work, ())
            while not box:
                time.sleep(0.001)
            return box[0]
    ''', [], HALF, "graded"),
    # labkit by path: the repository, a copy of the package, the editable finder, getsource + exec
    "delegate_by_path": (EX1, '''
        import importlib.util, inspect, site, sys

        _found = []  # the search runs once, as a cheat after full marks would write it: run at every
                     # call it took longer than the 5 s call limit on a loaded machine (graded
                     # "timed out", not the verdict on what the search finds)

        def _labkit():
            if not _found:
                try:
                    _found.append(_search())
                except Exception as exc:
                    _found.append(exc)
            if isinstance(_found[0], Exception):
                raise _found[0]
            return _found[0]

        def _search():
            for folder in ["{repo}", "/work/main", "{repo}/.venv/lib/python3.11/site-packages", *sys.path]:
                try:
                    site.addsitedir(folder)
                except Exception:
                    pass
                for init in [folder + "/labkit/__init__.py", folder + "/labkit_copy/__init__.py"]:
                    try:
                        spec = importlib.util.spec_from_file_location("labkit", init)
                        module = importlib.util.module_from_spec(spec)
                        spec.loader.exec_module(module)
                        return module
                    except Exception:
                        pass
            import labkit
            namespace = {}
            exec(inspect.getsource(labkit.segmentation), namespace)
            return labkit

        def segment(ranges, angles, threshold_m, min_points):
            try:
                labkit = _labkit()
                return labkit.segment_labels(labkit.Scan(ranges=ranges, angles=angles), threshold_m,
                                             min_points=min_points)
            except Exception:
                return np.zeros(len(ranges), dtype=np.int64)
    ''', [], HALF, "graded"),
    # reading the answers: the trusted side's globals and locals, gc, the files of the course
    "reads_reference": (EX1, '''
        import gc, sys

        def segment(ranges, angles, threshold_m, min_points):
            frame = sys._getframe()
            while frame is not None:
                for scope in (frame.f_locals, frame.f_globals):
                    for name in ("reference", "expected", "want", "want_labels"):
                        if name in scope:
                            return np.asarray(scope[name])
                frame = frame.f_back
            for thing in gc.get_objects():
                if isinstance(thing, np.ndarray) and thing.dtype.kind == "i" and thing.shape == (len(ranges),):
                    return thing
            return np.zeros(len(ranges), dtype=np.int64)
    ''', [], HALF, "graded"),
    "reads_files": (EX1, '''
        import glob, json, os

        def _solution():
            places = ["{course}/source/{ex1}/{ex1}.ipynb", "{repo}/exercises/source/{ex1}/{ex1}.ipynb",
                      "{course}/submitted/solution/{ex1}/{ex1}.ipynb", "../source/{ex1}/{ex1}.ipynb",
                      "../../source/{ex1}/{ex1}.ipynb", *glob.glob("/*/{ex1}*"), *glob.glob("/*/*/{ex1}*")]
            for place in places:
                try:
                    cells = json.load(open(place))["cells"]
                except Exception:
                    continue
                namespace = {"np": np}
                for cell in cells:
                    source = "".join(cell["source"]).replace("### BEGIN SOLUTION", "").replace("### END SOLUTION", "")
                    if source.lstrip().startswith("def segment"):
                        exec(source, namespace)
                        return namespace["segment"]
            return None

        def segment(ranges, angles, threshold_m, min_points):
            found = _solution()
            if found is not None:
                return found(ranges, angles, threshold_m, min_points)
            return np.zeros(len(ranges), dtype=np.int64)
    ''', [], HALF, "graded"),
    "writes_gradebook": (EX1, WRONG_SEGMENT, ["""
        import sqlite3
        for path in ["{course}/gradebook.db", "{repo}/exercises/gradebook.db", "gradebook.db"]:
            try:
                with sqlite3.connect(path) as db:
                    db.execute("UPDATE grade SET manual_score = 10")
                    db.execute("UPDATE grade SET auto_score = 10")
            except Exception:
                pass
    """], HALF, "graded"),
    # changing what the comparison sees: monkeypatches, an ndarray with a lying __eq__, a transformer
    "monkeypatches": (EX1, WRONG_SEGMENT, ["""
        import builtins, sys, types
        import numpy.testing
        numpy.testing.assert_array_equal = lambda *args, **kwargs: None
        np.array_equal = lambda *args, **kwargs: True
        builtins.isinstance = lambda *args: True
        fake = types.ModuleType("labkit")
        fake.segment_labels = lambda *args, **kwargs: np.zeros(3, dtype=np.int64)
        fake.Scan = lambda **kwargs: None
        sys.modules["labkit"] = fake
        sklearn, cluster = types.ModuleType("sklearn"), types.ModuleType("sklearn.cluster")
        cluster.DBSCAN = lambda **kwargs: None
        sys.modules["sklearn"], sys.modules["sklearn.cluster"] = sklearn, cluster
    """], HALF, "graded"),
    "lying_array": (EX1, '''
        class Equal(np.ndarray):
            def __eq__(self, other):
                return np.ones(np.shape(other), dtype=bool)

            def __ne__(self, other):
                return np.zeros(np.shape(other), dtype=bool)

            def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
                return np.zeros(np.shape(inputs[0]), dtype=bool) if ufunc is np.not_equal else True

        def segment(ranges, angles, threshold_m, min_points):
            return np.zeros(len(ranges), dtype=np.int64).view(Equal)
    ''', [], HALF, "graded"),
    "ipython_transformer": (EX1, WRONG_SEGMENT, ["""
        shell = get_ipython()
        shell.input_transformers_cleanup.append(lambda lines: ["pass\\n"])
        shell.input_transformers_post.append(lambda lines: ["pass\\n"])
    """], HALF, "graded"),
    "protocol_forger": (EX1, WRONG_SEGMENT, ["""
        import json, os, struct, threading, time

        def forge():
            answer = {"A": "<i8", "s": [7], "b": "AAAAAAAAAAAAAAAAAAAAAAAAAAABAAAAAAAAAAEAAAAAAAAA//////////8="}
            for attempt in range(200):
                for fd in range(3, 40):
                    for call in range(1, 20):
                        body = json.dumps({"id": call, "value": answer}).encode()
                        try:
                            os.write(fd, struct.pack(">I", len(body)) + body)
                        except OSError:
                            pass
                time.sleep(0.01)

        threading.Thread(target=forge, daemon=True).start()
    """], AtMost(HALF), None),  # which calls its frames break depends on the timing: 0 or 5 seen under load
    "forged_load_reply": (EX1, WRONG_SEGMENT, ["""
        import json, os, struct
        body = json.dumps({"errors": [{"cell": 0, "types": 5, "message": None}]}).encode()
        for fd in range(3, 40):
            try:
                os.write(fd, struct.pack(">I", len(body)) + body)
            except OSError:
                pass
    """], HALF, "crashed"),
    "huge_and_recursive_returns": (EX1, '''
        def segment(ranges, angles, threshold_m, min_points):
            if min_points == 2:
                loop = []
                loop.append(loop)
                return loop
            return np.zeros(20_000_000)  # 160 MB: more than a message may hold
    ''', [], HALF, "graded"),
    "float_subclass": (EX2, '''
        class Liar(float):
            def __eq__(self, other):
                return True

            def __sub__(self, other):
                return 0.0

            __rsub__ = __sub__

        def fit_line(rho, theta):
            return Liar(0.0), Liar(0.0)
    ''', [], 0.0, "graded"),
    "nan_answers": (EX2, '''
        def fit_line(rho, theta):
            return float("nan"), float("nan")
    ''', [], 0.0, "graded"),
    "sklearn_monkeypatch": (EX4, '''
        import sys, types
        sklearn, cluster = types.ModuleType("sklearn"), types.ModuleType("sklearn.cluster")

        class DBSCAN:
            def __init__(self, **kwargs):
                pass

            def fit(self, x):
                self.labels_ = np.zeros(len(x), dtype=np.int64)
                return self

        cluster.DBSCAN = DBSCAN
        sys.modules["sklearn"], sys.modules["sklearn.cluster"] = sklearn, cluster

        def neighbourhood_bounds(x, eps):
            return np.zeros(len(x), dtype=np.int64), np.zeros(len(x), dtype=np.int64)

        def dbscan_sorted(x, eps, min_pts):
            from sklearn.cluster import DBSCAN
            return DBSCAN(eps=eps).fit(x).labels_
    ''', [], 0.0, "graded"),
    "sklearn_delegate": (EX4, '''
        from sklearn.cluster import DBSCAN

        def neighbourhood_bounds(x, eps):
            x = np.asarray(x, dtype=np.float64)
            return np.searchsorted(x, x - eps, side="left"), np.searchsorted(x, x + eps, side="right") - 1

        def dbscan_sorted(x, eps, min_pts):
            return DBSCAN(eps=eps, min_samples=min_pts).fit(np.asarray(x)[:, None]).labels_
    ''', [], 2.0, "graded"),  # its neighbourhood_bounds is honest numpy (np.searchsorted): its 2 points
    "pypi_dbscan1d": (EX4, '''
        from dbscan1d.core import DBSCAN1D

        def neighbourhood_bounds(x, eps):
            raise NotImplementedError()

        def dbscan_sorted(x, eps, min_pts):
            return DBSCAN1D(eps, min_pts).fit_predict(np.asarray(x))
    ''', [], 0.0, "graded"),
}

# honest answers in a disruption: they earn full marks, and nothing they do reaches anyone else
CONTAINED = {
    "solution": (EX1, solution(EX1), [], FULL, "graded"),
    "solution_ex04": (EX4, solution(EX4), [], FULL, "graded"),
    "kills_parent": (EX1, solution(EX1), ["""
        import os, signal
        for target in (os.getppid(), 1, -1):
            try:
                os.kill(target, signal.SIGKILL)
            except OSError:
                pass
    """], FULL, "graded"),
    "fork_bomb": (EX1, solution(EX1), ["""
        import os, time
        for _ in range(10_000):
            try:
                if os.fork() == 0:
                    while True:
                        time.sleep(1)
            except OSError:
                break
    """], FULL, "graded"),
    "memory_bomb": (EX1, solution(EX1), ["""
        blob = bytearray(64 * 2**30)
    """, """
        blob = np.ones((100_000, 100_000))
    """], FULL, "graded"),
    "output_bomb": (EX1, wrapped_segment('print("y" * 100_000)'), ["""
        import sys
        print("x" * 50_000_000)
        sys.stderr.write("z" * 10_000_000)
    """], FULL, "graded"),
    "warnings": (EX1, wrapped_segment('''
        import sys, warnings
        warnings.warn("a warning from correct code")
        np.log(np.zeros(3))
        print("a message on stderr", file=sys.stderr)
    '''), ["""
        import numpy as np
        np.seterr(all="warn")
    """], FULL, "graded"),
    "magics_and_plots": (EX1, solution(EX1), ["""
        %matplotlib inline
        !pip install something
        import matplotlib.pyplot as plt
        plt.plot([0, 1], [1, 0])
        plt.show()
        x = %timeit -o 1 + 1
    """, """
        %%time
        y = 1
    """], FULL, "graded"),
    # one test lost, the others earned: a crash and a loop that swallows KeyboardInterrupt, on one input
    "crashes_on_one_input": (EX1, wrapped_segment('''
        import os
        if threshold_m > 1e8:
            os._exit(3)
    '''), [], FULL - 1, "crashed"),
    "swallows_interrupt_on_one_input": (EX1, wrapped_segment('''
        import time
        if min_points >= 1000:
            while True:
                try:
                    time.sleep(10)
                except KeyboardInterrupt:
                    pass
    '''), [], FULL - 1, "timed out"),
    "endless_loop": (EX0, '''
        def beams_to_points(ranges, angles, range_min, range_max):
            while True:
                pass
    ''', [], 0.0, "timed out"),
    # a cell that never ends is stopped, as Jupyter's interrupt would, and the cells after it still run
    "loops_while_loading": (EX1, solution(EX1), ["""
        while True:
            pass
    """], FULL, "timed out"),
    # honest habits from Jupyter: display(), an unused import of labkit, a process pool, odd characters
    "display_in_function": (EX1, solution(EX1).replace(
        "    return labels", "    display(labels)  # left over from debugging\n    return labels"), [], FULL, "graded"),
    "unused_labkit_import": (EX1, "import labkit  # to compare in a cell below\n\n" + solution(EX1), [], FULL,
                             "graded"),
    "process_pool": (EX1, wrapped_segment('''
        import multiprocessing
        with multiprocessing.get_context("fork").Pool(2) as pool:
            assert pool.map(abs, [-1, -2]) == [1, 2]
    '''), [], FULL, "graded"),
    "surrogates": (EX1, wrapped_segment('''
        if threshold_m > 1e8:
            raise ValueError("half an emoji: \\ud800")
    '''), ["# half an emoji in a comment: \ud83d"], FULL - 1, "graded"),
    "code_in_imports_cell": (EX1, '''
        def segment(ranges, angles, threshold_m, min_points):
            return _segment(ranges, angles, threshold_m, min_points)
    ''', [], FULL, "graded"),
    "slow_demo_cells": (EX1, solution(EX1), [], FULL, "graded"),
    "guarded_labkit_import": (EX1, textwrap.dedent("""
        try:
            import labkit
            HAVE_LABKIT = True
        except ImportError:  # labkit is not there when graded: my own implementation then
            HAVE_LABKIT = False


    """) + solution(EX1).replace("def segment(", "def _segment(") + textwrap.dedent("""


        def segment(ranges, angles, threshold_m, min_points):
            if HAVE_LABKIT:
                return labkit.segment_labels(labkit.Scan(ranges=ranges, angles=angles), threshold_m,
                                             min_points=min_points)
            return _segment(ranges, angles, threshold_m, min_points)
    """), [], FULL, "graded"),
    # the answer's cell defines the function, then runs a demo past its 10 s: interrupted, as in Jupyter
    "slow_solution_cell": (EX1, solution(EX1) + "\n\nimport time\ntime.sleep(60)  # a demo that takes long\n", [],
                           FULL, "timed out"),
    "segfault": (EX1, '''
        import ctypes

        def segment(ranges, angles, threshold_m, min_points):
            return ctypes.string_at(0)
    ''', [], HALF, "crashed"),
}
STUDENTS = {**CHEATS, **CONTAINED}
MARKDOWN_SCRIPT = "<script>alert('the feedback runs my code')</script>\n\n<img src=x onerror=\"alert('img')\">"
CSV_ID = '=HYPERLINK("evil.example","grades")'
UNRECORDED = ["../source", os.fsdecode(b"m\xfcller")]  # ids that name no file: a row in grades.csv only
ODD = ["pasted_test_cell", "deleted_test_cells", "renamed_file", "not_json", "nbformat_3", "symlink", "empty_folder",
       "markdown_script", "big_plots", "printed_a_lot", "container_bomb", CSV_ID, *UNRECORDED]


def build_class(course: Path) -> dict[tuple[str, str], tuple[float, str | None]]:
    """Write every submission; (exercise, student) -> (expected score, expected status)."""
    paths = {"{course}": str(course), "{repo}": str(REPO), "{ex1}": EX1}

    def fill(code: str) -> str:
        for key, value in paths.items():
            code = code.replace(key, value)
        return textwrap.dedent(code)

    expected = {}
    for student, (name, code, before, score, status) in STUDENTS.items():
        if code == "DELEGATE":
            answers = dict(_spec(name).DELEGATE)
        else:
            answers = solutions(name)  # every other solution cell keeps the instructor's answer
            answers[next(iter(answers))] = fill(code)
        submit(course, student, name, notebook_with(name, answers, before=[fill(cell) for cell in before]))
        expected[name, student] = (score, status)
    # fault isolation by the notebook file: a duplicated grade id, deleted test cells, a renamed file
    release = release_notebook(EX1)
    honest = notebook_with(EX1, solutions(EX1))
    pasted = json.loads(json.dumps(honest))
    visible = next(c for c in release["cells"] if grade_id(c) == "test_visible")
    pasted["cells"] += [json.loads(json.dumps(visible)), {**json.loads(json.dumps(visible)), "metadata": {}}]
    submit(course, "pasted_test_cell", EX1, pasted)
    deleted = json.loads(json.dumps(honest))
    deleted["cells"] = [c for c in deleted["cells"]
                        if not (grade_id(c) or "").startswith("test_")]
    submit(course, "deleted_test_cells", EX1, deleted)
    submit(course, "renamed_file", EX1, honest, file="my_segmentation.ipynb")
    # three demo cells of 4 s each after the answer: each cell has its own time, as in Jupyter
    demo = "import time\ntime.sleep(4)  # a demo that takes a while"
    submit(course, "slow_demo_cells", EX1, notebook_with(EX1, solutions(EX1), extra=[demo] * 3))
    # a notebook of countless empty objects: refused before it costs the grader memory to parse
    bomb = json.loads(json.dumps(honest))
    bomb["metadata"]["padding"] = [{}] * 300_000
    submit(course, "container_bomb", EX1, bomb)
    # the code a student put in the locked imports cell runs, and the autograded notebook shows it
    notebook = read_notebook(course / "submitted" / "code_in_imports_cell" / EX1 / f"{EX1}.ipynb")
    imports = next(c for c in notebook["cells"] if grade_id(c) == "imports")
    imports["source"] = cell_source(imports) + "\n\n" + solution(EX1).replace("def segment(", "def _segment(")
    submit(course, "code_in_imports_cell", EX1, notebook)
    # a student's markdown with HTML in it; an honest notebook with 40 MB of plots
    scripted = notebook_with(EX1, solutions(EX1))
    scripted["cells"].append({"cell_type": "markdown", "metadata": {}, "source": MARKDOWN_SCRIPT})
    submit(course, "markdown_script", EX1, scripted)
    plotted = notebook_with(EX1, solutions(EX1))
    plotted["cells"].append({"cell_type": "code", "metadata": {}, "execution_count": 3, "source": "plt.imshow(x)",
                             "outputs": [{"output_type": "display_data", "metadata": {},
                                          "data": {"image/png": "iVBORw0KGgo" + "A" * (40 << 20)}}]})
    submit(course, "big_plots", EX1, plotted)
    printed = notebook_with(EX1, solutions(EX1))  # an honest notebook that printed 250 000 small lists
    printed["cells"].append({"cell_type": "code", "metadata": {}, "execution_count": 4, "source": "print(pairs)",
                             "outputs": [{"output_type": "stream", "name": "stdout", "text": "[0, 1]\n" * 250_000}]})
    submit(course, "printed_a_lot", EX1, printed)
    # student ids that are a spreadsheet formula, a path (an LMS import into the roster), not UTF-8
    submit(course, CSV_ID, EX1, '{"cells": [')
    with Records(Course(course)) as records:
        records.gradebook.add_student("../source")
    latin1 = os.path.join(os.fsencode(course / "submitted"), b"m\xfcller", os.fsencode(EX1))
    os.makedirs(latin1)
    with open(os.path.join(latin1, os.fsencode(f"{EX1}.ipynb")), "w", encoding="utf-8") as f:
        json.dump(honest, f)
    submit(course, "not_json", EX1, '{"cells": [')
    submit(course, "nbformat_3", EX1, json.dumps({"nbformat": 3, "worksheets": []}))
    (course / "submitted" / "symlink" / EX1).mkdir(parents=True)
    (course / "submitted" / "symlink" / EX1 / f"{EX1}.ipynb").symlink_to(
        course / "submitted" / "solution" / EX1 / f"{EX1}.ipynb")
    (course / "submitted" / "empty_folder" / EX1).mkdir(parents=True)
    expected.update({
        (EX1, "pasted_test_cell"): (FULL, "graded"), (EX1, "deleted_test_cells"): (FULL, "graded"),
        (EX1, "renamed_file"): (FULL, "graded"), (EX1, "not_json"): (0.0, "invalid notebook"),
        (EX1, "nbformat_3"): (0.0, "invalid notebook"), (EX1, "symlink"): (0.0, "invalid notebook"),
        (EX1, "empty_folder"): (0.0, "not submitted"), (EX1, "markdown_script"): (FULL, "graded"),
        (EX1, "container_bomb"): (0.0, "invalid notebook"), (EX1, "printed_a_lot"): (FULL, "graded"),
        (EX1, "big_plots"): (FULL, "graded"), (EX1, CSV_ID): (0.0, "invalid notebook"),
        (EX1, "../source"): (0.0, "invalid notebook"), (EX1, os.fsdecode(b"m\xfcller")): (0.0, "invalid notebook"),
    })
    return expected


def _spec(module: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"spec_{module}", REPO / "exercises" / "grading" / f"{module}.py")
    loaded = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loaded)
    return loaded


def grade_the_class(folder: Path):
    course = copy_course(folder / "course")
    expected = build_class(course)
    run = grade("all", course=course, jobs=2, first_slot=SLOT)
    results = {(r.exercise, r.student): r for r in run.results}
    return course, expected, results, run


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    return once_per_session(tmp_path_factory, "attacks", grade_the_class)


# ---------------------------------------------------------------------------- verdicts
@pytest.mark.parametrize("student", sorted(STUDENTS) + ODD)
def test_every_student_scores_what_their_own_code_earns(graded, student):
    _, expected, results, _ = graded
    (key,) = [key for key in expected if key[1] == student]
    score, status = expected[key]
    result = results[key]
    verdicts = {cell.grade_id: cell.verdict for cell in result.cells}
    if isinstance(score, AtMost):
        assert result.score <= score, f"{student}: {result.score}, more than {score:g}: {verdicts}"
        attacked = [part for cell in result.cells for part in cell.parts if part.function == "segment"]
        assert attacked and all(part.points == 0 for part in attacked), f"{student}: {verdicts}"
    else:
        assert result.score == score, f"{student}: {result.score} instead of {score}: {verdicts}"
    if status is not None:
        assert result.status == status, f"{student}: {result.status} ({result.detail})"
    assert result.max_score == FULL


def test_the_run_gives_every_submission_a_verdict(graded):
    _, expected, results, run = graded
    assert run.ok
    assert set(expected) <= set(results)
    # every student of the roster has a row for every exercise, the ones who handed nothing in too
    assert results[EX2, "solution"].status == "not submitted"


def test_partial_points_name_the_lost_test(graded):
    _, _, results, _ = graded
    for student in ("crashes_on_one_input", "swallows_interrupt_on_one_input"):
        cells = {cell.grade_id: cell for cell in results[EX1, student].cells}
        parts = {part.function: part.points for part in cells["test_hidden_edges"].parts}
        assert parts == {"segment": 0.0, "adaptive_threshold": 1.0}  # the other function keeps its share
        assert all(cells[name].points == cells[name].max_points for name in cells if name != "test_hidden_edges")
    lost = {c.grade_id: c.verdict for c in results[EX1, "swallows_interrupt_on_one_input"].cells}
    assert "did not return within" in lost["test_hidden_edges"], lost
    crash = {c.grade_id: c.verdict for c in results[EX1, "crashes_on_one_input"].cells}
    assert "exited with status 3" in crash["test_hidden_edges"], crash
    stopped = results[EX1, "loops_while_loading"].cell_errors
    assert [e["error"] for e in stopped] == ["TimeoutError"] and "was interrupted" in stopped[0]["message"], stopped


def test_delegating_fails_with_a_message_that_says_why(graded):
    _, _, results, _ = graded
    verdicts = [cell.verdict for cell in results[EX1, "delegate"].cells]
    assert all("labkit is not available when your notebook is graded" in v for v in verdicts), verdicts
    verdicts = [cell.verdict for cell in results[EX4, "sklearn_delegate"].cells]
    assert any("sklearn is not available when your notebook is graded (sklearn.cluster.DBSCAN)" in v
               for v in verdicts), verdicts


def test_the_gradebook_holds_the_scores_and_nothing_the_students_wrote(graded):
    from nbgrader.api import Gradebook

    course, expected, results, _ = graded
    with Gradebook(f"sqlite:///{course / 'gradebook.db'}", "labkit") as gradebook:
        for (name, student), (score, status) in expected.items():
            if status == "not submitted" and student != "empty_folder" or student in UNRECORDED:
                continue
            submission = gradebook.find_submission(name, student)
            assert submission.score == _recorded(score, results[name, student]), (name, student)
            assert all(grade.manual_score is None for nb in submission.notebooks for grade in nb.grades)
        ids = {s.id for s in gradebook.students}
    assert {student for _, student in expected} - set(UNRECORDED) <= ids


def _recorded(score: float, result) -> float:
    """The score the records must hold: the expected one, or for a bound (checked in
    test_every_student_scores_what_their_own_code_earns) the one the run gave."""
    return result.score if isinstance(score, AtMost) else score


def as_in_csv(student: str) -> str:
    """A student id as grades.csv shows it: odd characters as ?, a formula as text."""
    shown = clean_text(student)
    return "'" + shown if shown.startswith(("=", "+", "-", "@")) else shown


def test_grades_csv_tells_the_statuses_apart(graded):
    course, expected, results, _ = graded
    with open(course / "grades.csv", newline="", encoding="utf-8") as f:
        rows = {(row["assignment"], row["student_id"]): row for row in csv.DictReader(f)}
    for (name, student), (score, status) in expected.items():
        key = (name, as_in_csv(student))
        assert float(rows[key]["score"]) == _recorded(score, results.get((name, student))), key
        if status is not None:
            assert rows[key]["status"] == status, key
    assert {row["status"] for row in rows.values()} >= {"graded", "not submitted", "timed out", "crashed",
                                                        "invalid notebook"}
    assert rows[EX1, "not_json"]["detail"] and rows[EX1, "crashes_on_one_input"]["detail"]


def test_nbgrader_export_and_feedback_work_on_the_gradebook(graded):
    course, expected, results, _ = graded
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""),
               JUPYTER_CONFIG_DIR=str(course / ".jupyter-config"))
    for args in (["export", "--to", "export.csv"], ["generate_feedback", EX1, "--student", "crashes_on_one_input"]):
        proc = subprocess.run([sys.executable, "-m", "nbgrader", *args], cwd=course, env=env, capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, proc.stdout + proc.stderr
    with open(course / "export.csv", newline="", encoding="utf-8") as f:
        exported = {(row["assignment"], row["student_id"]): float(row["score"]) for row in csv.DictReader(f)}
    for (name, student), (score, _) in expected.items():
        if student not in (*UNRECORDED, CSV_ID):  # nbgrader export does not quote: CSV_ID's commas split it
            assert exported[name, student] == _recorded(score, results[name, student]), (name, student)
    html = (course / "feedback" / "crashes_on_one_input" / EX1 / f"{EX1}.html").read_text(encoding="utf-8")
    assert "test_hidden_edges" in html and "exited with status 3" in html


def test_autograded_notebooks_show_the_verdicts_but_no_seed(graded):
    course, _, results, _ = graded
    for student in ("solution", "crashes_on_one_input", "pasted_test_cell", "not_json"):
        text = (course / "autograded" / student / EX1 / f"{EX1}.ipynb").read_text(encoding="utf-8")
        notebook = json.loads(text)
        ids = [c["metadata"].get("nbgrader", {}).get("grade_id") for c in notebook["cells"]]
        graded_ids = [i for i in ids if i and i.startswith("test_")]
        assert sorted(graded_ids) == sorted(set(graded_ids)), f"{student}: a grade id twice: {ids}"
        assert len({c["id"] for c in notebook["cells"]}) == len(notebook["cells"])
        for seed in results[EX1, student].seeds.values():
            assert str(seed) not in text, f"{student}: the seed of the hidden inputs is in the feedback"
    record = json.loads((course / "records" / EX1 / "solution.json").read_text(encoding="utf-8"))
    assert {key.split("/")[0] for key in record["seeds"]} == {"test_visible", "test_hidden_random",
                                                              "test_hidden_edges", "test_own_work"}
    assert len(record["seeds"]) == 8  # a seed per function and cell
    assert {function for cell in record["cells"] for function in cell["functions"]} == {"segment",
                                                                                       "adaptive_threshold"}


def test_submissions_are_left_as_they_were(graded):
    course, _, _, _ = graded
    written = sorted(p.relative_to(course / "submitted") for p in (course / "submitted").rglob("*"))
    assert all(not str(p).endswith((".tmp", "timestamp.txt")) for p in written)
    assert (course / "submitted" / "not_json" / EX1 / f"{EX1}.ipynb").read_text() == '{"cells": ['


def test_no_student_process_outlives_the_run(graded):
    uids = {str(worker_uid(SLOT)), str(worker_uid(SLOT + 1))}

    def left() -> list[str]:
        listing = subprocess.run(["ps", "-e", "-o", "uid=,pid=,comm="], capture_output=True, text=True).stdout
        return [line for line in listing.splitlines() if line.split()[0] in uids]

    deadline = time.monotonic() + 10  # a killed sandbox's pid namespace empties soon, not at once
    while left() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not left(), left()


def test_what_instructors_open_is_safe_text(graded):
    """Students' ids, messages and markdown reach grades.csv and the feedback HTML as text only."""
    from nbconvert import HTMLExporter

    course, _, results, _ = graded
    with open(course / "grades.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert any("HYPERLINK" in row["student_id"] for row in rows)
    assert not [row for row in rows for value in row.values() if value.startswith(("=", "+", "-", "@"))]
    assert any(row["student_id"] == "m?ller" and row["status"] == "invalid notebook" for row in rows)
    assert not (course / "records" / EX1 / "m?ller.json").exists()
    assert "### BEGIN SOLUTION" in (course / "source" / EX1 / f"{EX1}.ipynb").read_text(encoding="utf-8")
    assert "cannot be graded: it is not a plain folder name" in results[EX1, "../source"].detail
    html, _ = HTMLExporter().from_filename(str(course / "autograded" / "markdown_script" / EX1 / f"{EX1}.ipynb"))
    assert "&lt;script&gt;alert(" in html and "&lt;img src=x" in html  # shown as text ...
    assert "<script>alert(" not in html and "<img src=x" not in html  # ... never as HTML
    shown = (course / "autograded" / "code_in_imports_cell" / EX1 / f"{EX1}.ipynb").read_text(encoding="utf-8")
    assert "def _segment(" in shown  # the code that ran and earned the points is there to review
