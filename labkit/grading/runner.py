"""Grade one submission: the trusted tests against the student's functions in their worker.

:func:`grade_submission` is what a grading job runs (in the grader's process or in one of its
trusted child processes): it reads the submission (as data), starts the student's worker, runs the
notebook's code cells there once (with their own time budget), and then runs every graded cell's
tests *here*, on the trusted side, one function at a time: the cell's visible checks from the
*source* notebook (:func:`labkit.grading.run_checks`) and the spec's hidden tests, each with a
generator seeded from the course secret, the student, the cell, the test and the submission's code
(:func:`seed_for`): a regrade of the same code draws the same inputs, any change to it fresh ones. The
student's functions are :class:`StudentFunction` proxies: plain arguments out, plain results (or a
rebuilt built-in exception) back. Each function earns its share of a cell when its checks there pass.

What a student reads about a failure names the property that failed; a hidden test's inputs and
expected values never appear in it, and the student's own exception messages are cut short, without
their numbers (they could carry the hidden inputs out) and without control characters.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import inspect
import io
import json
import resource
import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .checks import GRADER
from .exercises import Course, Exercise, GradedCell, release_exercise
from .notebook import (
    InvalidNotebook,
    autograded_notebook,
    error,
    grade_id,
    read_notebook,
    same_code,
    stream,
    student_cells,
)
from .sandbox import CallTimedOut, Sandbox, SandboxBroken, Session, WorkerLost
from .text import one_line, printable, without_numbers

__all__ = [
    "STATUSES",
    "PartResult",
    "CellResult",
    "SubmissionResult",
    "Job",
    "StudentFunction",
    "grade_submission",
    "run_cells",
    "seed_for",
    "code_hash",
]

GRADED, NOT_SUBMITTED, TIMED_OUT, CRASHED = "graded", "not submitted", "timed out", "crashed"
INVALID, MANUAL, GRADER_ERROR = "invalid notebook", "needs manual grade", "grader error"
#: Every status a submission can get, in the order the summary shows them.
STATUSES = (GRADED, NOT_SUBMITTED, TIMED_OUT, CRASHED, INVALID, MANUAL, GRADER_ERROR)
MAX_SHOWN_CHARS = 2000
#: How much of the student's own exception message a failure in the hidden tests shows (without its numbers).
MAX_STUDENT_MESSAGE_CHARS = 160
#: How much of a hidden test's own message is shown.
MAX_HIDDEN_MESSAGE_CHARS = 400


@dataclass
class PartResult:
    """The verdict on one function's part of a graded cell.

    Parameters
    ----------
    function : str
        The student's function.
    max_points : float
        The points the part is worth.
    points : float
        The points given.
    verdict : str
        One line for the console.
    """

    function: str
    max_points: float
    points: float
    verdict: str


@dataclass
class CellResult:
    """The verdict on one graded cell.

    Parameters
    ----------
    grade_id : str
        The cell's nbgrader grade id.
    max_points : float
        The points it is worth.
    points : float or None
        The points given; None for a cell a human grades.
    verdict : str
        One line for the console.
    outputs : list of dict
        The nbformat outputs shown under the cell in the autograded notebook.
    seconds : float
        The time its tests took.
    parts : list of PartResult
        The verdict per function.
    """

    grade_id: str
    max_points: float
    points: float | None
    verdict: str
    outputs: list[dict] = field(default_factory=list)
    seconds: float = 0.0
    parts: list[PartResult] = field(default_factory=list)


@dataclass
class SubmissionResult:
    """Everything the grader's parent needs to record one submission (plain data, picklable).

    Parameters
    ----------
    exercise : str
        The exercise's name.
    student : str
        The student id.
    status : str
        The submission's status: graded, not submitted, invalid notebook, ... (the statuses of
        :mod:`labkit.grading.command`).
    cells : list of CellResult
        The verdict on every graded cell.
    detail : str
        One line on what went wrong (cells not passed, notes on the notebook's run).
    cell_errors : list of dict
        The student's cells that raised, timed out or crashed the worker when the notebook ran.
    timing : dict of str to float
        Seconds of each phase (``total_s``, ``start_s``, ``load_s``, ``calls_s``, ``trusted_s``,
        ``cpu_s``) and the number of ``workers`` started.
    notebook : dict or None
        The autograded notebook (nbformat), feedback for the student.
    unanswered : list of str
        The grade ids of solution cells the student left as released.
    seeds : dict of str to int
        The seed of every hidden test's inputs, by ``cell/part``.
    """

    exercise: str
    student: str
    status: str
    cells: list[CellResult]
    detail: str = ""
    cell_errors: list[dict] = field(default_factory=list)
    timing: dict[str, float] = field(default_factory=dict)
    notebook: dict | None = None
    unanswered: list[str] = field(default_factory=list)
    seeds: dict[str, int] = field(default_factory=dict)

    @property
    def score(self) -> float:
        return round(sum(cell.points or 0.0 for cell in self.cells), 6)

    @property
    def max_score(self) -> float:
        return sum(cell.max_points for cell in self.cells)


@dataclass(frozen=True)
class Job:
    """One submission to grade (plain data, so that it can go to a child process).

    Parameters
    ----------
    course : str or None
        The course folder; None: the exercise is the one the notebook itself describes
        (``--check`` without the course: see :func:`labkit.grading.exercises.release_exercise`).
    exercise : str
        The exercise's name.
    student : str
        The student id.
    notebook : str or None
        The submitted notebook; None: nothing was submitted.
    secret : bytes or None
        The course secret the hidden inputs' seeds are drawn from (:func:`seed_for`); None: none.
    isolate : bool
        Run the student's code in the sandbox (False: ``--no-sandbox``).
    visible_only : bool
        Run the visible checks only (``--check``).
    """

    course: str | None
    exercise: str
    student: str
    notebook: str | None
    secret: bytes | None
    isolate: bool = True
    visible_only: bool = False


class StudentFunction:
    """The student's function ``name`` as the trusted tests see it: a call into the worker.

    Arguments go out as plain data (see :mod:`labkit.grading.protocol`); the result comes back as
    fresh built-in values, or the exception the student's code raised as a fresh built-in
    exception (noting that the student's function raised it).

    Parameters
    ----------
    session : Session
        The submission's session.
    name : str
        The function's name in the student's notebook.
    """

    def __init__(self, session: Session, name: str) -> None:
        self._session = session
        self.__name__ = name

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        try:
            return self._session.call(self.__name__, args, kwargs)
        except SandboxBroken:
            raise  # the grader's problem, not something the student's function raised
        except Exception as raised:
            raised.add_note(f"(raised by your {self.__name__}(...))")
            # its message is the student's text (a mark any exception takes: its class declares no such attribute)
            setattr(raised, "labkit_student_raised", True)  # noqa: B010
            raise

    def __repr__(self) -> str:
        return f"<the student's {self.__name__}>"


def code_hash(code: list[str]) -> str:
    """A digest of the code cells a submission runs: any change to them draws fresh hidden inputs.

    Parameters
    ----------
    code : list of str
        The code cells, in order.

    Returns
    -------
    str
        The digest, hexadecimal.
    """
    return hashlib.sha256(json.dumps(code, ensure_ascii=False).encode("utf-8", "replace")).hexdigest()


def seed_for(secret: bytes, exercise: str, student: str, cell: str, part: str = "", code: str = "") -> int:
    """The seed of one test's inputs.

    It is unknown without the course secret, other for every student, cell, test and submitted
    code, and the same on a regrade of the same code.

    Parameters
    ----------
    secret : bytes
        The course secret.
    exercise : str
        The exercise's name.
    student : str
        The student id.
    cell : str
        The graded cell's grade id.
    part : str
        The test's name.
    code : str
        The digest of the submitted code (:func:`code_hash`).

    Returns
    -------
    int
        The seed.
    """
    message = "\x00".join((exercise, student, cell, part, code)).encode("utf-8")
    return int.from_bytes(hmac.new(secret, message, hashlib.sha256).digest()[:8], "big")


def _student_raised(raised: BaseException) -> bool:
    return getattr(raised, "labkit_student_raised", False)


def _failure(cell: GradedCell, function: str, raised: BaseException, part: str) -> tuple[dict, str]:
    """The error output and the one-line verdict of ``function``'s ``part`` ("visible"/"hidden") that failed."""
    if isinstance(raised, WorkerLost):
        name = "TimeoutError" if isinstance(raised, CallTimedOut) else "WorkerCrashed"
        message = str(raised.args[0]) if raised.args else name
    else:
        name = type(raised).__name__
        message = "".join(traceback.format_exception_only(raised)).strip().removeprefix(f"{name}: ")
        message = "" if message == name else message
    if not message and not _student_raised(raised):  # a check that says nothing: say at least what failed
        message = (f"a check of {function} failed without saying why (the test's own assertion has no message)"
                   if isinstance(raised, AssertionError) else f"a check of {function} raised it without a message")
    if part == "hidden" and _student_raised(raised):  # the student's text, about inputs they have not seen
        first, _, rest = message.partition("\n")
        note = rest.strip().splitlines()[-1] if rest.strip() else ""
        message = printable(without_numbers(first), MAX_STUDENT_MESSAGE_CHARS) + (f" {note}" if note else "")
    elif part == "hidden":
        message = printable(message, MAX_HIDDEN_MESSAGE_CHARS)
    else:
        message = printable(message, MAX_SHOWN_CHARS)
    lines = [f"{name}: {message}" if message else name]
    if part == "visible":
        frames = [f for f in traceback.extract_tb(raised.__traceback__) if f.filename == f"<{cell.grade_id}>"]
        where = frames[-1].lineno if frames else None
        if where is not None:
            code = cell.code.splitlines()
            text = code[where - 1].strip() if where <= len(code) else ""
            lines.insert(0, f"{function}, in the visible checks, line {where}: {text}")
        else:
            lines.insert(0, f"{function}, in the visible checks:")
    else:
        lines.insert(0, f"{function}, in the hidden tests (inputs you have not seen):")
    return error(name, message, lines), f"{function} failed ({part}): {lines[-1]}"


def _points_text(points: float) -> str:
    return f"{points:g} point{'s' if points != 1 else ''}"


def run_cells(exercise: Exercise, session: Session, *, seeds: Callable[[str, str], int] | None,
              functions: tuple[str, ...] | None = None) -> list[CellResult]:
    """Run every graded cell's tests against the session's worker, in notebook order, a function at a time.

    Parameters
    ----------
    exercise : Exercise
        The exercise, with its tests.
    session : Session
        The submission's session, its notebook loaded.
    seeds : callable or None
        ``seeds(cell, part)`` gives the seed of a test's inputs (``part``: the hidden test's name,
        or ``"visible/<function>"``); None runs the visible checks only, each with fresh inputs
        from the OS.
    functions : tuple of str or None
        Run the tests of these functions only (the others' parts score 0, "not run"); None: all.

    Returns
    -------
    list of CellResult
        The verdict on every graded cell, in notebook order.
    """
    wanted = exercise.functions if functions is None else tuple(functions)
    namespace: dict[str, Any] = {"__name__": f"grader_{exercise.name}"}
    for code in exercise.setup:
        exec(compile(code, "<setup>", "exec"), namespace)
    proxies = {name: StudentFunction(session, name) for name in exercise.functions}
    results = []
    for cell in exercise.cells:
        if not cell.auto:
            results.append(CellResult(cell.grade_id, cell.points, None, "graded by hand"))
            continue
        started = time.perf_counter()
        out = io.StringIO()
        failures: dict[str, tuple[dict, str]] = {}
        checked: set[str] = set()

        def generator(part: str, cell: GradedCell = cell) -> np.random.Generator:
            return np.random.default_rng(None if seeds is None else seeds(cell.grade_id, part))

        def grade_check(function: str, check: Callable, cell: GradedCell = cell,
                        failures: dict = failures, checked: set = checked) -> None:
            checked.add(function)
            if function not in wanted:
                return
            session.begin_test(exercise.test_timeout_s)
            try:
                check(generator(f"visible/{function}"))
            except SandboxBroken:
                raise
            except (Exception, WorkerLost) as raised:  # noqa: BLE001 -- a failing check is a verdict
                failures.setdefault(function, _failure(cell, function, raised, "visible"))

        with contextlib.redirect_stdout(out), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the instructor's comparisons warn on the student's NaNs
            if cell.visible:
                namespace.update(proxies)
                token = GRADER.set(grade_check)
                try:
                    exec(compile(cell.code, f"<{cell.grade_id}>", "exec"), namespace)
                except SandboxBroken:
                    raise  # no worker could start: no verdict on the student (the run calls it a grader error)
                except (Exception, WorkerLost) as raised:  # noqa: BLE001 -- the cell's own code failed: every function
                    for function in exercise.functions:
                        failures.setdefault(function, _failure(cell, function, raised, "visible"))
                finally:
                    GRADER.reset(token)
                for function in exercise.functions:  # a check the cell never reached (it raised before) fails
                    if function not in checked and function not in failures:
                        failures[function] = _failure(cell, function, AssertionError("its check did not run"),
                                                      "visible")
            for function in exercise.functions:
                if function not in wanted:
                    failures[function] = ({}, f"{function} not run")
            if seeds is not None:
                for function in exercise.functions:
                    if function in failures:
                        continue
                    for test in cell.tests_of(function):
                        session.begin_test(exercise.test_timeout_s)
                        rng = generator(test.name)
                        arguments = {test.function: proxies[test.function], "rng": rng}
                        try:
                            test.test(**{p: arguments[p] for p in inspect.signature(test.test).parameters})
                        except SandboxBroken:
                            raise
                        except (Exception, WorkerLost) as raised:  # noqa: BLE001 -- a failing test is a verdict
                            failures[function] = _failure(cell, function, raised, "hidden")
                            break
        parts = [PartResult(f, cell.shares[f], 0.0 if f in failures else cell.shares[f],
                            failures[f][1] if f in failures else "passed") for f in exercise.functions]
        earned = sum(part.points for part in parts)
        points = cell.points if not failures else round(earned, 6)
        lines = [f"{part.function}: {'passed' if part.points else 'failed'} ({_points_text(part.points)} of "
                 f"{part.max_points:g})" for part in parts] if len(parts) > 1 else []
        printed = printable(out.getvalue(), MAX_SHOWN_CHARS)
        outputs = [stream(printed + ("\n" if printed and not printed.endswith("\n") else "") + "\n".join(lines))] \
            if printed or lines else []
        outputs += [failures[f][0] for f in exercise.functions if f in failures and failures[f][0]]
        if not failures:
            verdict = "passed"
        else:
            lost = "; ".join(failures[f][1] for f in exercise.functions if f in failures)
            verdict = lost if len(parts) == 1 else f"{points:g} of {cell.points:g} points: {lost}"
        results.append(CellResult(cell.grade_id, cell.points, points, verdict, outputs,
                                  time.perf_counter() - started, parts))
    return results


def _status(session: Session, cells: list[CellResult]) -> str:
    if session.crashed:
        return CRASHED
    if session.timed_out:
        return TIMED_OUT
    if any(cell.points is None for cell in cells):
        return MANUAL
    return GRADED


def _blank(exercise: Exercise, verdict: str, output: dict | None = None) -> list[CellResult]:
    return [CellResult(c.grade_id, c.points, 0.0 if c.auto else None, verdict, [output] if output else [])
            for c in exercise.cells]


def _first_line(source: str) -> str:
    lines = [line.strip() for line in source.splitlines() if line.strip() and not line.strip().startswith("#")]
    return (lines[0] if lines else "")[:80]


def _cpu_seconds() -> float:
    """CPU seconds of this process and of its children that it waited for (bwrap itself; the workers'
    own time comes from :meth:`~labkit.grading.sandbox.Worker.cpu_seconds`)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


_COURSES: dict[str, Course] = {}
_SLOT = [0]


def set_slot(slot: Any) -> None:
    """This process's job number, which picks its workers' uid; a pool initializer passes a queue to take it from."""
    _SLOT[0] = slot if isinstance(slot, int) else slot.get()


def forget_courses() -> None:
    """Read the courses' exercises again on the next submission (a run in this process after a spec changed)."""
    _COURSES.clear()


def _exercise(job: Job, submission: dict | None = None) -> Exercise:
    if job.course is None:  # --check without the course: the exercise the notebook itself describes
        assert submission is not None, "grade_submission refuses an unreadable notebook without the course"
        return release_exercise(submission)
    if job.course not in _COURSES:
        _COURSES[job.course] = Course(job.course)
    return _COURSES[job.course].exercise(job.exercise)


def _notes(errors: list[dict]) -> str:
    """What happened while the notebook ran, for the detail column: the cells that were stopped or not run."""
    noted = [f"cell {e['cell'] + 1} ({e['starts'][:40]}): {e['message']}" for e in errors
             if e["error"] in ("TimeoutError", "WorkerCrashed")]
    return "; ".join(noted[:3]) + (f"; and {len(noted) - 3} more" if len(noted) > 3 else "")


def _hidden_tests_of(job: Job) -> tuple[str, bytes] | None:
    """The course and its secret for a job that runs the hidden tests too; None for ``--check`` (visible only)."""
    if job.visible_only:
        return None
    if job.course is None or job.secret is None:
        raise ValueError("a job that runs the hidden tests needs the course and its secret")
    return job.course, job.secret


def _sources(cells: list[dict]) -> dict[str, Any]:
    """Grade id -> source of the cells that have a grade id."""
    found: dict[str, Any] = {}
    for cell in cells:
        gid = grade_id(cell)
        if gid is not None:
            found[gid] = cell["source"]
    return found


def grade_submission(job: Job) -> SubmissionResult:
    """Grade one submission; every problem of the submission is part of the result, never an exception.

    (Without a course, ``--check`` on a notebook that is not a release of the course is a ValueError.)

    Parameters
    ----------
    job : Job
        The submission.

    Returns
    -------
    SubmissionResult
        The verdicts, the status and the autograded notebook.
    """
    hidden = _hidden_tests_of(job)
    result = SubmissionResult(job.exercise, job.student, GRADED, [])
    submission, problem = None, None
    if job.notebook is not None:
        try:
            submission = read_notebook(Path(job.notebook), inside=None if hidden is None else Path(hidden[0]))
        except InvalidNotebook as invalid:
            problem = invalid
    if job.course is None and submission is None:
        raise ValueError(f"your notebook cannot be read: {problem}")
    exercise = _exercise(job, submission)
    result.exercise = exercise.name
    if job.notebook is None:
        result.status, result.cells = NOT_SUBMITTED, _blank(exercise, "not submitted")
        return result
    if problem is not None:
        shown = error("InvalidNotebook", f"your notebook could not be graded: {problem}")
        result.status, result.detail = INVALID, one_line(problem)
        result.cells = _blank(exercise, f"invalid notebook: {problem}", shown)
        result.notebook = autograded_notebook(None, exercise.release, exercise.test_cells,
                                              {c.grade_id: c.outputs for c in result.cells})
        return result
    assert submission is not None, "read (job.notebook is not None), or returned above as invalid"
    sandbox = Sandbox(exercise.masked, limits=exercise.limits, slot=_SLOT[0], isolate=job.isolate)
    code = student_cells(submission, exercise.test_cells)
    seeds, used = None, {}
    if hidden is not None:
        digest, secret = code_hash(code), hidden[1]

        def seeds(cell: str, part: str) -> int:
            used[f"{cell}/{part}"] = seed_for(secret, exercise.name, job.student, cell, part, digest)
            return used[f"{cell}/{part}"]

    started, cpu = time.perf_counter(), _cpu_seconds()
    with Session(sandbox, code, load_timeout_s=exercise.load_timeout_s, call_timeout_s=exercise.call_timeout_s,
                 submission_timeout_s=exercise.submission_timeout_s) as session:
        session.load()  # before any test, with its own budget
        result.cells = run_cells(exercise, session, seeds=seeds)
    result.seeds = used
    result.status = _status(session, result.cells)
    result.cell_errors = [{**error, "message": printable(error["message"], 500),
                           "starts": printable(_first_line(code[error["cell"]]) if error["cell"] < len(code) else "")}
                          for error in session.cell_errors or []]
    lost = [f"{c.grade_id} {c.verdict}" for c in result.cells if c.verdict != "passed"]
    notes = _notes(result.cell_errors)
    if notes:  # the student reads it under the first graded cell of the feedback, the instructor in grades.csv
        first = next((c for c in result.cells if c.points is not None), None)
        if first is not None:
            first.outputs.insert(0, stream(f"While your notebook ran: {notes}\n"))
    result.detail = one_line("; ".join([*lost, *([f"notebook: {notes}"] if notes else [])]), 2000)
    total = time.perf_counter() - started
    result.timing = {
        "total_s": total, "start_s": session.timing.start_s, "load_s": session.timing.load_s,
        "calls_s": session.timing.calls_s, "workers": session.timing.workers,
        "trusted_s": total - session.timing.start_s - session.timing.load_s - session.timing.calls_s,
        "cpu_s": _cpu_seconds() - cpu + session.timing.worker_cpu_s,
    }
    released, answers = _sources(exercise.release["cells"]), _sources(submission["cells"])
    result.unanswered = [gid for gid, text in released.items()
                         if gid in answers and exercise_solution(exercise, gid) and same_code(answers[gid], text)]
    result.notebook = autograded_notebook(submission, exercise.release, exercise.test_cells,
                                          {c.grade_id: c.outputs for c in result.cells})
    return result


def exercise_solution(exercise: Exercise, gid: str) -> bool:
    """True when ``gid`` is a solution cell of the exercise."""
    return any(grade_id(c) == gid and c["metadata"].get("nbgrader", {}).get("solution")
               for c in exercise.release["cells"])
