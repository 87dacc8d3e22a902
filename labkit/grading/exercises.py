"""The course on disk (``exercises/``) and its exercises as the trusted grader sees them.

An exercise is three trusted files:

- ``source/<name>/<name>.ipynb``: the instructor notebook. Its solution cells hold the answer, its
  visible test cell the *visible checks* (a ``check_<function>(rng)`` per function, run by
  :func:`labkit.grading.run_checks`), and its metadata (``"labkit"``) what students write and what each
  function is worth: ``{"exercise": name, "functions": {function: points, ...}, "masked": [package, ...]}``;
- ``release/<name>/<name>.ipynb``: what ``make release`` generated from it (the student copy, also the
  layout of the autograded notebook and of the gradebook's cells);
- ``grading/<name>.py``: the *spec*, a Python module with the hidden tests. The tests of the graded
  cell ``<grade_id>`` are its functions named ``<grade_id>`` or ``<grade_id>__<anything>``; each takes
  one of the student's functions (by its name) and ``rng``, and counts for that function. See
  ``docs/guide/exercises.md`` ("Adding an exercise") for its form.

Points are per function: a graded cell's points are shared among the functions in proportion to their
points (ex01: ``segment`` 5 and ``adaptive_threshold`` 5 share each cell half and half), and a
function's share of a cell is earned when its visible check and its hidden tests in that cell all pass.

The spec never runs where student code runs, and nbgrader never copies it (it copies only
``source/<name>/``). :func:`release_exercise` builds an exercise from a release notebook alone (its
visible checks, no hidden tests): what a student's ``labkit grade --check`` runs.
"""

from __future__ import annotations

import ast
import importlib.util
import inspect
import math
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

from .notebook import InvalidNotebook, cell_source, grade_id, nbgrader_metadata, read_notebook, same_code
from .sandbox import Limits

__all__ = ["Course", "Exercise", "GradedCell", "HiddenTest", "find_course", "release_exercise"]

MARKERS = ("### BEGIN HIDDEN TESTS", "### END HIDDEN TESTS")
#: The defaults of the time limits a spec may change (seconds): per call of a student's function, per
#: function's part of a graded cell, per notebook cell (all cells together: ``LOAD_BUDGET`` times it, see
#: :mod:`labkit.grading.sandbox`), and for all of one submission's tests together (the student's calls and
#: the notebook run again after a lost worker).
TIMEOUTS = {"CALL_TIMEOUT_S": 5.0, "TEST_TIMEOUT_S": 30.0, "LOAD_TIMEOUT_S": 10.0, "SUBMISSION_TIMEOUT_S": 120.0}


@dataclass(frozen=True)
class HiddenTest:
    """One hidden test of a graded cell: ``test(<function>=..., rng=...)`` counts for ``function``.

    Parameters
    ----------
    name : str
        The test's name in the spec.
    function : str
        The student's function it tests.
    test : callable
        The test: raises when the function gets its inputs wrong.
    """

    name: str
    function: str
    test: Callable[..., None]


@dataclass(frozen=True)
class GradedCell:
    """One graded cell of an exercise.

    Parameters
    ----------
    grade_id : str
        The cell's nbgrader grade id.
    points : float
        The points it is worth.
    code : str
        The visible checks: the source notebook's code of the cell (empty for a manually graded cell).
    hidden : tuple of HiddenTest
        The spec's hidden tests of the cell.
    auto : bool
        False for a cell nbgrader leaves to a human (a graded answer cell or a markdown cell).
    shares : dict
        Function -> the points of this cell it earns (the cell's points in proportion to the functions').
    """

    grade_id: str
    points: float
    code: str
    hidden: tuple[HiddenTest, ...] = ()
    auto: bool = True
    shares: dict[str, float] = field(default_factory=dict)

    @property
    def visible(self) -> bool:
        """True when the visible code has a statement (not only comments)."""
        return bool(ast.parse(self.code).body) if self.auto else False

    def tests_of(self, function: str) -> tuple[HiddenTest, ...]:
        return tuple(test for test in self.hidden if test.function == function)


