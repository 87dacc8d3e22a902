"""``labkit grade``: grade a class, or check one notebook the way it will be graded.

``labkit grade <exercise|all> [--jobs N]`` collects every submission under ``exercises/submitted/``,
grades each in its own sandboxed worker (:mod:`labkit.grading.runner`), with ``N`` trusted grading
processes (:class:`concurrent.futures.ProcessPoolExecutor`) while this process alone writes the
gradebook, the autograded notebooks, the records and ``grades.csv``
(:mod:`labkit.grading.records`). It shows a progress bar and ends with a summary per exercise;
the exit status is 0 when every submission got a verdict (whatever it was).

``labkit grade --check my.ipynb`` runs one notebook's visible tests with the same trusted grader
and sandbox and prints a verdict per graded cell and function; outside a course (a student with
only the release) the checks are the notebook's own locked cells, as released.

:func:`add_grade_parser` and :func:`run_grade` are what ``labkit``'s command line calls;
``python -m labkit.grading`` runs the same command on its own.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import contextlib
import fcntl
import json
import multiprocessing
import os
import secrets
import signal
import sys
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from .exercises import Course, Exercise, find_course, release_exercise
from .notebook import grade_id, read_notebook
from .records import Records, student_id_problem
from .runner import (
    GRADER_ERROR,
    INVALID,
    NOT_SUBMITTED,
    STATUSES,
    Job,
    SubmissionResult,
    forget_courses,
    grade_submission,
    set_slot,
)
from .sandbox import Sandbox, SandboxBroken, Worker, check_bwrap, kill_all_workers
from .text import one_line, printable

__all__ = ["grade", "check", "check_summary", "add_grade_parser", "run_grade", "main", "GradingRun",
           "GradingInterrupted"]


@dataclass
class GradingRun:
    """What one ``labkit grade`` run did.

    Parameters
    ----------
    results : list of SubmissionResult
        One per submission graded.
    seconds : float
        The run's wall time.
    jobs : int
        The grading processes that worked in parallel.
    csv : Path or None
        The grades CSV written.
    """

    results: list[SubmissionResult] = field(default_factory=list)
    seconds: float = 0.0
    jobs: int = 1
    csv: Path | None = None

    @property
    def ok(self) -> bool:
        """True when every submission got a verdict (no grader error)."""
        return all(result.status != GRADER_ERROR for result in self.results)

    def summary(self) -> str:
        """A table per exercise: submissions per status, mean score; then the throughput."""
        by_exercise: dict[str, list[SubmissionResult]] = {}
        for result in self.results:
            by_exercise.setdefault(result.exercise, []).append(result)
        shown = [s for s in STATUSES if any(r.status == s for r in self.results)] or [STATUSES[0]]
        header = ["exercise", *shown, "mean score"]
        rows = []
        for name, results in sorted(by_exercise.items()):
            counts = Counter(r.status for r in results)
            handed_in = [r for r in results if r.status != NOT_SUBMITTED]
            mean = sum(r.score for r in handed_in) / len(handed_in) if handed_in else 0.0
            top = results[0].max_score
            rows.append([name, *(str(counts[s]) for s in shown), f"{mean:.1f} / {top:g}"])
        widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header))]
        lines = ["  ".join(cell.ljust(w) if i == 0 else cell.rjust(w) for i, (cell, w) in
                           enumerate(zip(row, widths, strict=True))) for row in [header, *rows]]
        graded = sum(1 for r in self.results if r.status != NOT_SUBMITTED)
        rate = graded / self.seconds * 60 if self.seconds > 0 else 0.0
        plural = "s" if self.jobs != 1 else ""
        where = f"; grades in {self.csv}" if self.csv else ""
        lines.append(f"{graded} submissions graded in {self.seconds:.1f} s ({rate:.0f} per minute, "
                     f"{self.jobs} job{plural}){where}")
        return "\n".join(lines)


class GradingInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`grade`: ``graded`` of the ``total`` submissions to grade were graded and saved.

    Parameters
    ----------
    graded : int
        The submissions graded and saved.
    total : int
        The submissions there were to grade.
    """

    def __init__(self, graded: int, total: int) -> None:
        super().__init__(f"{graded} of {total} submissions were graded and saved")
        self.graded, self.total = graded, total


