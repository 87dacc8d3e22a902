"""The tests' side of grading: the visible checks' runner, and the hidden tests' comparisons.

:func:`run_checks` runs a notebook's visible checks, one per function a student writes: in Jupyter
(and ``labkit grade --check``) it runs them all and says which failed; when the notebook is graded, the
grader calls it with each check counted for its own function.

:func:`assert_beams_result` compares a ``(points, indices)`` answer with the reference,
:func:`assert_labels_result` a per-item label array and :func:`assert_line_result` a line
``(r, alpha)`` in normal form; :class:`Moved` moves a test's inputs (and its answers) to a random
place. They run on the grader's trusted side, on the plain values the worker sent back (numbers,
strings, lists, tuples, exact numpy arrays of numeric dtype): nothing the student's code built
reaches them. Their messages name what is wrong -- the type, the shape, how many items differ and
where the first one is, how large an error is -- and never the inputs or the expected values: they
are the feedback on inputs the student has not seen.
"""

from __future__ import annotations

import contextvars
import math
import numbers
from collections.abc import Callable
from typing import Any

import numpy as np

from ..course import Feedback, student_frames
from ..geometry import normalize_line, transform_points, wrap_angle

__all__ = ["run_checks", "ChecksFailed", "Moved", "assert_beams_result", "assert_labels_result", "assert_line_result"]


class ChecksFailed(Feedback):
    """Visible checks failed, with each failing function's error and where it was raised.

    The message says where in the notebook's code each error was raised (the check's line, the line of
    the student's function). In Jupyter it shows as this message alone."""

#: Set by the grader while it runs a visible cell: what :func:`run_checks` hands each check to.
GRADER: contextvars.ContextVar[Callable[[str, Callable], None] | None] = contextvars.ContextVar(
    "labkit_grading_checks", default=None)


def run_checks(**checks: Callable[[np.random.Generator], None]) -> None:
    """Run each function's visible checks: ``run_checks(segment=check_segment, ...)``.

    Each check is called with a fresh ``numpy.random.Generator`` (for the examples it draws) and raises
    (an ``AssertionError`` saying what is wrong) when its function gets an example wrong. In Jupyter
    every check runs, a line per function says whether it passed, and :class:`ChecksFailed` is raised at
    the end with every failure and the lines of the notebook where each was raised (no traceback into
    labkit); ``visible tests passed`` when none failed.

    When the notebook is graded (``labkit grade``, or ``--check``), the grader runs each check on its
    own, with a generator drawn for the submission: a check that fails costs its own function's share
    of the cell only.

    Parameters
    ----------
    **checks
        Function name -> its check, ``check(rng)``.

    Examples
    --------
    >>> def check_double(rng):
    ...     assert 2 * 3 == 6
    >>> run_checks(double=check_double)
    double: passed
    visible tests passed
    >>> def check_half(rng):
    ...     assert 3 // 2 == 1.5, "3 // 2 is floor division: use 3 / 2"
    >>> try:
    ...     run_checks(double=check_double, half=check_half)
    ... except ChecksFailed as failed:
    ...     print(failed)
    double: passed
    half: FAILED
    half: AssertionError: 3 // 2 is floor division: use 3 / 2
      at line 2 in check_half: assert 3 // 2 == 1.5, "3 // 2 is floor division: use 3 / 2"
    """
    for function, check in checks.items():
        if not callable(check):
            raise TypeError(f"run_checks({function}=...) needs a function of rng, got {type(check).__name__}")
    grader = GRADER.get()
    if grader is not None:
        for function, check in checks.items():
            grader(function, check)
        return
    failures = []
    for function, check in checks.items():
        try:
            check(np.random.default_rng())
        except Exception as error:  # noqa: BLE001 -- reported, and raised together below
            frames = student_frames(error)
            failures.append(f"{function}: {type(error).__name__}: {error}" + (f"\n  at {frames}" if frames else ""))
            print(f"{function}: FAILED")
        else:
            print(f"{function}: passed")
    if failures:
        raise ChecksFailed("\n".join(failures))
    print("visible tests passed")


def _magnitude(error: float) -> str:
    """The order of magnitude of an error, not its value: ``about 1e-3``."""
    return f"about 1e{math.floor(math.log10(error)):d}" if error > 0 and math.isfinite(error) else "an unknown amount"


def _differ(count: int, total: int, item: str, first: int) -> str:
    items, verb = f"{item}s" if total != 1 else item, "differs" if count == 1 else "differ"
    return f"{count} of {total} {items} {verb} from the reference (the first at {item} {first})"