@dataclass(frozen=True)
class Exercise:
    """What the grader knows about one exercise; built by :meth:`Course.exercise` or :func:`release_exercise`.

    Parameters
    ----------
    name : str
        The exercise's name.
    source : dict
        The instructor's source notebook.
    release : dict
        The student release notebook.
    module : types.ModuleType or None
        The spec with the hidden tests (``grading/<name>.py``); None without the course.
    functions : tuple of str
        The functions the students write.
    points : dict of str to float
        Function -> its share of the points.
    masked : tuple of str
        Top-level packages the student's code must not import.
    setup : tuple of str
        The code cells that are neither solutions nor graded (run before the student's).
    cells : tuple of GradedCell
        The graded cells, in notebook order.
    test_cells : dict of str to str
        Grade id -> source text of every test cell.
    call_timeout_s : float
        The time limit of each call into the student's code, seconds.
    test_timeout_s : float
        The time limit of each test's calls together, seconds.
    load_timeout_s : float
        The time limit of each cell when the notebook runs, seconds.
    submission_timeout_s : float
        The time limit of all a submission's calls, seconds.
    limits : Limits
        The resource limits of the worker.
    """

    name: str
    source: dict
    release: dict
    module: ModuleType | None
    functions: tuple[str, ...]
    points: dict[str, float]
    masked: tuple[str, ...]
    setup: tuple[str, ...]
    cells: tuple[GradedCell, ...]
    test_cells: dict[str, str]
    call_timeout_s: float = TIMEOUTS["CALL_TIMEOUT_S"]
    test_timeout_s: float = TIMEOUTS["TEST_TIMEOUT_S"]
    load_timeout_s: float = TIMEOUTS["LOAD_TIMEOUT_S"]
    submission_timeout_s: float = TIMEOUTS["SUBMISSION_TIMEOUT_S"]
    limits: Limits = field(default_factory=Limits)

    @property
    def total(self) -> float:
        return sum(cell.points for cell in self.cells)

    @property
    def notebook(self) -> str:
        return f"{self.name}.ipynb"


def _problem(name: str, text: str) -> ValueError:
    return ValueError(f"exercise {name}: {text}")


def _load_module(name: str, path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"labkit_grading_spec_{name}", path)
    if spec is None or spec.loader is None:  # (only a name without the .py suffix has no loader)
        raise ImportError(f"exercise {name}: cannot load {path} as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses and pickling in a spec need their module registered
    spec.loader.exec_module(module)
    return module


def _defined_functions(source: str) -> list[str]:
    return [node.name for node in ast.parse(source).body if isinstance(node, ast.FunctionDef)]


def _solution_code(source: str) -> str:
    return "\n".join(line for line in source.splitlines() if line.strip() not in ("### BEGIN SOLUTION",
                                                                                   "### END SOLUTION"))


def _checked(code: str) -> list[str] | None:
    """The functions a visible cell's ``run_checks(...)`` call names (None when it has no such call)."""
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None)) == "run_checks":
            # (``**mapping`` names no function: shown as written, it matches none and the cell is refused)
            return [keyword.arg if keyword.arg is not None else f"**{ast.unparse(keyword.value)}"
                    for keyword in node.keywords]
    return None


def exercise_settings(name: str, notebook: dict) -> tuple[dict[str, float], tuple[str, ...]]:
    """``(points per function, masked packages)`` from a notebook's ``"labkit"`` metadata, checked."""
    settings = notebook.get("metadata", {}).get("labkit")
    if type(settings) is not dict or type(settings.get("functions")) is not dict or not settings["functions"]:
        raise _problem(name, 'the notebook\'s metadata needs "labkit": {"functions": {name: points, ...}} (what '
                             "students write, and what each function is worth)")
    points = settings["functions"]
    for function, value in points.items():
        if not function.isidentifier() or type(value) not in (int, float) or not value > 0:
            raise _problem(name, f"labkit.functions: {function!r} must be a Python name worth a positive number "
                                 f"of points, got {value!r}")
    masked = settings.get("masked", [])
    if type(masked) is not list or not all(type(m) is str and m.isidentifier() for m in masked):
        raise _problem(name, "labkit.masked must be a list of top-level package names, e.g. ['sklearn']")
    if settings.get("exercise", name) != name:
        raise _problem(name, f"labkit.exercise says {settings.get('exercise')!r}")
    return {f: float(v) for f, v in points.items()}, tuple(masked)


def _hidden_tests(name: str, module: ModuleType | None, graded: set[str], functions: tuple[str, ...]
                  ) -> dict[str, list[HiddenTest]]:
    """The spec's hidden tests by grade id, checked: each named after a graded cell, taking one function and rng."""
    found: dict[str, list[HiddenTest]] = {gid: [] for gid in graded}
    for attribute, value in vars(module).items() if module is not None else ():
        if not attribute.startswith("test_") or not inspect.isfunction(value):
            continue
        gid = attribute.partition("__")[0]
        if gid not in graded:
            raise _problem(name, f"the spec's {attribute}() matches no graded cell of the notebook ({sorted(graded)})")
        parameters = list(inspect.signature(value).parameters)
        taken = [p for p in parameters if p != "rng"]
        if len(taken) != 1 or taken[0] not in functions or set(parameters) - {"rng", *functions}:
            raise _problem(name, f"{attribute}() takes {parameters}; a hidden test takes one of the student's "
                                 f"functions {list(functions)} (the one it grades) and rng")
        found[gid].append(HiddenTest(attribute, taken[0], value))
    return found


