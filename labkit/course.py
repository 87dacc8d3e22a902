"""Checks for the course notebooks' "your turn" cells.

A "your turn" cell gives the student a function to complete; the stub as shipped raises
``NotImplementedError``. The check cell after it calls :func:`check` with cases whose
expected answers come from independent truth (closed-form geometry, a brute-force count,
labkit's own function) and a hint for each:

- the stub is not done yet: one line says so and the notebook goes on with labkit's
  version (``fallback``), so it still runs top to bottom untouched;
- a case fails: :class:`YourTurnError` says which input, what was expected, what came
  back, and the case's hint;
- every case passes: one line says so and the student's own function is used from then on.

>>> def double(x):
...     raise NotImplementedError
>>> f = check(double, [Case((2,), 4, hint="twice x")], fallback=lambda x: 2 * x)
not done yet: double still raises NotImplementedError; the notebook goes on with labkit's version
>>> f(3)
6
>>> def double(x):
...     return x + 2
>>> check(double, [Case((2,), 4, "twice x"), Case((5,), 10, "twice x, not x + 2")], fallback=None)
Traceback (most recent call last):
...
labkit.course.YourTurnError: double(5) returned 7, expected 10. Hint: twice x, not x + 2

Where arrays differ, the message lists the entries that differ, not a cut-down print of both:

>>> def is_far(ranges):
...     return np.asarray(ranges) > 2.0
>>> ranges = np.arange(40.0)
>>> check(is_far, [Case((ranges,), ranges >= 2.0, hint="at least 2 m")], fallback=None)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
labkit.course.YourTurnError: is_far(...) returned an array that differs at 1 of 40 entries: [2] is False, ...

In Jupyter a :class:`Feedback` error shows as its message alone: no traceback into labkit.
"""

from __future__ import annotations

import sys
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["Case", "Feedback", "YourTurnError", "check", "student_frames"]

_LABKIT = Path(__file__).resolve().parent
_INSTALLED = tuple({str(Path(p).resolve()) for p in (sys.prefix, sys.base_prefix, sys.exec_prefix)})
#: At most this many differing entries are listed in a message.
SHOWN_DIFFERENCES = 6


class Feedback(AssertionError):
    """Feedback on a student's answer: in Jupyter (IPython) it shows as its message alone.

    IPython asks an exception for ``_render_traceback_`` before it formats a traceback: the frames of
    labkit's checking code say nothing to a student, the message says what was wrong and where.
    """

    def _render_traceback_(self) -> list[str]:
        return [f"\x1b[0;31m{type(self).__name__}\x1b[0m: {self}"]


class YourTurnError(Feedback):
    """A "your turn" function gave a wrong answer; the message says where and gives a hint."""


def student_frames(error: BaseException, limit: int = 3) -> str:
    """Describe where the student's own code raised ``error``, one entry per frame.

    Only the frames of the student's code count (not labkit's, not an installed package's nor Python's
    own), each as e.g. ``line 7 in segment: x = ranges[i + 1]``.

    Parameters
    ----------
    error : BaseException
        The exception, with its traceback.
    limit : int
        How many of the innermost such frames to keep.

    Returns
    -------
    str
        The entries joined by ``"; "``, innermost last; empty when no frame is the student's."""
    lines = []
    for frame in traceback.extract_tb(error.__traceback__):
        where = str(Path(frame.filename).resolve()) if frame.filename and not frame.filename.startswith("<") else ""
        if where and (where.startswith(str(_LABKIT)) or where.startswith(_INSTALLED)):
            continue
        text = f"line {frame.lineno} in {frame.name}" + (f": {frame.line.strip()}" if frame.line else "")
        lines.append(text)
    return "; ".join(lines[-limit:])


@dataclass(frozen=True)
class Case:
    """One input of a check, what it should give, and a hint for when it does not.

    Parameters
    ----------
    args : tuple
        The positional arguments of the call.
    expected : object
        What the call should return: compared with :func:`numpy.allclose` (``atol``, ``rtol``, NaN
        equal to NaN) for numbers and arrays, by ``==`` otherwise, or by ``compare(got, expected)``
        when given.
    hint : str
        What to look at when the case fails.
    kwargs : dict
        The keyword arguments of the call.
    raises : type of BaseException or None
        The exception type the call must raise instead (types are checked, never message wording).
    atol : float
        The absolute tolerance.
    rtol : float
        The relative tolerance.
    compare : callable or None
        ``compare(got, expected)`` returning True when they agree.
    label : str
        What a message shows between the call's brackets (``name(label)``); empty: the arguments.
    """

    args: tuple
    expected: Any = None
    hint: str = ""
    kwargs: dict = field(default_factory=dict)
    raises: type[BaseException] | None = None
    atol: float = 1e-9
    rtol: float = 1e-9
    compare: Callable[[Any, Any], bool] | None = None
    label: str = ""


