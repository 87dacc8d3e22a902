"""Grade one submission: the trusted tests against the student's functions in their worker.

:func:`grade_submission` is what a grading job runs (in the grader's process or in one of its
trusted child processes): it reads the submission (as data), starts the student's worker with
the submission's code cells, and runs every graded cell's tests *here*, on the trusted side:
first the cell's visible code from the *source* notebook, then the spec's hidden tests with a
generator seeded from the course secret, the student and the cell. The student's functions are
:class:`StudentFunction` proxies: plain arguments out, plain results (or a rebuilt built-in
exception) back. A cell scores its points when both parts pass, 0 otherwise.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import io
import resource
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .course import Course, Exercise, GradedCell
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

__all__ = [
    "STATUSES",
    "CellResult",
    "SubmissionResult",
    "Job",
    "StudentFunction",
    "grade_submission",
    "run_cells",
    "seed_for",
]

GRADED, NOT_SUBMITTED, TIMED_OUT, CRASHED = "graded", "not submitted", "timed out", "crashed"
INVALID, MANUAL, GRADER_ERROR = "invalid notebook", "needs manual grade", "grader error"
#: Every status a submission can get, in the order the summary shows them.
STATUSES = (GRADED, NOT_SUBMITTED, TIMED_OUT, CRASHED, INVALID, MANUAL, GRADER_ERROR)
MAX_SHOWN_CHARS = 2000


@dataclass
class CellResult:
    """The verdict on one graded cell.

    ``points`` is None for a cell a human grades; ``outputs`` are the nbformat outputs shown
    under the cell in the autograded notebook; ``verdict`` is one line for the console.
    """

    grade_id: str
    max_points: float
    points: float | None
    verdict: str
    outputs: list[dict] = field(default_factory=list)
    seconds: float = 0.0


@dataclass
class SubmissionResult:
    """Everything the grader's parent needs to record one submission (plain data, picklable)."""

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
        return sum(cell.points or 0.0 for cell in self.cells)

    @property
    def max_score(self) -> float:
        return sum(cell.max_points for cell in self.cells)


@dataclass(frozen=True)
class Job:
    """One submission to grade (plain data, so that it can go to a child process)."""

    course: str
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
            raise

    def __repr__(self) -> str:
        return f"<the student's {self.__name__}>"


def seed_for(secret: bytes, exercise: str, student: str, cell: str) -> int:
    """The seed of one cell's hidden inputs: unknown without the course secret, the same on a regrade."""
    message = "\x00".join((exercise, student, cell)).encode("utf-8")
    return int.from_bytes(hmac.new(secret, message, hashlib.sha256).digest()[:8], "big")


def _shown(text: str) -> str:
    return text if len(text) <= MAX_SHOWN_CHARS else text[:MAX_SHOWN_CHARS] + " [...]"


def _failure(cell: GradedCell, raised: BaseException, part: str) -> tuple[dict, str]:
    """The error output and the one-line verdict of a cell whose ``part`` ("visible"/"hidden") failed."""
    if isinstance(raised, WorkerLost):
        name = "TimeoutError" if isinstance(raised, CallTimedOut) else "WorkerCrashed"
        message = str(raised.args[0]) if raised.args else name
    else:
        name = type(raised).__name__
        message = "".join(traceback.format_exception_only(raised)).strip().removeprefix(f"{name}: ")
        message = "" if message == name else message
    message = _shown(message)
    lines = [f"{name}: {message}" if message else name]
    if part == "visible":
        frames = [f for f in traceback.extract_tb(raised.__traceback__) if f.filename == f"<{cell.grade_id}>"]
        if frames:
            code = cell.code.splitlines()
            where = frames[-1].lineno
            text = code[where - 1].strip() if where <= len(code) else ""
            lines.insert(0, f"in the visible tests, line {where}: {text}")
    else:
        lines.insert(0, "in the hidden tests (inputs you have not seen):")
    return error(name, message, lines), f"failed ({part}): {lines[-1]}"