def assert_beams_result(result: Any, points: Any, indices: Any, *, atol: float = 1e-9) -> None:
    """Check a ``(points, indices)`` answer against the expected points and beam indices.

    Parameters
    ----------
    result : object
        What the student's function returned; expected a tuple ``(points, indices)``.
    points : array_like of shape (M, 2), metres
        Expected points, e.g. :attr:`labkit.Scan.xy`.
    indices : array_like of shape (M,), int
        Expected beam indices, e.g. :attr:`labkit.Scan.valid_indices`.
    atol : float, metres
        Absolute tolerance on the coordinates (a relative tolerance of 1e-9 applies too).

    Raises
    ------
    AssertionError
        With a message that says which part (type, shape, dtype, indices, values) is wrong, without the
        expected values.

    Examples
    --------
    >>> assert_beams_result((np.array([[1.0, 0.0]]), np.array([0])), [[1.0, 0.0]], [0])
    >>> assert_beams_result((np.zeros((1, 2)), np.array([0])), [[1.0, 0.0]], [0])
    Traceback (most recent call last):
    ...
    AssertionError: points are wrong: 1 of 1 row differs from the reference (the first at row 0)
    """
    expected_points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    expected_indices = np.asarray(indices, dtype=np.int64).reshape(-1)
    if not isinstance(result, tuple) or len(result) != 2:
        raise AssertionError(f"expected a tuple (points, indices), got {type(result).__name__}")
    got_points, got_indices = result
    for name, value in [("points", got_points), ("indices", got_indices)]:
        if not isinstance(value, np.ndarray):
            raise AssertionError(f"{name} must be a numpy array, got {type(value).__name__}")
    if got_points.ndim != 2 or got_points.shape[1:] != (2,):
        raise AssertionError(f"points must have shape (M, 2), one row per valid beam, got {got_points.shape}")
    if got_points.dtype != np.float64:
        raise AssertionError(f"points must have dtype float64, got {got_points.dtype}")
    if got_indices.shape != (got_points.shape[0],):
        raise AssertionError(f"indices must have shape (M,), one per row of points, got {got_indices.shape}")
    if not np.issubdtype(got_indices.dtype, np.integer):
        raise AssertionError(f"indices must be integers, got dtype {got_indices.dtype}")
    if got_indices.shape != expected_indices.shape:
        raise AssertionError("the number of rows is wrong: one row per beam with a valid reading")
    if not np.array_equal(got_indices, expected_indices):
        wrong = np.flatnonzero(got_indices != expected_indices)
        raise AssertionError(f"indices are wrong: {_differ(wrong.size, got_indices.size, 'position', int(wrong[0]))}")
    close = np.isclose(got_points, expected_points, rtol=1e-9, atol=atol)
    if not np.all(close):
        rows = np.flatnonzero(~np.all(close, axis=1))
        raise AssertionError(f"points are wrong: {_differ(rows.size, got_points.shape[0], 'row', int(rows[0]))}")


def assert_labels_result(result: Any, expected: Any, *, name: str = "labels", item: str = "beam") -> None:
    """Check an array of integer labels (one per item, -1 for "none") against the expected one.

    Parameters
    ----------
    result : object
        What the student's function returned; expected a numpy integer array.
    expected : array_like of shape (N,), int
        The reference labels, e.g. from :func:`labkit.segment_labels`.
    name, item : str
        How the message calls the array and its items ("labels", "beam").

    Raises
    ------
    AssertionError
        With a message that says which part (type, shape, dtype, how many items differ and the first)
        is wrong, without the expected labels.

    Examples
    --------
    >>> assert_labels_result(np.array([0, 0, -1]), [0, 0, -1])
    >>> assert_labels_result(np.array([0, 1, -1]), [0, 0, -1])
    Traceback (most recent call last):
    ...
    AssertionError: labels are wrong: 1 of 3 beams differs from the reference (the first at beam 1)
    """
    want = np.asarray(expected, dtype=np.int64).reshape(-1)
    if not isinstance(result, np.ndarray):
        raise AssertionError(f"{name} must be a numpy array, got {type(result).__name__}")
    if result.shape != want.shape:
        raise AssertionError(f"{name} must have shape {want.shape} (one per {item}), got {result.shape}")
    if not np.issubdtype(result.dtype, np.integer):
        raise AssertionError(f"{name} must be integers, got dtype {result.dtype}")
    wrong = np.flatnonzero(result != want)
    if wrong.size:
        raise AssertionError(f"{name} are wrong: {_differ(wrong.size, want.size, item, int(wrong[0]))}")


