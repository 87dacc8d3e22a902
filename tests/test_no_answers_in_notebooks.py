"""No exercise answer in a notebook: what an exercise grades is not written out in any notebook.

The proof is the grader's own: every function a course notebook defines is tried, in place of each
function an exercise asks for, under that exercise's hidden random tests of that function (the
spec's ``test_hidden_random`` or ``test_hidden_random__<function>``, with fresh inputs). If one passes, a
student could copy it from the notebook and earn the function's points, and this test fails naming the
notebook, the function and the exercise.

Fast by construction: the notebooks are not run. Only their ``import`` statements, their simple
constants (``NAME = value`` by arithmetic and numpy calls) and their top-level ``def``s are executed (IPython magics are
translated first), so no experiment, figure or viewer is computed; then each candidate is called
under the hidden tests with a time limit.

A notebook could write the same computation with another signature, so each candidate is tried in
every *form* of the exercise's function this file knows (:data:`FORMS`): called with the arguments
in the exercise's order (keyword arguments mapped to their position), with the scan as a
:class:`labkit.Scan` instead of ``ranges, angles``, or with the weights ``1/rho`` passed explicitly.
The exercise's other functions (``similar`` while ``split_index`` is tried) are the instructor's
solution, so a pass is the candidate's alone.
"""

from __future__ import annotations

import ast
import contextlib
import functools
import inspect
import signal
import warnings
from pathlib import Path

import nbformat
import numpy as np
import pytest
from IPython.core.inputtransformer2 import TransformerManager

import labkit
from labkit.grading.exercises import Course
from tests.grading_course import EXERCISES, names, solutions

REPO = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))
SEEDS = (0, 1)  # fresh inputs per seed; a function that passes one seed already gives the answer away
CALL_LIMIT_S = 20  # per candidate and seed: a notebook helper that loops on foreign inputs fails, never hangs


# ---------------------------------------------------------------------------- the notebooks' functions
def _module_of(nb_path: Path) -> ast.Module:
    """The notebook's imports, constants and top-level defs, in notebook order."""
    transform = TransformerManager().transform_cell
    kept = []
    for cell in nbformat.read(nb_path, as_version=4).cells:
        if cell.cell_type != "code":
            continue
        for node in ast.parse(transform(cell.source)).body:
            if isinstance(node, ast.Import | ast.ImportFrom | ast.FunctionDef):
                kept.append(node)
            elif isinstance(node, ast.Assign) and _is_constant(node):
                kept.append(node)
    return ast.Module(body=kept, type_ignores=[])


def _root(node: ast.expr) -> str | None:
    while isinstance(node, ast.Attribute):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


def _is_constant(node: ast.Assign) -> bool:
    """``NAME = ...`` or ``A, B = ...`` computed by arithmetic and numpy/math calls alone (a default value)."""
    names = [t for target in node.targets for t in (target.elts if isinstance(target, ast.Tuple) else [target])]
    return all(isinstance(t, ast.Name) for t in names) and all(
        _root(call.func) in ("np", "numpy", "math") for call in ast.walk(node.value) if isinstance(call, ast.Call))


def _without_defaults(node: ast.FunctionDef) -> ast.FunctionDef:
    """The def with every default set to None: for defaults taken from an experiment (``rows=rows``)."""
    node = ast.parse(ast.unparse(node)).body[0]
    node.args.defaults = [ast.Constant(None) for _ in node.args.defaults]
    node.args.kw_defaults = [None if d is None else ast.Constant(None) for d in node.args.kw_defaults]
    return ast.fix_missing_locations(node)


