"""The course on disk (``exercises/``) and its exercises as the trusted grader sees them.

An exercise is three trusted files:

- ``source/<name>/<name>.ipynb``: the instructor notebook. Its solution cells hold the answer,
  its graded test cells the *visible* tests (code only, no hidden-test markers), which the grader
  runs on its trusted side against the student's functions;
- ``release/<name>/<name>.ipynb``: what ``make release`` generated from it (the student copy,
  also the layout of the autograded notebook and of the gradebook's cells);
- ``grading/<name>.py``: the *spec*, a Python module with the hidden tests (one function per
  graded cell, named after its grade id) and what the worker may not import. See
  ``exercises/README.md`` for its form.

The spec never runs where student code runs, and nbgrader never copies it (it copies only
``source/<name>/``).
"""

from __future__ import annotations

import ast
import importlib.util
import inspect
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

from .notebook import InvalidNotebook, cell_source, grade_id, nbgrader_metadata, read_notebook, same_code
from .sandbox import Limits

__all__ = ["Course", "Exercise", "GradedCell", "find_course"]

MARKERS = ("### BEGIN HIDDEN TESTS", "### END HIDDEN TESTS")


@dataclass(frozen=True)
class GradedCell:
    """One graded cell of an exercise.

    Attributes
    ----------
    grade_id : str
    points : float
    code : str
        The visible tests: the source notebook's code of the cell (empty for a manually graded cell).
    hidden : callable or None
        The spec's hidden tests of the cell: called with the student's functions (by parameter
        name) and ``rng``, a generator seeded per submission.
    auto : bool
        False for a cell nbgrader leaves to a human (a graded answer cell or a markdown cell).
    """

    grade_id: str
    points: float
    code: str
    hidden: Callable[..., None] | None
    auto: bool = True

    @property
    def parameters(self) -> tuple[str, ...]:
        """The hidden tests' parameter names (the student's functions and ``rng``)."""
        return tuple(inspect.signature(self.hidden).parameters) if self.hidden else ()

    @property
    def visible(self) -> bool:
        """True when the visible code has a statement (not only comments)."""
        return bool(ast.parse(self.code).body) if self.auto else False


@dataclass(frozen=True)
class Exercise:
    """What the grader knows about one exercise; built by :meth:`Course.exercise`."""

    name: str
    source: dict
    release: dict
    module: ModuleType
    functions: tuple[str, ...]
    masked: tuple[str, ...]
    setup: tuple[str, ...]
    cells: tuple[GradedCell, ...]
    test_cells: dict[str, str]
    call_timeout_s: float
    test_timeout_s: float
    load_timeout_s: float
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
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses and pickling in a spec need their module registered
    spec.loader.exec_module(module)
    return module


def _defined_functions(source: str) -> list[str]:
    return [node.name for node in ast.parse(source).body if isinstance(node, ast.FunctionDef)]


def _solution_code(source: str) -> str:
    return "\n".join(line for line in source.splitlines() if line.strip() not in ("### BEGIN SOLUTION",
                                                                                   "### END SOLUTION"))


def build_exercise(name: str, source: dict, release: dict, module: ModuleType) -> Exercise:
    """Check a source notebook, its release and its spec against each other; the exercise they make."""
    functions = tuple(getattr(module, "FUNCTIONS", ()))
    if not functions or not all(isinstance(f, str) and f.isidentifier() for f in functions):
        raise _problem(name, "the spec must set FUNCTIONS = (the names of the functions students write, ...)")
    masked = tuple(getattr(module, "MASKED", ()))
    if not all(isinstance(m, str) and m.isidentifier() for m in masked):
        raise _problem(name, "MASKED must be a tuple of top-level package names, e.g. ('sklearn',)")
    written = []
    setup, cells, test_cells = [], [], {}
    for cell in source["cells"]:
        meta, gid, text = nbgrader_metadata(cell), grade_id(cell), cell_source(cell)
        if cell["cell_type"] == "code" and MARKERS[0] in text:
            raise _problem(name, f"cell {gid} has hidden tests in the notebook: move them into its spec's "
                                 f"function {gid}(...), where students never see them")
        if meta.get("solution"):
            written += _defined_functions(_solution_code(text)) if cell["cell_type"] == "code" else []
        if meta.get("grade"):
            if type(gid) is not str or not gid.isidentifier():
                raise _problem(name, f"graded cell {gid!r}: its grade id must be a Python name")
            auto = cell["cell_type"] == "code" and not meta.get("solution")
            cells.append(GradedCell(gid, float(meta.get("points", 0)), text if auto else "",
                                    getattr(module, gid, None), auto))
            if auto:
                test_cells[gid] = text
        elif cell["cell_type"] == "code" and not meta.get("solution"):
            setup.append(text)
    missing = [f for f in functions if f not in written]
    if missing:
        raise _problem(name, f"FUNCTIONS names {missing}, which no solution cell defines")
    graded = {cell.grade_id for cell in cells}
    for attribute, value in vars(module).items():
        if attribute.startswith("test_") and inspect.isfunction(value) and attribute not in graded:
            raise _problem(name, f"the spec's {attribute}() matches no graded cell of the notebook ({sorted(graded)})")
    for cell in cells:
        if cell.auto and not cell.visible and cell.hidden is None:
            raise _problem(name, f"graded cell {cell.grade_id} tests nothing (no code in the notebook, no"
                                 f" {cell.grade_id}() in the spec): it would give its points away")
        if cell.hidden is None:
            continue
        parameters = set(inspect.signature(cell.hidden).parameters)
        unknown = parameters - set(functions) - {"rng"}
        if unknown:
            raise _problem(name, f"{cell.grade_id}() takes {sorted(unknown)}; a hidden test may take the"
                                 f" student's functions {list(functions)} and rng")
    released = {grade_id(c): cell_source(c) for c in release["cells"] if grade_id(c) is not None}
    for gid, text in test_cells.items():
        if gid not in released or not same_code(released[gid], text):
            raise ValueError(f"exercises/release/{name} is stale (cell {gid} differs from the source):"
                             " run `make release`")
    return Exercise(
        name=name, source=source, release=release, module=module, functions=functions,
        masked=masked, setup=tuple(setup), cells=tuple(cells), test_cells=test_cells,
        call_timeout_s=float(getattr(module, "CALL_TIMEOUT_S", 5.0)),
        test_timeout_s=float(getattr(module, "TEST_TIMEOUT_S", 30.0)),
        load_timeout_s=float(getattr(module, "LOAD_TIMEOUT_S", 10.0)),
        limits=getattr(module, "LIMITS", Limits()),
    )


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
    """The course at ``path``; by default ``./exercises``, or ``.`` when it is a course folder itself."""
    if path is not None:
        return Course(path)
    for candidate in (Path("exercises"), Path(".")):
        if (candidate / "source").is_dir() and (candidate / "nbgrader_config.py").is_file():
            return Course(candidate)
    raise FileNotFoundError("no course here: run from the repository root (which holds exercises/) or pass --course")