def assert_line_result(result: Any, r: float, alpha: float, *, atol: float = 1e-7) -> None:
    """Check a line ``(r, alpha)`` in normal form ``x cos(alpha) + y sin(alpha) = r``.

    Parameters
    ----------
    result : object
        What the student's function returned; expected a tuple of two real numbers
        ``(r, alpha)`` with ``r >= 0`` (metres) and ``alpha`` in (-pi, pi] (radians).
    r, alpha : float
        The expected line, e.g. :attr:`labkit.LineFit.r` and :attr:`labkit.LineFit.alpha`.
    atol : float
        Absolute tolerance on ``r`` (metres) and on ``alpha`` (radians; the difference is
        taken across the wrap, so -pi + 1e-12 is close to pi).

    Raises
    ------
    AssertionError
        With a message that says which part (type, sign of r, range of alpha, value) is wrong, and the
        error's order of magnitude (not the expected value).

    Examples
    --------
    >>> assert_line_result((2.0, 0.0), 2.0, 1e-12)
    >>> assert_line_result((-2.0, math.pi), 2.0, 0.0)
    Traceback (most recent call last):
    ...
    AssertionError: r must be >= 0 (turn the normal around: r -> -r, alpha -> alpha + pi), got a negative r
    """
    if not isinstance(result, tuple) or len(result) != 2:
        raise AssertionError(f"expected a tuple (r, alpha), got {type(result).__name__}")
    for name, value in zip(("r", "alpha"), result, strict=True):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise AssertionError(f"{name} must be a number (float), got {type(value).__name__}")
        if not math.isfinite(value):
            raise AssertionError(f"{name} must be finite, got {value}")
    got_r, got_alpha = float(result[0]), float(result[1])
    if got_r < 0:
        raise AssertionError("r must be >= 0 (turn the normal around: r -> -r, alpha -> alpha + pi), got a negative r")
    if not -math.pi < got_alpha <= math.pi:
        raise AssertionError("alpha must be in (-pi, pi] (wrap it)")
    if abs(got_r - r) > atol:
        raise AssertionError(f"r is wrong: off by {_magnitude(abs(got_r - r))} m (allowed: {atol:g} m)")
    gap = abs(math.remainder(got_alpha - alpha, 2 * math.pi))
    if gap > atol:
        hint = " (off by pi: the normal turned around?)" if abs(gap - math.pi) < 1e-6 else ""
        raise AssertionError(f"alpha is wrong: off by {_magnitude(gap)} rad (allowed: {atol:g} rad){hint}")


class Moved:
    """A random similarity of the plane: scale by ``scale``, turn by ``angle``, then shift by ``shift``.

    The spec of an exercise grades its visible examples a second time, moved: every number changes,
    the answer changes as geometry says (labels and indices stay, points and lines move with the
    plane), so a table of the visible answers earns nothing while a working function passes.
    ``scale`` is a power of two other than 1 (1/4 to 8), so scaled readings keep exact ties (a gap of
    exactly ``eps``, a reading exactly at ``range_min``) and no visible input comes back unchanged
    (with a scale of 1, a table keyed on the ranges found the turned examples again: 1 seed in 6).

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the scale, the angle and the shift.
    shift : bool
        Shift the plane too (False: turn and scale about the origin, e.g. for scans seen from it).

    Examples
    --------
    >>> moved = Moved(np.random.default_rng(0))
    >>> r, alpha = moved.line(2.0, 0.0)
    >>> bool(np.isclose(r, moved.scale * 2.0 + moved.shift @ [np.cos(alpha), np.sin(alpha)]))
    True
    """

    def __init__(self, rng: np.random.Generator, *, shift: bool = True) -> None:
        k = int(rng.integers(-2, 3))
        self.scale = float(2.0 ** (k + (k >= 0)))  # 1/4 to 8, never 1: a table of the visible inputs never matches
        self.angle = float(rng.uniform(-np.pi, np.pi))
        self.shift = rng.uniform(-5.0, 5.0, 2) if shift else np.zeros(2)

    def points(self, points: Any) -> np.ndarray:
        """``points`` (N x 2) moved."""
        xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        return transform_points(self.scale * xy, (*self.shift, self.angle))

    def bearing(self, angles: Any) -> Any:
        """Directions (radians) turned with the plane, wrapped into (-pi, pi]."""
        return wrap_angle(np.asarray(angles, dtype=np.float64) + self.angle)

    def line(self, r: float, alpha: float) -> tuple[float, float]:
        """The line ``x cos(alpha) + y sin(alpha) = r`` moved, in normal form again (r >= 0)."""
        alpha = float(self.bearing(alpha))
        return normalize_line(self.scale * r + float(self.shift @ [np.cos(alpha), np.sin(alpha)]), alpha)
