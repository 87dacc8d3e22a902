"""What grading leaves behind, written by the grader's single parent process only.

- nbgrader's gradebook (``gradebook.db``, through :class:`nbgrader.api.Gradebook`): the assignment
  with its notebook and cells (as ``nbgrader generate_assignment`` records them, taken from the
  release), then per submission the student, the submission and an auto score per graded cell,
  so that ``nbgrader export``, ``generate_feedback`` and the formgrader keep working. A regrade
  replaces the auto scores; a score a human entered stays and marks the cell for review;
- ``autograded/<student>/<exercise>/<exercise>.ipynb``: the graded notebook feedback is made from;
- ``records/<exercise>/<student>.json``: the grader's own record (status, per-cell verdicts, the
  seeds of the hidden inputs, timings); never copied into feedback;
- ``grades.csv``: one row per student and exercise with the status.

Every file is written under a temporary name and renamed when complete; nothing under
``submitted/`` is ever written, moved or deleted.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import re
import shutil
import sqlite3
import tempfile
import time
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path

from .exercises import Course, Exercise
from .notebook import grade_id, nbgrader_metadata, write_notebook_text
from .protocol import clean_text
from .runner import GRADED, GRADER_ERROR, MANUAL, NOT_SUBMITTED, SubmissionResult
from .text import one_line, printable

__all__ = ["Records", "write_atomic", "student_id_problem", "CSV_COLUMNS"]

CSV_COLUMNS = ("assignment", "student_id", "status", "score", "max_score", "detail")
_FORMULA = ("=", "+", "-", "@", "\t", "\r")
MAX_CSV_CHARS = 2000


def student_id_problem(student: str) -> str | None:
    """Why ``student`` cannot name the files the grader writes for them (a folder name, a record), or None.

    Student ids come from folder names under ``submitted/`` and from the gradebook's roster (an
    LMS import): one such as ``../source`` would write outside the student's folders.

    Parameters
    ----------
    student : str
        The student id.

    Returns
    -------
    str or None
        The reason, for a message; None when the id is safe.
    """
    if student in ("", ".", "..") or student.startswith(".") or any(c in student for c in "/\\\0"):
        return "it is not a plain folder name"
    if student != student.strip():
        return "it starts or ends with white space"
    if clean_text(student) != student:
        return "it is not valid UTF-8"
    if printable(student) != student:
        return "it holds control characters (a terminal escape?)"
    return None


def _csv_text(text: str) -> str:
    """A CSV field a terminal and a spreadsheet show as text: on one line, without escape sequences or control
    characters (``cat grades.csv`` must not be rewritten by a student's message), at most 2000 characters, and
    a leading ``'`` where it would start a formula."""
    text = one_line(text, MAX_CSV_CHARS)
    return "'" + text if text.startswith(_FORMULA) else text


@contextlib.contextmanager
def _beside(path: Path) -> Iterator[str]:
    """A temporary file name in ``path``'s folder; renamed to ``path`` when the block completes."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    try:
        yield temporary
        os.chmod(temporary, 0o644)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename.

    Parameters
    ----------
    path : Path
        The file.
    text : str
        Its new content (UTF-8).
    """
    with _beside(path) as temporary, open(temporary, "w", encoding="utf-8", errors="replace", newline="") as f:
        f.write(text)


@contextlib.contextmanager
def _quiet_sqlalchemy() -> Iterator[None]:
    """nbgrader's ``add_submission`` makes SQLAlchemy warn that objects are not in the session yet
    (``nbgrader autograde`` warns the same); the rows are written all the same."""
    from sqlalchemy.exc import SAWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SAWarning)
        yield


def alembic_head() -> str:
    """The schema revision of nbgrader's gradebook, read from its migration scripts in this process.

    ``nbgrader`` finds it by running the ``alembic`` program (which must then be on ``PATH``, and
    takes seconds); this is the same answer without a subprocess.
    """
    from alembic.config import Config
    from alembic.script import ScriptDirectory
    from nbgrader.dbutil import ALEMBIC_DIR

    config = Config()
    config.set_main_option("script_location", ALEMBIC_DIR)
    (head,) = ScriptDirectory.from_config(config).get_heads()
    return head


