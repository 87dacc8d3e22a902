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
import collections
import contextlib
import functools
import inspect
import io
import keyword
import re
import signal
import textwrap
import tokenize
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


# ---------------------------------------------------------------------------- near-copies: token n-grams
# A notebook can give an exercise away without a function that passes its hidden tests: a cell that
# computes the same thing inline, a helper with a renamed signature, a comment that spells the lines.
# So every code cell and every function of every notebook (comments included, read as tokens) is compared
# with every answer of the course: each solution function of exercises/source (docstring and input
# guards dropped: they are not the answer) and each independent reference of exercises/grading (a
# top-level function that is neither a test, nor a checker, nor a generator of random input).
#
# Both sides become token streams with names blanked (a local name is "_"; numpy, math, builtins, keywords
# and attribute names stay: ``x[i] * np.cos(t)`` and ``a[k] * np.cos(b)`` are the same stream) and then
# sets of 5-token n-grams. An answer's n-gram is *distinctive* when it belongs to the answers of one
# exercise only and occurs in at most 3 notebook cells (``np.asarray(_, dtype=float)`` is everyone's);
# the score of a (notebook unit, answer) pair is the share of the answer's distinctive n-grams found in
# the unit. Measured on the notebooks before this test (the listed near-copies of issue 34), copies
# scored 0.30-0.52 (ex11's homogeneous matrix 0.52, ex07's triplet direction 0.30-0.36, ex06's
# brute-force bounds 0.32-0.39) and every other pair at most 0.19: NEAR_COPY sits in that gap.
NGRAM = 5
NEAR_COPY = 0.25
GENERIC_CELLS = 3  # an n-gram in more notebook cells than this is common notebook code, not an answer
MIN_DISTINCTIVE = 15  # an answer with fewer distinctive n-grams is too short to be told from plain numpy

_KEEP = frozenset({"np", "numpy", "math", "labkit", "scipy"} | set(dir(__builtins__ if isinstance(__builtins__, dict)
                                                                       else vars(__builtins__))))
_WORD = re.compile(r"[A-Za-z_]\w*|\d+\.?\d*(?:e-?\d+)?|\*\*|//|==|<=|>=|!=|->|[^\s\w]")
_NOT_AN_ANSWER = re.compile(r"^_?(test_|check|assert|as_|is_number|same|flat|plain|near|bool|expect|timed|segment$)")


def normal_tokens(source: str) -> list[str]:
    """``source`` as tokens with local names blanked; a comment's words are read as tokens too."""
    out: list[str] = []
    previous = ""

    def add(word: str) -> None:
        nonlocal previous
        named = word[0].isalpha() or word[0] == "_"
        out.append("_" if named and previous != "." and word not in _KEEP and not keyword.iskeyword(word) else word)
        previous = word

    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            for word in _WORD.findall(token.string.lstrip("#")):
                add(word)
        elif token.type in (tokenize.NAME, tokenize.NUMBER, tokenize.OP):
            add(token.string)
        elif token.type == tokenize.STRING:
            out.append("S")
            previous = "S"
    return out


def ngrams(tokens: list[str]) -> set[tuple[str, ...]]:
    return {tuple(tokens[i:i + NGRAM]) for i in range(len(tokens) - NGRAM + 1)}


def _answer_source(node: ast.FunctionDef) -> str:
    """The def without docstrings and input guards (``raise``, ``if ...: raise``): the computation."""
    node = ast.parse(ast.unparse(node)).body[0]
    for inner in ast.walk(node):
        for field in ("body", "orelse"):
            body = getattr(inner, field, None)
            if isinstance(body, list) and body and isinstance(body[0], ast.stmt):
                kept = [s for s in body
                        if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant))
                        and not isinstance(s, ast.Raise)
                        and not (isinstance(s, ast.If) and not s.orelse
                                 and all(isinstance(b, ast.Raise) for b in s.body))]
                setattr(inner, field, kept or [ast.Pass()])
    return ast.unparse(node)