# ---------------------------------------------------------------------------- the class
def _secret(course: Course) -> bytes:
    """The course secret the hidden inputs' seeds come from: created once, kept beside the gradebook."""
    path = course.secret_file
    if not path.exists():
        with contextlib.suppress(FileExistsError):
            handle = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(handle, "w") as f:
                f.write(secrets.token_hex(32) + "\n")
    return bytes.fromhex(path.read_text(encoding="utf-8").strip())


@contextlib.contextmanager
def _locked(course: Course):
    """One ``labkit grade`` per course at a time (they would share one gradebook)."""
    with open(course.root / ".grading.lock", "a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise ValueError(f"another `labkit grade` is grading {course.root}; wait for it to finish") from None
        yield


def _roster(course: Course, records: Records) -> list[str]:
    """Every student: those in the gradebook and those with a folder under submitted/."""
    students = {student.id for student in records.gradebook.students}
    if course.submitted.is_dir():
        students |= {p.name for p in course.submitted.iterdir() if p.is_dir() and not p.name.startswith(".")}
    return sorted(students)


def _handed_in(course: Course, student: str, exercise: str) -> tuple[Path | None, bool]:
    """(the notebook to grade or None, whether the student has a folder for the exercise).

    The notebook is ``<exercise>.ipynb``, or the only notebook in the folder when it was renamed.
    """
    folder = course.submitted / student / exercise
    if not folder.is_dir():
        return None, False
    expected = folder / f"{exercise}.ipynb"
    if expected.is_file():
        return expected, True
    others = [p for p in folder.glob("*.ipynb") if p.is_file()]
    return (others[0] if len(others) == 1 else None), True


def _probe(isolate: bool, slot: int) -> None:
    """Start one worker, so that a broken sandbox stops the run before any student is graded."""
    try:
        Worker(Sandbox(isolate=isolate, slot=slot)).kill()
    except SandboxBroken as broken:
        raise PermissionError(f"labkit grade cannot start its sandbox: {broken}") from None


def _grade_jobs(jobs: list[Job], workers: int, first_slot: int):
    """Yield a result per job as it completes (in this process, or in ``workers`` trusted children)."""
    if workers <= 1:
        set_slot(first_slot)
        forget_courses()  # the exercises as the run checked them, not as an earlier run in this process read them
        for job in jobs:
            yield _guarded(job)
        return
    context = multiprocessing.get_context("spawn")
    slots = context.Queue()
    for slot in range(first_slot, first_slot + workers):
        slots.put(slot)
    with concurrent.futures.ProcessPoolExecutor(workers, mp_context=context, initializer=_grading_process,
                                                initargs=(slots, os.getpid())) as pool:
        futures = {}
        try:  # (the submits too: a Ctrl-C there must not wait, in the pool's exit, for the jobs already queued)
            with _ctrl_c_deferred():  # the first submits start the grading processes
                for job in jobs:
                    futures[pool.submit(_guarded, job)] = job
            for future in concurrent.futures.as_completed(futures):
                try:
                    yield future.result()
                except Exception as problem:  # noqa: BLE001 -- a dead grading process: that job's verdict
                    yield _grader_error(futures[future], problem)
        except BaseException:  # Ctrl-C (or a failure here): stop the grading processes now, not after their queue
            for child in multiprocessing.active_children():
                child.terminate()
            pool.shutdown(cancel_futures=True)
            raise


@contextlib.contextmanager
def _ctrl_c_deferred() -> Iterator[None]:
    """A Ctrl-C within waits for the end: then it raises KeyboardInterrupt (the pool is started inside).

    The first submits start the grading processes. A Ctrl-C in the middle of starting one would stop
    this process between its fork and its handing the child what to run (the child then dies with an
    EOFError traceback on the user's terminal), or reach the child before its initializer
    (:func:`_grading_process`) has set its handler (a KeyboardInterrupt traceback in the middle of its
    imports). So this thread blocks SIGINT, which a child inherits across exec and holds pending until
    its initializer unblocks it, and this process only notes a Ctrl-C that another of its threads
    receives, to raise it at the end."""
    import threading  # noqa: PLC0415 - only here

    caught: list[int] = []
    main = threading.current_thread() is threading.main_thread()  # (only the main thread may set handlers)
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum)) if main else None
    old = signal.pthread_sigmask(signal.SIG_BLOCK, [signal.SIGINT])
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)  # what is pending for this thread arrives: noted
        if main:
            signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def _skip_iri_grammars() -> None:
    """Keep jsonschema from compiling its IRI grammars in this process: ~3 s of CPU saved per process.

    nbgrader imports nbformat, which imports jsonschema, which imports ``rfc3987_syntax`` when it is installed
    (jupyter-events asks for it) to check the "iri" string format; that import builds 38 lark parsers, 3 s of
    CPU in every process of a grading run and 60 % of its start. Neither nbformat's schema nor labkit checks
    that format, and jsonschema goes without it when the import fails, which an entry of None in
    ``sys.modules`` makes it do. A process that has imported the package already keeps it.
    """
    sys.modules.setdefault("rfc3987_syntax", None)  # type: ignore[arg-type]