def _new_gradebook(path: Path) -> None:
    """Create an empty gradebook stamped with nbgrader's schema revision (nbgrader adds the tables)."""
    if path.exists():
        return
    head = alembic_head()
    with _beside(path) as temporary, contextlib.closing(sqlite3.connect(temporary)) as db:
        db.execute("CREATE TABLE alembic_version (version_num VARCHAR(32) NOT NULL)")
        db.execute("INSERT INTO alembic_version (version_num) VALUES (?)", (head,))
        db.commit()


def course_id(course: Course) -> str:
    """The ``course_id`` set in ``nbgrader_config.py`` (nbgrader's default when it sets none)."""
    config = course.root / "nbgrader_config.py"
    text = config.read_text(encoding="utf-8") if config.is_file() else ""
    found = re.search(r"""^c\.CourseDirectory\.course_id\s*=\s*["']([^"']+)["']""", text, re.M)
    return found.group(1) if found else "default_course"


def _timestamp(folder: Path):
    from nbgrader.utils import parse_utc

    path = folder / "timestamp.txt"
    try:
        return parse_utc(path.read_text(encoding="utf-8")[:100].strip()) if path.is_file() else None
    except (OSError, ValueError, TypeError, OverflowError):
        return None


class Records:
    """The gradebook and the files of one course; open it with ``with Records(course) as records:``.

    Parameters
    ----------
    course : Course
        The course.
    """

    def __init__(self, course: Course) -> None:
        self.course = course

    def __enter__(self) -> Records:
        from nbgrader.api import Gradebook

        _new_gradebook(self.course.gradebook)
        with contextlib.redirect_stdout(io.StringIO()):
            self.gradebook = Gradebook(f"sqlite:///{self.course.gradebook}", course_id(self.course))
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.gradebook.close()

    # ------------------------------------------------------------------ the assignment
    def ensure_assignment(self, exercise: Exercise) -> None:
        """The assignment, notebook and cells of ``exercise`` in the gradebook, as its release has them.

        Raises
        ------
        ValueError
            When the gradebook already holds submissions of a different set of graded cells.
        """
        from nbformat import from_dict
        from nbgrader.api import MissingEntry
        from nbgrader.utils import is_locked

        gb, name = self.gradebook, exercise.name
        cells = [c for c in exercise.release["cells"] if grade_id(c) is not None]
        wanted = {grade_id(c): float(nbgrader_metadata(c).get("points", 0)) for c in cells
                  if nbgrader_metadata(c).get("grade")}
        try:
            notebook = gb.find_notebook(name, name)
        except MissingEntry:
            notebook = None
        if notebook is not None:
            have = {cell.name: cell.max_score for cell in notebook.grade_cells}
            if have != wanted and notebook.submissions:
                raise ValueError(
                    f"the graded cells of {name} changed since it was graded ({have} in the gradebook, {wanted} now):"
                    f" grade the old version, or remove its submissions from {self.course.gradebook} first")
            if have != wanted:
                gb.remove_notebook(name, name)
                notebook = None
        gb.update_or_create_assignment(name)
        if notebook is None:
            kernelspec = json.dumps(exercise.release["metadata"].get("kernelspec", {}))
            gb.add_notebook(name, name, kernelspec=kernelspec)
        for cell in cells:
            meta, gid = nbgrader_metadata(cell), grade_id(cell)
            if meta.get("grade"):
                gb.update_or_create_grade_cell(gid, name, name, max_score=float(meta.get("points", 0)),
                                               cell_type=cell["cell_type"])
            if meta.get("solution"):
                gb.update_or_create_solution_cell(gid, name, name)
            gb.update_or_create_source_cell(gid, name, name, cell_type=cell["cell_type"],
                                            locked=is_locked(from_dict(cell)), source=cell["source"],
                                            checksum=meta.get("checksum"))

    # ------------------------------------------------------------------ one submission
    def save(self, result: SubmissionResult, *, has_folder: bool) -> SubmissionResult:
        """Record one result: gradebook scores, autograded notebook, record file. Returns the result,
        its status turned into "needs manual grade" where a human score waits for review. A grader
        error is recorded, but the gradebook and the autograded notebook keep what they had."""
        name, student = result.exercise, result.student
        folder = self.course.submitted / student / name
        if result.status == GRADER_ERROR:  # no verdict: the gradebook keeps what it had
            self._record(result)
            return result
        if result.status != NOT_SUBMITTED or has_folder:
            with _quiet_sqlalchemy():
                waiting = self._scores(result, folder)
            if waiting and result.status == GRADED:
                result.status = MANUAL
        if result.notebook is not None:
            target = self.course.autograded / student / name
            write_atomic(target / f"{name}.ipynb", write_notebook_text(result.notebook))
            stamp = folder / "timestamp.txt"
            if stamp.is_file() and not stamp.is_symlink() and stamp.stat().st_size < 1000:
                shutil.copyfile(stamp, target / "timestamp.txt")
        self._record(result)
        return result

    def _scores(self, result: SubmissionResult, folder: Path) -> bool:
        """The auto score of every graded cell; True when one of them waits for a human."""
        gb = self.gradebook
        gb.update_or_create_student(result.student)
        timestamp = _timestamp(folder)
        stamp = {"timestamp": timestamp} if timestamp else {}
        submission = gb.update_or_create_submission(result.exercise, result.student, **stamp)
        scores = {cell.grade_id: cell.points for cell in result.cells}
        waiting = False
        for notebook in submission.notebooks:
            for grade in notebook.grades:
                grade.auto_score = scores.get(grade.name, 0.0)
                grade.needs_manual_grade = grade.manual_score is not None or grade.auto_score is None
                waiting |= grade.needs_manual_grade
            for comment in notebook.comments:
                comment.auto_comment = "No response." if comment.name in result.unanswered else None
        gb.db.commit()
        return waiting

    def _record(self, result: SubmissionResult) -> None:
        record = {
            "exercise": result.exercise, "student": result.student, "status": result.status,
            "score": result.score, "max_score": result.max_score, "detail": result.detail,
            "graded_at": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "cells": [{"grade_id": c.grade_id, "points": c.points, "max_points": c.max_points, "verdict": c.verdict,
                       "seconds": round(c.seconds, 4),
                       "functions": {p.function: {"points": p.points, "max_points": p.max_points, "verdict": p.verdict}
                                     for p in c.parts}} for c in result.cells],
            "cell_errors": result.cell_errors, "timing": result.timing, "seeds": result.seeds,
        }
        path = self.course.records / result.exercise / f"{result.student}.json"
        write_atomic(path, json.dumps(record, indent=1) + "\n")

    # ------------------------------------------------------------------ grades.csv
    def scores(self) -> dict[tuple[str, str], tuple[float, float]]:
        """(exercise, student) -> (score, max score) of every submission in the gradebook."""
        found = {}
        for assignment in self.gradebook.assignments:
            for submission in assignment.submissions:
                found[assignment.name, submission.student.id] = (submission.score, submission.max_score)
        return found

    def write_csv(self, path: Path, unrecorded: Sequence[SubmissionResult] = ()) -> int:
        """``grades.csv`` from every record, and ``unrecorded`` results (students whose id names no file):
        one row per student and exercise. Returns the number of rows."""
        scores = self.scores()
        rows = [{"assignment": r.exercise, "student_id": r.student, "status": r.status, "score": "0",
                 "max_score": f"{r.max_score:g}", "detail": r.detail} for r in unrecorded]
        for record_path in sorted(self.course.records.glob("*/*.json")):
            record = json.loads(record_path.read_text(encoding="utf-8"))
            key = (record["exercise"], record["student"])
            score, max_score = scores.get(key, (record["score"], record["max_score"]))
            rows.append({"assignment": key[0], "student_id": key[1], "status": record["status"],
                         "score": f"{score:g}", "max_score": f"{max_score:g}", "detail": record["detail"]})
        text = io.StringIO()
        writer = csv.DictWriter(text, fieldnames=CSV_COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows({key: _csv_text(value) for key, value in row.items()} for row in rows)
        write_atomic(Path(path), text.getvalue())
        return len(rows)