@functools.cache
def course_answers() -> list[tuple[str, str, ast.FunctionDef]]:
    """(exercise, label, def) for every solution function and every reference of the grading files."""
    found = []
    for exercise in names():
        for code in solutions(exercise).values():
            found += [(exercise, f"{exercise} solution {node.name}", node) for node in ast.parse(code).body
                      if isinstance(node, ast.FunctionDef)]
        grading = ast.parse((REPO / "exercises" / "grading" / f"{exercise}.py").read_text(encoding="utf-8"))
        found += [(exercise, f"exercises/grading/{exercise}.py {node.name}", node) for node in grading.body
                  if isinstance(node, ast.FunctionDef) and not _NOT_AN_ANSWER.match(node.name)
                  and "rng" not in [a.arg for a in node.args.args]]
    return found


@functools.cache
def notebook_units() -> list[tuple[str, str]]:
    """(where, source) for every code cell of every notebook and every function defined in one."""
    transform = TransformerManager().transform_cell
    units = []
    for nb_path in NOTEBOOKS:
        for i, cell in enumerate(nbformat.read(nb_path, as_version=4).cells):
            if cell.cell_type != "code":
                continue
            source = transform(cell.source)
            units.append((f"{nb_path.name} cell {i} ({cell.get('id')})", source))
            defs = [node for node in ast.walk(ast.parse(source)) if isinstance(node, ast.FunctionDef)]
            units += [(f"{nb_path.name} cell {i} def {node.name}",
                       textwrap.dedent(ast.get_source_segment(source, node)))
                      for node in defs]
    return units


def similarity_table() -> list[tuple[float, int, int, str, str]]:
    """(score, shared, distinctive, notebook unit, answer) for every pair, highest score first."""
    units = [(where, ngrams(normal_tokens(source))) for where, source in notebook_units()]
    in_cells = collections.Counter(g for where, grams in units if " def " not in where for g in grams)
    answers = [(exercise, label, ngrams(normal_tokens(_answer_source(node))))
               for exercise, label, node in course_answers()]
    in_exercises = collections.Counter(g for exercise in {e for e, _, _ in answers}
                                       for g in set().union(*(grams for e, _, grams in answers if e == exercise)))
    rows = []
    for _, label, grams in answers:
        distinctive = {g for g in grams if in_exercises[g] == 1 and in_cells[g] <= GENERIC_CELLS}
        if len(distinctive) < MIN_DISTINCTIVE:
            continue
        for where, unit in units:
            shared = len(distinctive & unit)
            rows.append((shared / len(distinctive), shared, len(distinctive), where, label))
    return sorted(rows, reverse=True)


def test_the_similarity_sees_a_copy_with_other_names():
    """The measure can fail: an exercise's solution with every name changed and comments added scores 1."""
    exercise, label, node = next(a for a in course_answers() if a[1] == "ex05_iepf_and_corners solution corner")
    renamed = _answer_source(node)
    for old, new in [("line1", "first"), ("line2", "second"), ("det", "d"), ("c1", "ca"), ("s2", "sb")]:
        renamed = re.sub(rf"\b{old}\b", new, renamed)
    assert renamed != _answer_source(node)
    answer, copy = ngrams(normal_tokens(_answer_source(node))), ngrams(normal_tokens("# the corner\n" + renamed))
    assert answer <= copy


def test_no_notebook_cell_or_function_is_a_near_copy_of_an_answer():
    table = similarity_table()
    assert table and table[-1][0] == 0.0, "the table covers unrelated pairs too"
    copies = [f"{where} ~ {label}: {shared}/{n} distinctive n-grams ({score:.2f})"
              for score, shared, n, where, label in table if score >= NEAR_COPY]
    assert not copies, "a notebook holds a near-copy of an exercise's answer: " + "; ".join(copies)