def build_exercise(name: str, source: dict, release: dict, module: ModuleType | None) -> Exercise:
    """Check a source notebook, its release and its spec against each other; the exercise they make.

    ``module`` None builds the exercise from the notebook's visible checks alone (``source`` may then be
    the release itself): what ``--check`` runs without the course.
    """
    points, masked = exercise_settings(name, source)
    functions = tuple(points)
    if module is not None:
        for old in ("FUNCTIONS", "MASKED"):
            if hasattr(module, old):
                raise _problem(name, f"the spec's {old} moved into the notebook's metadata (\"labkit\")")
    written = []
    setup, cells, test_cells = [], [], {}
    for cell in source["cells"]:
        meta, gid, text = nbgrader_metadata(cell), grade_id(cell), cell_source(cell)
        if not meta or gid in test_cells:  # (a student's copy: their own cells, a test cell pasted twice)
            continue
        if cell["cell_type"] == "code" and MARKERS[0] in text:
            raise _problem(name, f"cell {gid} has hidden tests in the notebook: move them into its spec's "
                                 f"function {gid}(...), where students never see them")
        if meta.get("solution"):
            written += _defined_functions(_solution_code(text)) if cell["cell_type"] == "code" else []
        if meta.get("grade"):
            if type(gid) is not str or not gid.isidentifier() or "__" in gid:
                raise _problem(name, f"graded cell {gid!r}: its grade id must be a Python name without '__'")
            auto = cell["cell_type"] == "code" and not meta.get("solution")
            cells.append((gid, float(meta.get("points", 0)), text if auto else "", auto))
            if auto:
                test_cells[gid] = text
        elif cell["cell_type"] == "code" and not meta.get("solution"):
            setup.append(text)
    missing = [f for f in functions if f not in written]
    if missing:
        raise _problem(name, f"labkit.functions names {missing}, which no solution cell defines")
    hidden = _hidden_tests(name, module, {gid for gid, *_ in cells}, functions)
    total = sum(cell_points for _, cell_points, _, auto in cells if auto)
    if not math.isclose(sum(points.values()), total):
        raise _problem(name, f"the functions' points ({sum(points.values()):g}) must add up to the graded cells' "
                             f"({total:g})")
    built = []
    for gid, cell_points, code, auto in cells:
        shares = {f: round(cell_points * points[f] / total, 6) for f in functions} if auto else {}
        built.append(GradedCell(gid, cell_points, code, tuple(hidden[gid]), auto, shares))
        if not auto:
            continue
        checked = _checked(code) if built[-1].visible else []
        if checked is None:
            raise _problem(name, f"graded cell {gid} has code but no run_checks(...) call: its checks must say which "
                                 "function each one grades")
        if checked and sorted(checked) != sorted(functions):
            raise _problem(name, f"the run_checks(...) of cell {gid} checks {checked}, not the functions "
                                 f"{list(functions)}")
        untested = [f for f in functions if f not in checked and not built[-1].tests_of(f)]
        if module is not None and untested:
            raise _problem(name, f"graded cell {gid} tests nothing of {untested} (no visible check, no hidden "
                                 "test): it would give their points away")
    released = {grade_id(c): cell_source(c) for c in release["cells"] if grade_id(c) is not None}
    for gid, text in test_cells.items():
        if gid not in released or not same_code(released[gid], text):
            raise ValueError(f"exercises/release/{name} is stale (cell {gid} differs from the source):"
                             " run `make release`")
    if release.get("metadata", {}).get("labkit") != source.get("metadata", {}).get("labkit"):
        raise ValueError(f"exercises/release/{name} is stale (its labkit metadata differs from the source):"
                         " run `make release`")
    timeouts = {key: float(getattr(module, key, default)) for key, default in TIMEOUTS.items()}
    return Exercise(
        name=name, source=source, release=release, module=module, functions=functions, points=points,
        masked=masked, setup=tuple(setup), cells=tuple(built), test_cells=test_cells,
        call_timeout_s=timeouts["CALL_TIMEOUT_S"], test_timeout_s=timeouts["TEST_TIMEOUT_S"],
        load_timeout_s=timeouts["LOAD_TIMEOUT_S"], submission_timeout_s=timeouts["SUBMISSION_TIMEOUT_S"],
        limits=getattr(module, "LIMITS", Limits()),
    )