def _grading_process(slots, run_pid: int) -> None:
    """Set up a trusted grading process of a parallel run: its job number, and signals. Ctrl-C is the run's
    to handle (the terminal sends it to the whole group), so this process ignores SIGINT; the run sends
    SIGTERM instead, on which it kills its workers (sandbox, cgroup, folder) and exits at once, the
    submission it was grading left without a verdict. It gets that SIGTERM from the kernel too when the
    run dies without sending it (SIGKILL, an out-of-memory kill), instead of waiting for jobs forever."""
    _skip_iri_grammars()
    set_slot(slots)
    signal.signal(signal.SIGINT, _ignore)  # not SIG_IGN: the workers would inherit that, and cells need SIGINT
    signal.signal(signal.SIGTERM, _stop_grading_process)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGINT])  # started blocked (see _ctrl_c_deferred)
    _end_with_parent(signal.SIGTERM)
    if os.getppid() != run_pid:  # the run ended before the line above could take effect
        _stop_grading_process(signal.SIGTERM, None)


def _end_with_parent(signum: int) -> None:
    """Ask Linux to send ``signum`` to this process when its parent ends (prctl PR_SET_PDEATHSIG)."""
    import ctypes  # noqa: PLC0415 - only here

    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(1, signum, 0, 0, 0)  # 1 = PR_SET_PDEATHSIG


def _ignore(signum, frame) -> None:  # noqa: ARG001 -- a signal handler's signature
    pass


def _stop_grading_process(signum, frame) -> None:  # noqa: ARG001 -- a signal handler's signature
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # the pool sends it again when it sees this process gone
    kill_all_workers()
    os._exit(128 + signum)


def _grader_error(job: Job, problem: BaseException) -> SubmissionResult:
    return SubmissionResult(job.exercise, job.student, GRADER_ERROR, [],
                            detail=f"the grader failed: {type(problem).__name__}: {problem}"[:2000])


def _guarded(job: Job) -> SubmissionResult:
    try:
        return grade_submission(job)
    except Exception as problem:  # noqa: BLE001 -- one submission's grader failure must not stop the class
        return _grader_error(job, problem)


def _fill(result: SubmissionResult, exercise: Exercise) -> SubmissionResult:
    if not result.cells:
        from .runner import CellResult

        result.cells = [CellResult(c.grade_id, c.points, 0.0, result.status) for c in exercise.cells]
    return result