def test_no_notebook_function_has_an_exercises_name_and_signature():
    """A notebook function named as an exercise's function, with its parameters, is that exercise's task."""
    asked = {}
    for exercise in names():
        for code in solutions(exercise).values():
            for node in ast.parse(code).body:
                if isinstance(node, ast.FunctionDef):
                    asked[node.name] = (exercise, [a.arg for a in node.args.args])
    found = []
    for where, source in notebook_units():
        if " def " in where:
            continue  # its cell is read whole
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.FunctionDef) and node.name in asked:
                exercise, parameters = asked[node.name]
                if [a.arg for a in node.args.args] == parameters:
                    found.append(f"{where}: {node.name}({', '.join(parameters)}) is {exercise}'s")
    assert not found, "; ".join(found)


# ---------------------------------------------------------------------------- your-turn cells
def _your_turn_cells():
    for nb_path in NOTEBOOKS:
        for i, cell in enumerate(nbformat.read(nb_path, as_version=4).cells):
            tags = cell.get("metadata", {}).get("tags", [])
            if cell.cell_type == "code" and ("your-turn" in tags or "your-turn-check" in tags):
                yield nb_path.name, i, cell, "your-turn" in tags


def test_every_your_turn_check_takes_its_fallback_from_a_module():
    """The check cell below a task holds no answer: its fallback is ``fallbacks.NAME`` (labkit.course_fallbacks)
    or a labkit function, never a lambda or a function defined in the cell (nor a name imported into it)."""
    import labkit.course_fallbacks as fallbacks

    found, checks = [], 0
    for notebook, i, cell, is_task in _your_turn_cells():
        if is_task:
            continue
        tree = ast.parse(TransformerManager().transform_cell(cell.source))
        for call in ast.walk(tree):
            for kw in getattr(call, "keywords", []) if isinstance(call, ast.Call) else []:
                if kw.arg != "fallback":
                    continue
                checks += 1
                value = kw.value
                from_module = _root(value) in ("labkit", "iav") or (
                    _root(value) == "fallbacks" and hasattr(fallbacks, value.attr))
                ok = isinstance(value, ast.Attribute) and from_module
                if not ok:
                    found.append(f"{notebook} cell {i}: fallback={ast.unparse(value)}")
    assert checks >= 15, f"only {checks} fallbacks found"
    assert not found, "a check cell writes its fallback out below the task: " + "; ".join(found)


def _spelled_statement(text: str) -> str | None:
    """A piece of ``text`` (from a word to a comma, semicolon or the end) that parses as an assignment,
    a return or an ``if``/``while`` header; None when there is none."""
    starts = [m.start() for m in re.finditer(r"\b\w", text)]
    ends = [m.start() for m in re.finditer(r"[,;]|$", text)]
    for a in starts:
        for b in ends:
            piece = text[a:b].strip().rstrip(".:")
            if b <= a or not piece:
                continue
            try:
                statement = ast.parse(piece + (" pass" if piece.startswith(("if ", "while ")) else "")).body
            except SyntaxError:
                continue
            if statement and isinstance(statement[0], ast.Assign | ast.AugAssign | ast.Return | ast.While | ast.If):
                return piece
    return None


def test_no_your_turn_comment_spells_a_line_of_code():
    """A task's comments give ideas, not lines: no comment line of a your-turn cell parses as an assignment,
    a return or an ``if``/``while`` header (``keep = min_points // 2`` is the answer, "protect the ends" an idea)."""
    found = []
    for notebook, i, cell, is_task in _your_turn_cells():
        if not is_task:
            continue
        for line in cell.source.splitlines():
            text = line.strip()
            if not text.startswith("#"):
                continue
            if _spelled_statement(text.lstrip("#")):
                found.append(f"{notebook} cell {i}: {text}")
    assert not found, "a your-turn comment spells the code: " + "; ".join(found)