def run_cells(
    exercise: Exercise, session: Session, *, seeds: dict[str, int] | None
) -> list[CellResult]:
    """Run every graded cell's tests against the session's worker, in notebook order.

    ``seeds`` (grade id -> seed) runs the hidden tests too; None runs the visible tests only.
    """
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
        namespace.update(proxies)
        session.begin_test(exercise.test_timeout_s)
        failure = None
        part = "visible"
        try:
            with contextlib.redirect_stdout(out), warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the instructor's comparisons warn on the student's NaNs
                exec(compile(cell.code, f"<{cell.grade_id}>", "exec"), namespace)
                if seeds is not None and cell.hidden is not None:
                    part = "hidden"
                    rng = np.random.default_rng(seeds[cell.grade_id])
                    cell.hidden(**{name: proxies.get(name, rng) for name in cell.parameters})
        except SandboxBroken:
            raise  # no worker could start: no verdict on the student (the run calls it a grader error)
        except (Exception, WorkerLost) as raised:  # noqa: BLE001 -- a failing test is a verdict
            failure = _failure(cell, raised, part)
        outputs = [stream(_shown(out.getvalue()))] if out.getvalue() else []
        if failure is None:
            points, verdict = cell.points, "passed"
        else:
            outputs.append(failure[0])
            points, verdict = 0.0, failure[1]
        results.append(CellResult(cell.grade_id, cell.points, points, verdict, outputs,
                                  time.perf_counter() - started))
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


def _exercise(job: Job) -> Exercise:
    if job.course not in _COURSES:
        _COURSES[job.course] = Course(job.course)
    return _COURSES[job.course].exercise(job.exercise)


def grade_submission(job: Job) -> SubmissionResult:
    """Grade one submission; every problem of the submission is part of the result, never an exception."""
    exercise = _exercise(job)
    result = SubmissionResult(job.exercise, job.student, GRADED, [])
    if job.notebook is None:
        result.status, result.cells = NOT_SUBMITTED, _blank(exercise, "not submitted")
        return result
    try:
        submission = read_notebook(Path(job.notebook), inside=None if job.visible_only else Path(job.course))
    except InvalidNotebook as problem:
        shown = error("InvalidNotebook", f"your notebook could not be graded: {problem}")
        result.status, result.detail = INVALID, str(problem)
        result.cells = _blank(exercise, f"invalid notebook: {problem}", shown)
        result.notebook = autograded_notebook(None, exercise.release, exercise.test_cells,
                                              {c.grade_id: c.outputs for c in result.cells})
        return result
    sandbox = Sandbox(exercise.masked, limits=exercise.limits, slot=_SLOT[0], isolate=job.isolate)
    code = student_cells(submission, exercise.test_cells)
    seeds = None
    if not job.visible_only:
        seeds = {c.grade_id: seed_for(job.secret, exercise.name, job.student, c.grade_id) for c in exercise.cells}
    started, cpu = time.perf_counter(), _cpu_seconds()
    with Session(sandbox, code, load_timeout_s=exercise.load_timeout_s,
                 call_timeout_s=exercise.call_timeout_s) as session:
        result.cells = run_cells(exercise, session, seeds=seeds)
    result.seeds = seeds or {}
    result.status = _status(session, result.cells)
    result.cell_errors = [{**error, "starts": _first_line(code[error["cell"]]) if error["cell"] < len(code) else ""}
                          for error in session.cell_errors or []]
    result.detail = "; ".join(f"{c.grade_id} {c.verdict}" for c in result.cells if c.verdict != "passed")
    total = time.perf_counter() - started
    result.timing = {
        "total_s": total, "start_s": session.timing.start_s, "load_s": session.timing.load_s,
        "calls_s": session.timing.calls_s, "workers": session.timing.workers,
        "trusted_s": total - session.timing.start_s - session.timing.load_s - session.timing.calls_s,
        "cpu_s": _cpu_seconds() - cpu + session.timing.worker_cpu_s,
    }
    released = {grade_id(c): c["source"] for c in exercise.release["cells"] if grade_id(c) is not None}
    answers = {grade_id(c): c["source"] for c in submission["cells"] if grade_id(c) is not None}
    result.unanswered = [gid for gid, text in released.items()
                         if gid in answers and exercise_solution(exercise, gid) and same_code(answers[gid], text)]
    result.notebook = autograded_notebook(submission, exercise.release, exercise.test_cells,
                                          {c.grade_id: c.outputs for c in result.cells})
    return result


def exercise_solution(exercise: Exercise, gid: str) -> bool:
    """True when ``gid`` is a solution cell of the exercise."""
    return any(grade_id(c) == gid and c["metadata"].get("nbgrader", {}).get("solution")
               for c in exercise.release["cells"])