def _run(node: ast.stmt, namespace: dict, filename: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exec(compile(ast.Module(body=[node], type_ignores=[]), filename, "exec"), namespace)


def notebook_functions(nb_path: Path) -> dict[str, object]:
    """Every top-level function of the notebook, defined in one namespace (helpers see each other).

    A def whose defaults come from the notebook's experiments is defined with those defaults set to
    None: the hidden tests pass every argument, so the function is still tried."""
    namespace: dict = {"__name__": f"notebook_{nb_path.stem}"}
    defs = []
    for node in _module_of(nb_path).body:
        try:
            _run(node, namespace, str(nb_path))
        except Exception:  # noqa: BLE001 -- an import or constant this test cannot run is no def
            if not isinstance(node, ast.FunctionDef):
                continue
            _run(_without_defaults(node), namespace, str(nb_path))
        if isinstance(node, ast.FunctionDef):
            defs.append(node.name)
    return {name: namespace[name] for name in dict.fromkeys(defs)}


@functools.cache
def candidates() -> list[tuple[str, str, object]]:
    """(notebook, name, function) for every top-level def of every course notebook."""
    return [(nb.stem, name, fn) for nb in NOTEBOOKS for name, fn in notebook_functions(nb).items()]


# ---------------------------------------------------------------------------- the forms of an exercise's function
def _bound(reference, args, kwargs) -> list:
    """The call's arguments in the reference signature's order, defaults filled in."""
    bound = inspect.signature(reference).bind(*args, **kwargs)
    bound.apply_defaults()
    return list(bound.arguments.values())


def positional(candidate, reference):
    """``candidate`` called with the arguments in the exercise's order."""
    return lambda *args, **kwargs: candidate(*_bound(reference, args, kwargs))


def with_scan(candidate, reference):
    """``ranges, angles, ...`` given as ``labkit.Scan(ranges, angles), ...``."""
    def call(*args, **kwargs):
        ranges, angles, *rest = _bound(reference, args, kwargs)
        return candidate(labkit.Scan(ranges=ranges, angles=angles), *rest)
    return call


def with_weights(candidate, reference):
    """``rho, theta`` given with the weights of the exercise, ``rho, theta, 1/rho``."""
    def call(*args, **kwargs):
        rho, theta, *rest = _bound(reference, args, kwargs)
        rho = np.asarray(rho, dtype=float)
        return candidate(rho, np.asarray(theta, dtype=float), 1.0 / rho, *rest)
    return call


#: Per function an exercise asks for: the forms a notebook might write it in (positional for all).
FORMS = {
    "segment": (with_scan,),
    "beams_to_points": (with_scan,),
    "fit_line": (with_weights,),
}


#: How many more arguments a form passes than the exercise's function takes.
EXTRA_ARGUMENTS = {positional: 0, with_scan: -1, with_weights: 1}


def _forms(function: str):
    return (positional, *FORMS.get(function, ()))


def _takes(candidate, n: int) -> bool:
    """True when ``candidate`` can be called with ``n`` positional arguments (the forms call so)."""
    try:
        inspect.signature(candidate).bind(*range(n))
    except (TypeError, ValueError):
        return False
    return True


@contextlib.contextmanager
def _time_limit(seconds: float):
    def expire(signum, frame):
        raise TimeoutError(f"took over {seconds} s")
    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _passes(hidden, functions: dict, seed: int) -> bool:
    rng = np.random.default_rng(seed)
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"), _time_limit(CALL_LIMIT_S):
            warnings.simplefilter("ignore")
            hidden(**{p: rng if p == "rng" else functions[p] for p in inspect.signature(hidden).parameters})
    except Exception:  # noqa: BLE001 -- any failure (wrong answer, wrong signature, crash, timeout) is a fail
        return False
    return True


@functools.cache
def _solution_functions(name: str) -> dict:
    namespace = {"np": np}
    for code in solutions(name).values():
        exec(compile(code, f"<{name} solution>", "exec"), namespace)
    return namespace


COURSE = Course(EXERCISES)


# ---------------------------------------------------------------------------- the tests
def test_the_notebooks_define_functions():
    """The test below sees the notebooks' functions (a parser that found none would prove nothing)."""
    found = {nb for nb, _, _ in candidates()}
    assert len(candidates()) >= 20 and len(found) >= 5, f"only {len(candidates())} functions found in {sorted(found)}"


def test_the_forms_reach_a_known_answer():
    """The check can fail: labkit's own versions, written as a notebook would, pass the hidden tests.

    ``labkit.fit_line_polar`` given explicit weights (the form of a general weighted fit) and
    ``labkit.segment_labels`` given a Scan are the exercise answers in another signature: the forms
    must reach them, or a notebook writing them so would slip through.
    """
    def fit_polar(rho, theta, w):
        assert np.allclose(w, 1.0 / np.asarray(rho)), "the weights form passes w = 1/rho"
        fit = labkit.fit_line_polar(rho, theta)
        return fit.r, fit.alpha

    def segment_fixed(scan, threshold_m, min_points):
        return labkit.segment_labels(scan, threshold_m=threshold_m, min_points=min_points, adaptive=False)

    for exercise, function, candidate in [("ex02_weighted_line_fit", "fit_line", fit_polar),
                                          ("ex01_range_segmentation", "segment", segment_fixed)]:
        assert _answers(exercise, function, candidate), f"{candidate.__name__} was not recognised as {function}"


def _answers(exercise_name: str, function: str, candidate) -> list[str]:
    """The forms in which ``candidate`` passes the hidden random tests as ``function``."""
    exercise = COURSE.exercise(exercise_name)
    random_cell = next(cell for cell in exercise.cells if cell.grade_id == "test_hidden_random")
    tests = [test.test for test in random_cell.tests_of(function)]  # the hidden random tests of this function
    solution = _solution_functions(exercise_name)
    reference = solution[function]
    passed = []
    n = len(inspect.signature(reference).parameters)
    for form in _forms(function):
        if not _takes(candidate, n + EXTRA_ARGUMENTS[form]):
            continue  # the form would raise TypeError on the first call
        functions = {f: solution[f] for f in exercise.functions} | {function: form(candidate, reference)}
        if all(_passes(hidden, functions, seed) for seed in SEEDS for hidden in tests):
            passed.append(form.__name__)
    return passed


@pytest.mark.parametrize("exercise_name", names())
def test_no_notebook_function_passes_the_hidden_tests(exercise_name):
    exercise = COURSE.exercise(exercise_name)
    found = []
    for function in exercise.functions:
        for notebook, name, candidate in candidates():
            for form in _answers(exercise_name, function, candidate):
                found.append(f"notebooks/{notebook}.ipynb: {name} passes {exercise_name}'s hidden tests as "
                             f"{function} ({form})")
    assert not found, ("a notebook writes out what an exercise grades (a student could copy it): "
                       + "; ".join(found))
