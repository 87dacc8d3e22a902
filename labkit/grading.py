"""Helpers for the hidden tests of the nbgrader exercises in ``exercises/``.

Exercises ask students for pure functions and grade them on fresh random inputs against
labkit's reference implementation. Two things make that work:

- :func:`random_beams` draws a scan's worth of beams with every kind of invalid reading
  (NaN, +/-inf, zero, negative, below ``range_min``, at or beyond ``range_max``), as
  keyword arguments that both the student's function and :class:`labkit.Scan` accept;
- :func:`forbid_package_calls` runs the student's function under a profiler and fails when
  the function called into labkit itself, so that a submission that only delegates to the
  reference earns no points for the cell that uses it (see its Notes for the limits);
  :func:`own_work` wraps the student's function in the same check, so that every graded cell
  that calls it through the wrapper fails for such a submission.

:func:`random_wall_beams` draws a partial sweep across a random scene of walls (runs of
neighbouring points, jumps between walls, clutter and invalid readings), the input of
segmentation and line-fitting exercises.

:func:`assert_beams_result` compares a ``(points, indices)`` answer with the reference,
:func:`assert_labels_result` a per-item label array and :func:`assert_line_result` a line
``(r, alpha)`` in normal form; they say what is wrong in words a student can act on.

This module imports the standard library and numpy only, so it can be imported (and its
profiler can run) without pulling in any other part of labkit.
"""

from __future__ import annotations

import functools
import importlib.util
import math
import numbers
import os
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "PackageCalls",
    "record_package_calls",
    "calls_into",
    "forbid_package_calls",
    "own_work",
    "random_beams",
    "random_wall_beams",
    "assert_beams_result",
    "assert_labels_result",
    "assert_line_result",
]

_THIS_FILE = os.path.realpath(__file__)
_THIS_MODULE = __name__


@dataclass(frozen=True)
class PackageCalls:
    """What :func:`record_package_calls` saw while the function ran.

    Attributes
    ----------
    result : object
        The function's return value.
    calls : tuple of str
        Qualified names (``module.qualname``) of the package's functions that were called,
        each once, in the order of their first call. Empty when none was.
    tampered : bool
        True when the function called ``sys.setprofile`` itself, which switches the
        recorder off: its calls after that point could not be seen.
    """

    result: Any
    calls: tuple[str, ...]
    tampered: bool

    @property
    def clean(self) -> bool:
        """True when no call into the package was seen and the recorder stayed on."""
        return not self.calls and not self.tampered


