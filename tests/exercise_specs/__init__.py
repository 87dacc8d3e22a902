"""What ``tests/test_exercises.py`` needs to know about each nbgrader exercise: one module per exercise.

A module ``<name>.py`` in this package describes the exercise ``exercises/source/<name>/<name>.ipynb``
with a module-level ``SPEC = ExerciseSpec(...)``. The tests find the modules themselves
(:func:`load_specs`), so adding an exercise takes its source folder, its spec module and
``make release``; ``test_exercises.py`` stays as it is.

The spec holds only what the notebook cannot say about itself: which cells are the answer,
what the release must keep of them, the points, and submissions that prove the grading works
(a cheater that delegates to labkit, plausible mistakes, optionally an endless loop). The
instructor's solution and the hidden tests are read from the source notebook.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = ["ExerciseSpec", "load_specs"]


@dataclass(frozen=True)
class ExerciseSpec:
    """One exercise of the course, as the tests see it.

    Attributes
    ----------
    name : str
        Assignment name: the folder ``exercises/source/<name>/`` and its notebook ``<name>.ipynb``.
        Must equal the spec module's name.
    solutions : mapping of str to str
        ``grade_id`` of every solution cell (``"solution": true``) -> the line(s) of that cell the
        release must still contain (the function's ``def`` line, so that students keep the
        signature); several lines are separated by newlines.
    points : mapping of str to int
        ``grade_id`` of every graded test cell -> its points, exactly as in the source.
    cheater : mapping of str to str
        ``grade_id`` of every solution cell -> code that gets the right answers by calling labkit.
        Every graded cell calls the student's functions through ``labkit.grading.own_work``, so
        it must fail every graded cell (score 0); called directly (``own_work`` switched off) it
        must pass every graded cell except :attr:`guard`.
    caught : str
        Regular expression that the guard's ``AssertionError`` must match when it catches the
        cheater (the labkit function it called, e.g. ``r"labkit\\.scan\\.Scan"``).
    guard : str
        ``grade_id`` of the own-work cell, the only one that may use ``forbid_package_calls`` (the
        others wrap the student's functions in ``own_work``).
    visible : str
        ``grade_id`` of the visible test cell, the only graded cell without hidden tests.
    mistakes : mapping of str to (str, str)
        Plausible wrong answers, each a description -> ``(old, new)``: the instructor's
        solution with the text ``old`` (found exactly once in the solution cells) replaced by
        ``new``. A hidden test cell must fail for each, which shows that the hidden tests can
        tell a wrong answer from a right one.
    looper : mapping of str to str or None
        ``grade_id`` of every solution cell -> code that never returns. Autograded (one exercise
        is enough) to prove that the per-cell timeout stops an endless loop and grading goes on;
        each of its graded cells costs the full timeout.
    """

    name: str
    solutions: Mapping[str, str]
    points: Mapping[str, int]
    cheater: Mapping[str, str]
    caught: str
    guard: str = "test_own_work"
    visible: str = "test_visible"
    mistakes: Mapping[str, tuple[str, str]] = field(default_factory=dict)
    looper: Mapping[str, str] | None = None

    def __post_init__(self) -> None:
        problems = []
        if not self.solutions:
            problems.append("solutions is empty")
        for role, cell in [("guard", self.guard), ("visible", self.visible)]:
            if cell not in self.points:
                problems.append(f"{role} cell {cell!r} is not among the graded cells {sorted(self.points)}")
        if any(not isinstance(p, int) or p <= 0 for p in self.points.values()):
            problems.append(f"points must be positive integers, got {dict(self.points)}")
        if set(self.solutions) & set(self.points):
            problems.append("a cell cannot be both a solution cell and a graded test cell")
        for what, codes in [("cheater", self.cheater), ("looper", self.looper)]:
            if codes is not None and set(codes) != set(self.solutions):
                problems.append(f"{what} must give code for every solution cell {sorted(self.solutions)}, "
                                f"got {sorted(codes)}")
        if problems:
            raise ValueError(f"ExerciseSpec {self.name!r}: " + "; ".join(problems))

    @property
    def notebook(self) -> str:
        """File name of the notebook, in both source/ and release/."""
        return f"{self.name}.ipynb"

    @property
    def total(self) -> int:
        return sum(self.points.values())

    @property
    def hidden(self) -> frozenset[str]:
        """Graded cells that must hold hidden tests: every one but the visible cell."""
        return frozenset(self.points) - {self.visible}


def load_specs() -> list[ExerciseSpec]:
    """The ``SPEC`` of every module in this package, sorted by name."""
    specs = []
    for module_info in pkgutil.iter_modules(__path__):
        module = importlib.import_module(f"{__name__}.{module_info.name}")
        spec = getattr(module, "SPEC", None)
        if not isinstance(spec, ExerciseSpec):
            raise TypeError(f"{module.__name__} must define SPEC = ExerciseSpec(...)")
        if spec.name != module_info.name:
            raise ValueError(f"{module.__name__} describes {spec.name!r}: name the module after the exercise")
        specs.append(spec)
    return sorted(specs, key=lambda spec: spec.name)