def grade(
    wanted: str,
    *,
    course: Course | Path | str | None = None,
    jobs: int = 1,
    students: list[str] | None = None,
    output: Path | str | None = None,
    isolate: bool = True,
    progress: bool = False,
    first_slot: int = 0,
) -> GradingRun:
    """Grade every submission of ``wanted`` (an exercise, a prefix such as ``ex01``, or ``all``).

    Parameters
    ----------
    wanted : str
        An exercise, a prefix such as ``ex01``, or ``all``.
    course : Course or path, optional
        The course folder (default: ``./exercises``).
    jobs : int
        Trusted grading processes working in parallel (each with its own sandboxed worker).
    students : list of str, optional
        Grade only these students.
    output : path, optional
        The grades CSV (default: ``<course>/grades.csv``).
    isolate : bool
        False runs student code without the sandbox (``--no-sandbox``): see :class:`~labkit.grading.sandbox.Sandbox`.
    progress : bool
        Show a progress bar on stderr.
    first_slot : int
        The first job's slot: job ``k`` runs student code as ``labkit.grading.sandbox.worker_uid``
        ``(first_slot + k)`` (so that concurrent runs, e.g. tests, use different uids).

    Returns
    -------
    GradingRun
        The results of every submission, the time taken and the CSV written.

    Raises
    ------
    ValueError, FileNotFoundError, PermissionError
        No such exercise or course folder, no bwrap, a sandbox that cannot start, a stale release.
    GradingInterrupted
        Ctrl-C (a :class:`KeyboardInterrupt`) once grading started: says how many submissions were
        graded and saved; ``grades.csv`` holds them.
    """
    if jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {jobs}")
    course = course if isinstance(course, Course) else find_course(course)
    names = course.resolve(wanted)
    if isolate:
        check_bwrap()
    exercises = {name: course.exercise(name) for name in names}
    started = time.perf_counter()
    csv_path = Path(output) if output else course.root / "grades.csv"
    run = GradingRun(jobs=jobs, csv=csv_path)
    with _locked(course), Records(course) as records:
        _probe(isolate, first_slot)
        secret = _secret(course)
        for exercise in exercises.values():
            records.ensure_assignment(exercise)
        roster = _roster(course, records)
        if students:
            unknown = sorted(set(students) - set(roster))
            if unknown:
                raise ValueError(f"no student {', '.join(unknown)} in {course.submitted} or the gradebook")
            roster = [s for s in roster if s in students]
        todo, folders, unrecorded = [], {}, []
        for name in names:
            for student in roster:
                problem = student_id_problem(student)
                if problem is not None:  # no file may be named after it: a row in grades.csv only
                    unrecorded.append(_fill(SubmissionResult(name, student, INVALID, [], detail=(
                        f"student id {one_line(student, 200)!r} cannot be graded: {problem}; rename the folder")),
                        exercises[name]))
                    continue
                notebook, folders[name, student] = _handed_in(course, student, name)
                todo.append(Job(str(course.root), name, student, str(notebook) if notebook else None, secret, isolate))
        run.results += unrecorded
        bar = _progress(len(todo), progress)
        try:
            for result in _grade_jobs(todo, min(jobs, max(len(todo), 1)), first_slot):
                run.results.append(records.save(_fill(result, exercises[result.exercise]),
                                                has_folder=folders[result.exercise, result.student]))
                bar.update(1)
                bar.set_postfix_str(f"{one_line(result.student, 40)}: {result.status}", refresh=False)
        except KeyboardInterrupt as interrupted:  # what the report says: how many were saved of how many
            raise GradingInterrupted(len(run.results) - len(unrecorded), len(todo)) from interrupted
        finally:  # also when interrupted: the CSV of what is graded so far
            bar.close()
            records.write_csv(csv_path, unrecorded)
    run.seconds = time.perf_counter() - started
    return run


def _progress(total: int, show: bool):
    from tqdm.auto import tqdm

    return tqdm(total=total, desc="grading", unit="nb", file=sys.stderr, disable=not show, leave=False)


# ---------------------------------------------------------------------------- one notebook
def _exercise_of(course: Course, notebook: Path, wanted: str | None) -> str:
    if wanted:
        return course.resolve(wanted)[0]
    names = course.names()
    stem = notebook.stem
    matches = [n for n in names if stem == n or stem.startswith(n) or n.startswith(stem)]
    if len(matches) == 1:
        return matches[0]
    cells = read_notebook(notebook)["cells"]
    ids = {grade_id(cell) for cell in cells}
    code = "\n".join(cell["source"] for cell in cells)
    matches = [n for n in names if course.exercise(n).test_cells.keys() <= ids
               and all(f"def {f}(" in code for f in course.exercise(n).functions)]
    if len(matches) != 1:
        raise ValueError(f"cannot tell which exercise {notebook.name} is: pass --exercise (one of {', '.join(names)})")
    return matches[0]