def _package_locations(package: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Directories (for a package) or files (for a plain module) that hold its code."""
    if not isinstance(package, str) or not package or package.startswith("."):
        raise ValueError(f"package must be an absolute module name such as 'labkit', got {package!r}")
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError) as exc:
        raise ValueError(f"package {package!r} cannot be found: {exc}") from None
    if spec is None:
        raise ValueError(f"package {package!r} cannot be found")
    dirs = tuple(os.path.realpath(p) + os.sep for p in (spec.submodule_search_locations or ()))
    files = () if dirs or not spec.origin else (os.path.realpath(spec.origin),)
    return dirs, files


@dataclass(frozen=True)
class _Run:
    """One call watched by :class:`_Watcher`: its result or the exception it raised."""

    result: Any
    error: Exception | None
    calls: tuple[str, ...]
    tampered: bool


class _Watcher:
    """Runs functions under a profiler that records their calls into one or more packages.

    The packages' locations are looked up once, and the verdict per code object is cached,
    so a wrapper built by :func:`own_work` costs little per call.
    """

    def __init__(self, packages: tuple[str, ...]) -> None:
        dirs: list[str] = []
        files: list[str] = []
        for package in packages:
            package_dirs, package_files = _package_locations(package)
            dirs += package_dirs
            files += package_files
        self.packages = packages
        self.dirs = tuple(dirs)
        self.files = frozenset(files)
        self.prefixes = tuple(package + "." for package in packages)
        self.by_code: dict[Any, bool] = {}

    def in_package(self, module_name: object) -> bool:
        return isinstance(module_name, str) and module_name != _THIS_MODULE and (
            module_name in self.packages or module_name.startswith(self.prefixes)
        )

    def code_in_package(self, code: Any, module_name: object) -> bool:
        hit = self.by_code.get(code)
        if hit is None:
            path = code.co_filename
            real = os.path.realpath(path) if os.path.isabs(path) else path
            hit = real != _THIS_FILE and (
                real in self.files or real.startswith(self.dirs) or self.in_package(module_name)
            )
            self.by_code[code] = hit
        return hit

    def run(self, func: Callable[..., Any], args: tuple, kwargs: dict) -> _Run:
        """Call ``func(*args, **kwargs)`` under the profiler. An ``Exception`` it raises is
        returned, not raised; anything else (``KeyboardInterrupt``) propagates."""
        seen: dict[str, None] = {}  # an insertion-ordered set
        state = {"active": True, "tampered": False}
        code_in_package, in_package, setprofile = self.code_in_package, self.in_package, sys.setprofile

        def profiler(frame: Any, event: str, arg: Any) -> None:
            if event == "c_call":  # the most frequent event that matters: first, and cheap for builtins
                if not state["active"]:
                    return
                if arg is setprofile:
                    state["tampered"] = True
                module_name = getattr(arg, "__module__", None)
                if module_name != "builtins" and in_package(module_name):
                    seen.setdefault(f"{module_name}.{getattr(arg, '__qualname__', repr(arg))}", None)
            elif event == "call":
                if not state["active"]:
                    return
                code = frame.f_code
                module_name = frame.f_globals.get("__name__")
                if code_in_package(code, module_name):
                    qualname = code.co_qualname
                    if "<locals>" in qualname and code.co_argcount and code.co_varnames[0] == "self":
                        # a method made by a factory (dataclasses' __init__): name it after its class
                        owner = type(frame.f_locals.get("self"))
                        qualname = f"{getattr(owner, '__qualname__', '?')}.{code.co_name}"
                    seen.setdefault(f"{module_name}.{qualname}", None)

        result, error = None, None
        previous = sys.getprofile()
        previous_threads = threading.getprofile()
        threading.setprofile(profiler)
        sys.setprofile(profiler)
        try:
            result = func(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001 -- handed back to the caller, who decides
            error = exc
        finally:
            state["active"] = False
            sys.setprofile(previous)
            threading.setprofile(previous_threads)
        return _Run(result=result, error=error, calls=tuple(seen), tampered=state["tampered"])


def record_package_calls(
    package: str, func: Callable[..., Any], /, *args: Any, **kwargs: Any
) -> PackageCalls:
    """Call ``func(*args, **kwargs)`` and record every call it makes into ``package``.

    The call runs under a profile function (:func:`sys.setprofile`, and
    :func:`threading.setprofile` for threads it starts). A call counts as a call into the
    package when the Python function's code lives in one of the package's directories, or
    its module (``__name__`` of its globals) is the package or one of its submodules --
    which also covers code that :mod:`dataclasses` generates at import time -- or, for a
    function implemented in C, its ``__module__`` is. This module itself (its helpers may
    be called from inside the package's hidden tests) is never counted.

    Parameters
    ----------
    package : str
        Top-level name of the package to watch, e.g. ``"labkit"``.
    func : callable
        The function under test (a student's answer).
    *args, **kwargs
        Passed to ``func`` unchanged.

    Returns
    -------
    PackageCalls
        ``result`` (what ``func`` returned), ``calls`` (qualified names seen) and
        ``tampered`` (``func`` called ``sys.setprofile``).

    Raises
    ------
    ValueError
        If ``package`` cannot be found.
    Exception
        Whatever ``func`` raises propagates unchanged, after the previous profile functions
        have been restored.

    See Also
    --------
    forbid_package_calls : the assertion the hidden tests use.

    Notes
    -----
    The previous profile functions of the calling thread and of new threads are restored
    afterwards, also when ``func`` raises or is interrupted (e.g. by nbgrader's per-cell
    timeout). The recorder slows Python-level calls down by a small constant factor; numpy
    work inside C is unaffected.

    Examples
    --------
    >>> import labkit
    >>> record_package_calls("labkit", labkit.polar_to_cartesian, [1.0], [0.0]).calls
    ('labkit.scan.polar_to_cartesian',)
    >>> record_package_calls("labkit", np.hypot, 3.0, 4.0).clean
    True
    """
    run = _Watcher((package,)).run(func, args, kwargs)
    if run.error is not None:
        raise run.error
    return PackageCalls(result=run.result, calls=run.calls, tampered=run.tampered)


def calls_into(package: str, func: Callable[..., Any], /, *args: Any, **kwargs: Any) -> bool:
    """True when ``func(*args, **kwargs)`` calls into ``package`` (or switches the recorder off).

    A shorthand for ``not record_package_calls(package, func, *args, **kwargs).clean``;
    see :func:`record_package_calls` for what counts as a call.

    Examples
    --------
    >>> import labkit
    >>> calls_into("labkit", lambda: labkit.Scan(ranges=[1.0], angles=[0.0]).xy)
    True
    >>> calls_into("labkit", lambda: np.cos(0.0))
    False
    """
    return not record_package_calls(package, func, *args, **kwargs).clean


def forbid_package_calls(package: str, func: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Any:
    """Call ``func(*args, **kwargs)`` and fail if it called into ``package``.

    The hidden "does its own work" test of an exercise runs the student's answer through
    this, so that a submission that only calls labkit's reference implementation (for
    example ``labkit.Scan(...).xy`` or ``labkit.polar_to_cartesian``) fails that cell.

    Parameters
    ----------
    package : str
        Top-level name of the forbidden package, e.g. ``"labkit"``.
    func : callable
        The function under test.
    *args, **kwargs
        Passed to ``func`` unchanged.

    Returns
    -------
    object
        What ``func`` returned, so the caller can check it against the reference.

    Raises
    ------
    AssertionError
        If ``func`` called any function of ``package`` (the message names them), or
        called ``sys.setprofile`` and so switched the check off.

    See Also
    --------
    record_package_calls : the recorder, and what counts as a call.

    Notes
    -----
    The check sees every call made in this process while ``func`` runs, in this thread
    and in threads it starts. It does not see work done in another process (``subprocess``,
    ``multiprocessing``), code copied out of the package and run under another file and
    module name, or results computed by the package before ``func`` was called. It is a
    guard against the obvious shortcut, not a proof of authorship; instructors should
    still read submissions that score suspiciously well.

    Examples
    --------
    >>> import labkit
    >>> forbid_package_calls("labkit", lambda r: np.asarray(r) * 2, [1.0])
    array([2.])
    >>> forbid_package_calls("labkit", labkit.polar_to_cartesian, [1.0], [0.0])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    AssertionError: polar_to_cartesian calls labkit's own implementation (labkit.scan.polar_to_cartesian); ...
    """
    return _guarded(func, (package,))(*args, **kwargs)


def _own_work_problem(name: str, packages: tuple[str, ...], calls: tuple[str, ...], tampered: bool) -> str | None:
    """What :func:`own_work` says about a watched call, or None."""
    if tampered:
        return (
            f"{name} called sys.setprofile, which switches off the check that it does not"
            f" call {' or '.join(packages)}; remove that call"
        )
    if calls:
        hit = [p for p in packages if any(c == p or c.startswith(p + ".") for c in calls)] or list(packages)
        shown = ", ".join(calls[:5]) + (", ..." if len(calls) > 5 else "")
        return (
            f"{name} calls {' and '.join(hit)}'s own implementation ({shown}); this exercise asks you to"
            f" write the computation yourself (numpy is fine)"
        )
    return None


def own_work(
    func: Callable[..., Any], package: str = "labkit", *, also: tuple[str, ...] = ()
) -> Callable[..., Any]:
    """``func`` wrapped so that every call fails when it calls into ``package`` (or ``also``).

    Every graded cell of an exercise calls the student's function through this wrapper
    (``checked = own_work(student_function)``, then ``checked(...)``), so that a submission
    that delegates to labkit's reference fails every cell, not only the own-work cell, and
    scores 0. An honest answer runs as before, a little slower (see Notes).

    Parameters
    ----------
    func : callable
        The function under test (a student's answer).
    package : str
        Top-level name of the forbidden package, ``"labkit"`` unless told.
    also : tuple of str
        Further forbidden packages, watched in the same pass (e.g. ``("sklearn",)``).

    Returns
    -------
    callable
        Takes the arguments of ``func`` and returns what ``func`` returned, or raises what it
        raised, when it made no call into the packages.

    Raises
    ------
    ValueError
        At once, if a package cannot be found.
    AssertionError
        From the wrapper, if ``func`` called into a package (the message names the calls;
        also when ``func`` then raised, since the error may well come from the package) or
        called ``sys.setprofile``.

    See Also
    --------
    forbid_package_calls : the same check for a single call.
    record_package_calls : the recorder, and what counts as a call.

    Notes
    -----
    The wrapper runs ``func`` under the profiler of :func:`record_package_calls`, with the
    packages' locations looked up once. Each Python-level call and each call of a builtin
    inside ``func`` then costs a profiler event (around a microsecond); numpy work inside C
    is unaffected. Do not store the wrapper under the function's own name: another of the
    student's functions that calls it would then run a profiler inside the profiler, which
    the check reports as switching it off.

    Examples
    --------
    >>> import labkit
    >>> double = own_work(lambda r: np.asarray(r) * 2)
    >>> double([1.0])
    array([2.])
    >>> own_work(labkit.polar_to_cartesian)([1.0], [0.0])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    AssertionError: polar_to_cartesian calls labkit's own implementation (labkit.scan.polar_to_cartesian); ...
    """
    return _guarded(func, (package, *also))


def _guarded(func: Callable[..., Any], packages: tuple[str, ...]) -> Callable[..., Any]:
    """The wrapper behind :func:`own_work` and :func:`forbid_package_calls`."""
    watcher = _Watcher(packages)
    name = getattr(func, "__name__", repr(func))

    @functools.wraps(func)
    def checked(*args: Any, **kwargs: Any) -> Any:
        run = watcher.run(func, args, kwargs)
        problem = _own_work_problem(name, packages, run.calls, run.tampered)
        if problem:
            raise AssertionError(problem) from None
        if run.error is not None:
            raise run.error
        return run.result

    return checked


# ---------------------------------------------------------------------------- test inputs
_INVALID_KINDS = ("nan", "inf", "-inf", "zero", "negative", "at_max", "beyond_max", "below_min")


def _draw_sizes(rng, n_beams, max_beams: int, invalid_fraction, most_invalid: float) -> tuple[int, float]:
    """Check the random-scan arguments; draw the beam count and the invalid fraction (up to
    ``most_invalid``) where they are not given."""
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if n_beams is None:
        if max_beams < 2:
            raise ValueError(f"max_beams must be >= 2, got {max_beams!r}")
        n_beams = int(rng.integers(2, max_beams + 1))
    elif int(n_beams) != n_beams or n_beams < 0:
        raise ValueError(f"n_beams must be a non-negative integer, got {n_beams!r}")
    if invalid_fraction is None:
        invalid_fraction = float(rng.uniform(0.0, most_invalid))
    elif not 0.0 <= invalid_fraction <= 1.0:
        raise ValueError(f"invalid_fraction must be in [0, 1], got {invalid_fraction!r}")
    return int(n_beams), invalid_fraction


def random_beams(
    rng: np.random.Generator,
    n_beams: int | None = None,
    *,
    invalid_fraction: float | None = None,
    max_beams: int = 720,
) -> dict[str, Any]:
    """Random beams of one scan, with invalid readings mixed in.

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness: the same generator state gives the same bytes.
    n_beams : int or None
        Number of beams N (0 and 1 allowed). None draws it from ``[2, max_beams]``.
    invalid_fraction : float in [0, 1] or None
        Probability that a beam's reading is replaced by an invalid one. None draws it
        from ``[0, 0.5]``; 1 gives a scan without a single valid beam.
    max_beams : int
        Upper bound for a drawn ``n_beams``.

    Returns
    -------
    dict
        ``ranges`` (ndarray (N,), metres), ``angles`` (ndarray (N,), radians, strictly
        increasing, spanning at most 2 pi, unevenly spaced), ``range_min`` and ``range_max``
        (float, metres; ``range_min`` is 0 in about a third of the draws). Pass it as
        ``**kwargs`` to :class:`labkit.Scan` and to the student's function. An invalid
        reading is one of NaN, +inf, -inf, 0, negative, exactly ``range_max``, beyond
        ``range_max`` or (when ``range_min > 0``) below ``range_min``. Valid readings
        include some exactly at ``range_min``, which is valid.

    Examples
    --------
    >>> beams = random_beams(np.random.default_rng(0), 5)
    >>> beams["ranges"].shape, beams["angles"].shape
    ((5,), (5,))
    >>> bool(np.all(np.diff(beams["angles"]) > 0))
    True
    """
    n, invalid_fraction = _draw_sizes(rng, n_beams, max_beams, invalid_fraction, 0.5)

    range_min = 0.0 if rng.random() < 1 / 3 else float(rng.uniform(0.02, 0.5))
    range_max = float(rng.uniform(4.0, 60.0))

    span = float(rng.uniform(0.1, 2 * np.pi))
    angle_min = float(rng.uniform(-np.pi, np.pi - span))
    steps = rng.uniform(0.5, 1.5, size=max(n - 1, 0))
    offsets = np.concatenate([[0.0], np.cumsum(steps)])[:n]
    if n > 1:
        offsets *= span / offsets[-1]
    angles = angle_min + offsets

    ranges = rng.uniform(range_min, range_max, size=n)
    ranges[rng.random(n) < 0.05] = range_min  # the boundary: valid
    if range_min == 0.0:
        ranges[ranges == 0.0] = range_max / 2  # ... except that 0 is never a return
    invalid = np.flatnonzero(rng.random(n) < invalid_fraction)
    kinds = rng.integers(0, len(_INVALID_KINDS), size=invalid.size)
    for i, kind in zip(invalid, kinds, strict=True):
        name = _INVALID_KINDS[kind]
        if name == "below_min" and range_min == 0.0:
            name = "negative"
        ranges[i] = {
            "nan": np.nan,
            "inf": np.inf,
            "-inf": -np.inf,
            "zero": 0.0,
            "negative": -float(rng.uniform(1e-3, 5.0)),
            "at_max": range_max,
            "beyond_max": float(rng.uniform(range_max, 2 * range_max)) + 1e-9,
            "below_min": float(rng.uniform(0.0, range_min)) if range_min > 0 else 0.0,
        }[name]
    return {"ranges": ranges, "angles": angles, "range_min": range_min, "range_max": range_max}


_WALL_INVALID_KINDS = ("nan", "inf", "-inf", "zero", "negative")


def random_wall_beams(
    rng: np.random.Generator,
    n_beams: int | None = None,
    *,
    invalid_fraction: float | None = None,
    max_beams: int = 720,
) -> dict[str, np.ndarray]:
    """Random beams of a partial sweep across a scene of walls, with clutter and invalid readings.

    The sweep is cut into a few angular sectors; each sector sees one straight wall at a
    random distance (0.3 to 8 m) and orientation, so neighbouring beams form runs of
    points a few centimetres apart and the range jumps between walls. Beams that would
    meet their wall at more than 80 degrees from its normal see nothing (``+inf``). Range
    noise (standard deviation up to 2 cm, the same for the whole scan), isolated clutter
    returns (up to 10 % of the beams) and invalid readings are added on top.

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness: the same generator state gives the same bytes.
    n_beams : int or None
        Number of beams N (0 and 1 allowed). None draws it from ``[2, max_beams]``.
    invalid_fraction : float in [0, 1] or None
        Probability that a beam's reading is replaced by NaN, +inf, -inf, 0 or a negative
        number. None draws it from ``[0, 0.2]``.
    max_beams : int
        Upper bound for a drawn ``n_beams``.

    Returns
    -------
    dict
        ``ranges`` (ndarray (N,), metres) and ``angles`` (ndarray (N,), radians, strictly
        increasing, unevenly spaced). The sweep never covers the full circle
        (:attr:`labkit.Scan.is_full_circle` is False), so its first and last beams are not
        neighbours. Pass it as ``**kwargs`` to :class:`labkit.Scan` (default range limits:
        a reading is valid when it is finite and > 0) and to the student's function.

    Examples
    --------
    >>> beams = random_wall_beams(np.random.default_rng(0), 50)
    >>> sorted(beams), beams["ranges"].shape
    (['angles', 'ranges'], (50,))
    >>> bool(np.all(np.diff(beams["angles"]) > 0))
    True
    """
    n, invalid_fraction = _draw_sizes(rng, n_beams, max_beams, invalid_fraction, 0.2)

    # Scan.is_full_circle: span + 1.5 * step >= 2 pi, with step = span / (n - 1)
    widest = 1.5 * np.pi if n < 3 else min(1.5 * np.pi, 0.9 * 2 * np.pi * (n - 1) / (n + 0.5))
    span = float(rng.uniform(min(0.05, widest), widest))
    angle_min = float(rng.uniform(-np.pi, np.pi - span))
    steps = rng.uniform(0.5, 1.5, size=max(n - 1, 0))
    offsets = np.concatenate([[0.0], np.cumsum(steps)])[:n]
    if n > 1:
        offsets *= span / offsets[-1]
    angles = angle_min + offsets

    n_walls = int(rng.integers(1, 9)) + int(np.ceil(span / (np.pi / 2)))
    cuts = np.sort(rng.uniform(angle_min, angle_min + span, size=n_walls - 1))
    bounds = np.concatenate([[angle_min], cuts, [angle_min + span]])
    wall = np.searchsorted(cuts, angles, side="right")
    middle = (bounds[:-1] + bounds[1:]) / 2
    normal = middle + rng.uniform(-0.6, 0.6, size=n_walls)
    distance = rng.uniform(0.3, 8.0, size=n_walls)
    cosine = np.cos(angles - normal[wall])
    ranges = np.full(n, np.inf)
    seen = cosine > np.cos(np.radians(80.0))
    ranges[seen] = distance[wall[seen]] / cosine[seen]
    ranges[seen] += rng.normal(0.0, float(rng.uniform(0.0, 0.02)), size=int(seen.sum()))
    clutter = np.flatnonzero(rng.random(n) < float(rng.uniform(0.0, 0.1)))
    ranges[clutter] = rng.uniform(0.2, 10.0, size=clutter.size)

    invalid = np.flatnonzero(rng.random(n) < invalid_fraction)
    kinds = rng.integers(0, len(_WALL_INVALID_KINDS), size=invalid.size)
    for i, kind in zip(invalid, kinds, strict=True):
        name = _WALL_INVALID_KINDS[kind]
        if name == "negative":
            ranges[i] = -float(rng.uniform(1e-3, 5.0))
        else:
            ranges[i] = {"nan": np.nan, "inf": np.inf, "-inf": -np.inf, "zero": 0.0}[name]
    return {"ranges": ranges, "angles": angles}


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
        With a message that says which part (type, shape, dtype, indices, values) is wrong.

    Examples
    --------
    >>> assert_beams_result((np.array([[1.0, 0.0]]), np.array([0])), [[1.0, 0.0]], [0])
    >>> assert_beams_result((np.zeros((1, 2)), np.array([0])), [[1.0, 0.0]], [0])
    Traceback (most recent call last):
    ...
    AssertionError: points are wrong: row 0 (beam 0) should be [1.0, 0.0], got [0.0, 0.0]
    """
    expected_points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    expected_indices = np.asarray(indices, dtype=np.int64).reshape(-1)
    if not isinstance(result, tuple) or len(result) != 2:
        raise AssertionError(f"expected a tuple (points, indices), got {type(result).__name__}")
    got_points, got_indices = result
    for name, value in [("points", got_points), ("indices", got_indices)]:
        if not isinstance(value, np.ndarray):
            raise AssertionError(f"{name} must be a numpy array, got {type(value).__name__}")
    if got_points.shape != expected_points.shape:
        raise AssertionError(f"points must have shape {expected_points.shape}, got {got_points.shape}")
    if got_points.dtype != np.float64:
        raise AssertionError(f"points must have dtype float64, got {got_points.dtype}")
    if got_indices.shape != expected_indices.shape:
        raise AssertionError(f"indices must have shape {expected_indices.shape}, got {got_indices.shape}")
    if not np.issubdtype(got_indices.dtype, np.integer):
        raise AssertionError(f"indices must be integers, got dtype {got_indices.dtype}")
    if not np.array_equal(got_indices, expected_indices):
        wrong = int(np.flatnonzero(got_indices != expected_indices)[0])
        raise AssertionError(
            f"indices are wrong: position {wrong} should be beam {expected_indices[wrong]},"
            f" got {got_indices[wrong]}"
        )
    close = np.isclose(got_points, expected_points, rtol=1e-9, atol=atol)
    if not np.all(close):
        row = int(np.flatnonzero(~np.all(close, axis=1))[0])
        raise AssertionError(
            f"points are wrong: row {row} (beam {expected_indices[row]}) should be"
            f" {expected_points[row].tolist()}, got {got_points[row].tolist()}"
        )



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
        With a message that says which part (type, shape, dtype, first wrong item) is wrong.

    Examples
    --------
    >>> assert_labels_result(np.array([0, 0, -1]), [0, 0, -1])
    >>> assert_labels_result(np.array([0, 1, -1]), [0, 0, -1])
    Traceback (most recent call last):
    ...
    AssertionError: labels are wrong: beam 1 should be 0, got 1 (expected [0, 0, -1], got [0, 1, -1])
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
        i = int(wrong[0])
        lo, hi = max(i - 3, 0), min(i + 4, want.size)
        where = "" if (lo, hi) == (0, want.size) else f" around {item}s {lo}..{hi - 1}"
        raise AssertionError(
            f"{name} are wrong: {item} {i} should be {want[i]}, got {result[i]} (expected{where}"
            f" {want[lo:hi].tolist()}, got {result[lo:hi].tolist()})"
        )


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
        With a message that says which part (type, sign of r, range of alpha, value) is wrong.

    Examples
    --------
    >>> assert_line_result((2.0, 0.0), 2.0, 1e-12)
    >>> assert_line_result((-2.0, math.pi), 2.0, 0.0)
    Traceback (most recent call last):
    ...
    AssertionError: r must be >= 0 (turn the normal around: r -> -r, alpha -> alpha + pi), got -2.0
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
        raise AssertionError(
            f"r must be >= 0 (turn the normal around: r -> -r, alpha -> alpha + pi), got {got_r}"
        )
    if not -math.pi < got_alpha <= math.pi:
        raise AssertionError(f"alpha must be in (-pi, pi], got {got_alpha} (wrap it)")
    if abs(got_r - r) > atol:
        raise AssertionError(f"r is wrong: should be {r:.9f} m, got {got_r:.9f} m")
    gap = abs(math.remainder(got_alpha - alpha, 2 * math.pi))
    if gap > atol:
        raise AssertionError(
            f"alpha is wrong: should be {alpha:.9f} rad ({math.degrees(alpha):.4f} deg),"
            f" got {got_alpha:.9f} rad ({math.degrees(got_alpha):.4f} deg)"
        )