def release_exercise(notebook: dict) -> Exercise:
    """The exercise a release notebook (or a student's copy of it) describes, without the course.

    It has the notebook's visible checks, functions, points and masked packages, and no hidden tests.

    Parameters
    ----------
    notebook : dict
        The release notebook, or a student's copy of it.

    Returns
    -------
    Exercise
        The exercise, without its spec (``module`` None).

    Raises
    ------
    ValueError
        When the notebook is not an exercise of this course, or a locked cell was changed (its nbgrader
        checksum differs): then its checks are not the ones the grader runs.
    """
    from nbformat import from_dict
    from nbgrader.utils import compute_checksum, is_locked

    settings = notebook.get("metadata", {}).get("labkit")
    name = settings.get("exercise") if type(settings) is dict else None
    if type(name) is not str or not re.fullmatch(r"[A-Za-z0-9_]+", name):
        raise ValueError("this notebook is not an exercise of the course (no labkit metadata): check the release "
                         "notebook you were given, with your answers in it")
    for cell in notebook["cells"]:
        meta = nbgrader_metadata(cell)
        if not meta or not meta.get("checksum") or not is_locked(from_dict({**cell, "outputs": []})):
            continue
        if compute_checksum(from_dict({**cell, "outputs": [], "execution_count": None})) != meta["checksum"]:
            raise ValueError(f"the locked cell {grade_id(cell)} of your notebook was changed: copy it back from the "
                             "release (the grader runs the release's copy)")
    return build_exercise(name, notebook, notebook, None)


class Course:
    """An nbgrader course folder: ``source/``, ``release/``, ``grading/``, ``submitted/``, ``autograded/``, ...

    Parameters
    ----------
    root : path
        The folder that holds ``nbgrader_config.py`` (the repository's ``exercises/``).
    """

    def __init__(self, root: Path | str) -> None:
        self.root = Path(root).resolve()
        if not (self.root / "source").is_dir():
            raise FileNotFoundError(f"{self.root} is not a course folder: it has no source/ (pass --course exercises)")
        self._exercises: dict[str, Exercise] = {}

    source = property(lambda self: self.root / "source")
    release = property(lambda self: self.root / "release")
    specs = property(lambda self: self.root / "grading")
    submitted = property(lambda self: self.root / "submitted")
    autograded = property(lambda self: self.root / "autograded")
    records = property(lambda self: self.root / "records")
    gradebook = property(lambda self: self.root / "gradebook.db")
    secret_file = property(lambda self: self.root / ".grading_secret")

    def names(self) -> list[str]:
        """Every exercise: the folders of ``source/`` that hold a notebook of their name."""
        return sorted(p.name for p in self.source.iterdir() if (p / f"{p.name}.ipynb").is_file())

    def resolve(self, wanted: str) -> list[str]:
        """``all``, an exercise's name or a unique prefix of it (``ex01``) -> exercise names."""
        names = self.names()
        if wanted == "all":
            return names
        if wanted in names:
            return [wanted]
        matches = [n for n in names if n.startswith(wanted) or re.sub(r"_.*", "", n) == wanted]
        if len(matches) != 1:
            raise ValueError(f"no exercise {wanted!r} in {self.source} (one of: all, {', '.join(names)})")
        return matches

    def exercise(self, name: str) -> Exercise:
        """The exercise ``name``, checked (source, release and spec agree), loaded once."""
        if name not in self._exercises:
            spec = self.specs / f"{name}.py"
            if not spec.is_file():
                raise FileNotFoundError(f"exercise {name} has no grading spec {spec} (its hidden tests)")
            paths = [self.source / name / f"{name}.ipynb", self.release / name / f"{name}.ipynb"]
            if not paths[1].is_file():
                raise FileNotFoundError(f"{paths[1]} is missing: run `make release`")
            try:
                source, release = (read_notebook(p) for p in paths)
            except InvalidNotebook as error:
                raise ValueError(f"exercise {name}: {error}") from None
            self._exercises[name] = build_exercise(name, source, release, _load_module(name, spec))
        return self._exercises[name]


def find_course(path: Path | str | None = None) -> Course:
    """The course at ``path``; by default ``./exercises``, or ``.`` when it is a course folder itself.

    Parameters
    ----------
    path : Path or str or None
        The course folder; None: the default.

    Returns
    -------
    Course
        The course.
    """
    if path is not None:
        return Course(path)
    for candidate in (Path("exercises"), Path(".")):
        if (candidate / "source").is_dir() and (candidate / "nbgrader_config.py").is_file():
            return Course(candidate)
    raise FileNotFoundError("no course here: run from the repository root (which holds exercises/) or pass --course")