def check(notebook: Path | str, *, course: Course | Path | str | None = None, exercise: str | None = None,
          isolate: bool = True) -> tuple[Exercise, SubmissionResult]:
    """Run one notebook's visible checks the way the grader runs them (sandbox, trusted checks).

    With a course (``course``, or ``./exercises``) the checks are the course's; without one -- a student with
    only the release -- they are the notebook's own locked cells (as released: a changed one is refused), with
    the functions, points and masked packages its metadata names. The verdicts are the same either way.

    Parameters
    ----------
    notebook : Path or str
        The student's notebook.
    course : Course or Path or str or None
        The course; None: ``./exercises`` when there is one, else none.
    exercise : str or None
        The exercise (a name or a prefix such as ``ex01``); None: the one the notebook's name or
        cells point to.
    isolate : bool
        Run the student's code in the sandbox (False: ``--no-sandbox``).

    Returns
    -------
    exercise : Exercise
        The exercise checked.
    result : SubmissionResult
        The verdicts of its visible checks.
    """
    notebook = Path(notebook)
    if not notebook.is_file():
        raise FileNotFoundError(f"no notebook {notebook}")
    if course is None:
        with contextlib.suppress(FileNotFoundError):
            course = find_course()
    elif not isinstance(course, Course):
        course = find_course(course)
    if isolate:
        check_bwrap()
    if course is None:
        job = Job(None, exercise or "", "you", str(notebook.resolve()), None, isolate, visible_only=True)
    else:
        job = Job(str(course.root), _exercise_of(course, notebook, exercise), "you", str(notebook.resolve()), None,
                  isolate, visible_only=True)
    try:
        result = grade_submission(job)
    except SandboxBroken as broken:
        raise PermissionError(f"labkit grade cannot start its sandbox: {broken}") from None
    if course is None:
        return release_exercise(read_notebook(notebook)), result
    return course.exercise(job.exercise), result


def _check_report(exercise: Exercise, result: SubmissionResult) -> tuple[str, bool]:
    lines = [f"{exercise.name}: the visible tests, run the way your notebook will be graded"]
    if result.detail and result.status == "invalid notebook":
        return "\n".join([*lines, f"  invalid notebook: {result.detail}"]), False
    for error in result.cell_errors:
        lines.append(f"  note: the cell that starts `{error['starts']}`: {error['error']}: {error['message'][:300]}")
    width = max(len(c.grade_id) for c in exercise.cells)
    passed = True
    for cell, verdict in zip(exercise.cells, result.cells, strict=True):
        if cell.auto and not cell.visible:
            lines.append(f"  {cell.grade_id.ljust(width)}  {cell.points:g} points  hidden tests only: graded on inputs "
                         "you have not seen when you hand in")
            continue
        passed &= verdict.points is not None and verdict.points == cell.points
        lines.append(f"  {cell.grade_id.ljust(width)}  {cell.points:g} points  "
                     + ("passed" if verdict.verdict == "passed" else f"{verdict.points or 0:g} earned"))
        for part in verdict.parts:
            text = "passed" if part.verdict == "passed" else part.verdict.removeprefix(f"{part.function} ")
            lines.append(f"    {part.function}: {part.points:g} of {part.max_points:g}: {text[:600]}")
    lines.append("all visible tests passed; the hidden tests run when your notebook is graded" if passed
                 else "some visible tests failed: fix them before you hand in")
    return "\n".join(lines), passed


def check_summary(exercise: Exercise, result: SubmissionResult) -> dict:
    """Summarise what :func:`check` found as plain data.

    This is what ``labkit grade --check NOTEBOOK --json`` prints and what JupyterLab's Validate in
    ``labkit lab`` shows: the verdict, the notes on cells that raised, and every visible graded cell's
    points and the verdict of each of its functions. Text the student's code produced is made printable,
    never HTML.

    Parameters
    ----------
    exercise : Exercise
        The exercise the notebook answers.
    result : SubmissionResult
        The result of checking the notebook.

    Returns
    -------
    dict
        JSON-ready data: the verdict, the notes and the visible cells."""
    report, passed = _check_report(exercise, result)
    summary: dict = {"exercise": exercise.name, "passed": passed, "report": report, "invalid": "", "notes": [],
                     "cells": []}
    if result.detail and result.status == "invalid notebook":
        summary["invalid"] = printable(result.detail)
        return summary
    summary["notes"] = [
        printable(f"the cell that starts `{error['starts']}`: {error['error']}: {error['message']}", 600)
        for error in result.cell_errors]
    for cell, verdict in zip(exercise.cells, result.cells, strict=True):
        hidden_only = cell.auto and not cell.visible
        summary["cells"].append({
            "grade_id": cell.grade_id, "points": cell.points, "earned": verdict.points, "hidden_only": hidden_only,
            "passed": hidden_only or (verdict.points is not None and verdict.points == cell.points),
            "parts": [{"function": part.function, "points": part.points, "max_points": part.max_points,
                       "verdict": printable(part.verdict, 2000)} for part in verdict.parts],
            # where a visible check failed: "segment, in the visible checks, line 24: labels = segment(...)"
            "where": [printable(line, 600) for output in verdict.outputs if output.get("output_type") == "error"
                      for line in output.get("traceback", [])[:-1]]})
    return summary