def _show(value: Any, limit: int = 160) -> str:
    if isinstance(value, np.ndarray):
        text = np.array2string(value, precision=4, threshold=12)
    else:
        text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _differences(got: Any, expected: Any, case: Case) -> str:
    """How an array answer differs from the expected one: its shape, or the entries that differ (index, value,
    expected value), the first :data:`SHOWN_DIFFERENCES` of them; "" when that cannot be said of these values."""
    try:
        g = np.asarray(got)
        e = np.asarray(expected)
    except (TypeError, ValueError):
        return ""
    if e.ndim == 0 or g.dtype == object or e.dtype == object:
        return ""
    if g.shape != e.shape:
        return f"an array of shape {g.shape}, expected shape {e.shape}"
    try:
        if g.dtype.kind in "fc" or e.dtype.kind in "fc":
            same = np.isclose(g, e, atol=case.atol, rtol=case.rtol, equal_nan=True)
        else:
            same = g == e
    except TypeError:
        return ""
    wrong = np.argwhere(~np.asarray(same, dtype=bool))
    if wrong.size == 0:
        return ""
    shown = []
    for index in wrong[:SHOWN_DIFFERENCES]:
        key = tuple(int(i) for i in index)
        at = ", ".join(str(i) for i in key)
        shown.append(f"[{at}] is {_show(g[key].item(), 40)}, expected {_show(e[key].item(), 40)}")
    more = f" (and {len(wrong) - SHOWN_DIFFERENCES} more)" if len(wrong) > SHOWN_DIFFERENCES else ""
    return f"an array that differs at {len(wrong)} of {e.size} entries: {'; '.join(shown)}{more}"


def _call_text(name: str, case: Case) -> str:
    if case.label:
        return f"{name}({case.label})"
    parts = [_show(a, 60) for a in case.args] + [f"{k}={_show(v, 60)}" for k, v in case.kwargs.items()]
    return f"{name}({', '.join(parts)})"


def _equal(got: Any, expected: Any, case: Case) -> bool:
    if case.compare is not None:
        return bool(case.compare(got, expected))
    if isinstance(expected, (bool, np.bool_)):
        return isinstance(got, (bool, np.bool_)) and bool(got) == bool(expected)
    if isinstance(expected, str) or expected is None:
        return got == expected
    if isinstance(expected, (tuple, list)) and not all(isinstance(e, (int, float, np.number)) for e in expected):
        if not isinstance(got, (tuple, list)) or len(got) != len(expected):
            return False
        return all(_equal(g, e, case) for g, e in zip(got, expected, strict=True))
    try:
        g = np.asarray(got, dtype=float)
        e = np.asarray(expected, dtype=float)
    except (TypeError, ValueError):
        return got == expected
    if g.shape != e.shape:
        return False
    return bool(np.allclose(g, e, atol=case.atol, rtol=case.rtol, equal_nan=True))


def check(student: Callable, cases: Sequence[Case], *, fallback: Callable | None, name: str | None = None,
          quiet: bool = False) -> Callable:
    """Check a "your turn" function on ``cases``; return the function to go on with.

    Raises :class:`YourTurnError` on the first case that fails, naming the input, the expected and
    the returned value and the hint.

    Parameters
    ----------
    student : callable
        The student's function.
    cases : sequence of Case
        The inputs and what they should give.
    fallback : callable or None
        The labkit version, to go on with while the stub still raises ``NotImplementedError``;
        None: a stub that still raises is a :class:`YourTurnError`.
    name : str or None
        The function's name in messages; None: its ``__name__``.
    quiet : bool
        Print nothing when every case passes.

    Returns
    -------
    callable
        ``student`` when every case passes, ``fallback`` when the stub is not written yet.
    """
    own_name: str = getattr(student, "__name__", "your function")
    name = name or own_name
    if not cases:
        raise ValueError("check needs at least one case")
    for case in cases:
        call = _call_text(name, case)
        try:
            got = student(*case.args, **case.kwargs)
        except NotImplementedError:
            if fallback is None:
                raise YourTurnError(f"{name} still raises NotImplementedError: complete it above") from None
            print(f"not done yet: {name} still raises NotImplementedError; the notebook goes on with labkit's version")
            return fallback
        except Exception as exc:  # the student's error, reported in words, with where in their code it happened
            if case.raises is not None and isinstance(exc, case.raises):
                continue
            expected = f"{case.raises.__name__}" if case.raises else _show(case.expected)
            frames = student_frames(exc)
            where = f" (at {frames})" if frames else ""
            raise YourTurnError(f"{call} raised {type(exc).__name__}: {exc}{where}; expected {expected}. "
                                f"Hint: {case.hint}") from None
        if case.raises is not None:
            raise YourTurnError(f"{call} returned {_show(got)}, expected it to raise {case.raises.__name__}. "
                                f"Hint: {case.hint}")
        if not _equal(got, case.expected, case):
            differs = _differences(got, case.expected, case) if case.compare is None else ""
            if differs:
                raise YourTurnError(f"{call} returned {differs}. Hint: {case.hint}")
            raise YourTurnError(f"{call} returned {_show(got)}, expected {_show(case.expected)}. Hint: {case.hint}")
    if not quiet:
        print(f"well done: {name} passes all {len(cases)} checks; the notebook goes on with your version")
    return student