# ---------------------------------------------------------------------------- command line
def _default_jobs() -> int:
    return max(len(os.sched_getaffinity(0)), 1)


def add_grade_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``grade`` to a command line's sub-commands (the parent parser provides ``-q/--quiet``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The parent parser's sub-commands.

    Returns
    -------
    argparse.ArgumentParser
        The ``grade`` parser.
    """
    parser = subparsers.add_parser(
        "grade", help="grade the submissions in exercises/submitted/, or --check one notebook",
        description="Grade every submission of an exercise: student code runs in a bubblewrap sandbox, the tests "
        "in a trusted process; scores go to nbgrader's gradebook and to grades.csv with a status per submission.",
    )
    parser.add_argument("exercise", nargs="?", help="an exercise (ex01 or ex01_range_segmentation), or all")
    parser.add_argument("-j", "--jobs", type=int, default=_default_jobs(),
                        help="grading processes in parallel (default: the number of CPUs)")
    parser.add_argument("--course", help="the course folder (default: ./exercises)")
    parser.add_argument("--student", action="append", metavar="ID", help="grade only this student (repeatable)")
    parser.add_argument("-o", "--output", help="the grades CSV (default: <course>/grades.csv)")
    parser.add_argument("--check", metavar="NOTEBOOK",
                        help="run one notebook's visible tests the way it will be graded (the release alone is "
                        "enough), and print a verdict per test and function")
    parser.add_argument("--exercise", dest="check_exercise", metavar="NAME",
                        help="with --check: the exercise, when the notebook's name does not say")
    parser.add_argument("--json", action="store_true",
                        help="with --check: print the verdicts as JSON (what Validate in `labkit lab` shows)")
    parser.add_argument("--no-sandbox", action="store_true",
                        help="run student code without bubblewrap (NOT isolated: it can read your files and "
                        "reach the network); only where you accept that risk")
    parser.set_defaults(func=run_grade)
    return parser


def run_grade(args: argparse.Namespace) -> int:
    """Run ``labkit grade``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of :func:`add_grade_parser`'s parser.

    Returns
    -------
    int
        The exit status.
    """
    _skip_iri_grammars()
    quiet = getattr(args, "quiet", False)
    if args.check:
        exercise, result = check(args.check, course=args.course, exercise=args.check_exercise,
                                 isolate=not args.no_sandbox)
        if getattr(args, "json", False):
            summary = check_summary(exercise, result)
            print(json.dumps(summary))
            return 0 if summary["passed"] else 1
        report, passed = _check_report(exercise, result)
        print(report)
        return 0 if passed else 1
    if not args.exercise:
        raise ValueError("say what to grade: an exercise (e.g. ex01) or all; or --check NOTEBOOK")
    try:
        run = grade(args.exercise, course=args.course, jobs=args.jobs, students=args.student, output=args.output,
                    isolate=not args.no_sandbox, progress=not quiet)
    except KeyboardInterrupt as interrupted:
        if isinstance(interrupted, GradingInterrupted):
            print(f"labkit grade: interrupted: {interrupted.graded} of {interrupted.total} submissions were graded "
                  "and saved (gradebook, grades.csv); the others are as they were. Run the same command "
                  "again to grade them.", file=sys.stderr)
        else:
            print("labkit grade: interrupted before grading started: nothing was changed", file=sys.stderr)
        return 130
    print(run.summary())
    for result in run.results:
        if result.status == GRADER_ERROR:
            print(f"{result.exercise} {one_line(result.student, 200)}: {one_line(result.detail)}", file=sys.stderr)
    return 0 if run.ok else 1


def main(argv: list[str] | None = None) -> int:
    """``python -m labkit.grading``: the ``grade`` command on its own.

    Parameters
    ----------
    argv : list of str or None
        The arguments; None: ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status.
    """
    parser = argparse.ArgumentParser(prog="python -m labkit.grading")
    commands = parser.add_subparsers(dest="command")
    add_grade_parser(commands).add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(["grade", *(argv if argv is not None else sys.argv[1:])])
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError, PermissionError) as error:
        print(f"labkit grade: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
