"""``labkit grade``: the instructor's run (gradebook, regrades, statuses, grades.csv), ``--check`` for
students, and the command line's errors (one line, exit status 1)."""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import os
import signal
import stat
import subprocess
import sys
import time
from functools import partial
from pathlib import Path

import pytest

from labkit.grading import add_grade_parser, cgroups, check, grade, run_grade
from labkit.grading.command import _check_report
from tests.grading_course import copy_course, notebook_with, release_notebook, solutions, submit

EX0 = "ex00_polar_to_cartesian"
SLOT = 40  # worker uids of its own (see labkit.grading.sandbox.worker_uid)


@pytest.fixture
def course(tmp_path) -> Path:
    course = copy_course(tmp_path / "course")
    submit(course, "alice", EX0, notebook_with(EX0, solutions(EX0)))
    submit(course, "bob", EX0, release_notebook(EX0))
    return course


def rows(path: Path) -> dict[tuple[str, str], dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return {(row["assignment"], row["student_id"]): row for row in csv.DictReader(f)}


def gradebook(course: Path):
    from nbgrader.api import Gradebook

    return Gradebook(f"sqlite:///{course / 'gradebook.db'}", "labkit")


def cli(*args: str, env: dict | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "labkit.grading", *args], capture_output=True, text=True,
                          timeout=600, env=env, cwd=cwd)


# ---------------------------------------------------------------------------- the instructor's run
def test_grade_writes_gradebook_csv_records_and_autograded_notebooks(course):
    run = grade("ex00", course=course, first_slot=SLOT)
    assert run.ok and {(r.student, r.status, r.score) for r in run.results} == {("alice", "graded", 10.0),
                                                                                 ("bob", "graded", 0.0)}
    table = rows(course / "grades.csv")
    assert (table[EX0, "alice"]["status"], table[EX0, "alice"]["score"]) == ("graded", "10")
    assert table[EX0, "bob"]["score"] == "0" and "NotImplementedError" in table[EX0, "bob"]["detail"]
    with gradebook(course) as gb:
        assert gb.find_submission(EX0, "alice").score == 10.0
        comments = {c.name: c.auto_comment for nb in gb.find_submission(EX0, "bob").notebooks for c in nb.comments}
        assert comments == {"beams_to_points": "No response."}  # the stub was left as released
    assert json.loads((course / "autograded" / "alice" / EX0 / f"{EX0}.ipynb").read_text())["nbformat"] == 4
    record = json.loads((course / "records" / EX0 / "alice.json").read_text())
    assert record["status"] == "graded" and len(record["seeds"]) == 4
    assert stat.S_IMODE((course / ".grading_secret").stat().st_mode) == 0o600
    assert not list(course.rglob("*.tmp")), "a temporary file was left behind"
    assert "2 submissions graded" in run.summary() and EX0 in run.summary()


def test_a_regrade_replaces_the_scores_keeps_a_human_score_and_reuses_the_seeds(course):
    first = {r.student: r for r in grade("ex00", course=course, first_slot=SLOT).results}
    submit(course, "bob", EX0, notebook_with(EX0, solutions(EX0)))  # bob hands in again
    with gradebook(course) as gb:
        grade_cell = next(g for nb in gb.find_submission(EX0, "alice").notebooks for g in nb.grades
                          if g.name == "test_visible")
        grade_cell.manual_score = 1.0  # the instructor overrode a cell by hand
        gb.db.commit()
    second = {r.student: r for r in grade("ex00", course=course, first_slot=SLOT).results}
    assert second["bob"].score == 10.0 and second["bob"].status == "graded"
    assert second["alice"].status == "needs manual grade"
    assert second["alice"].seeds == first["alice"].seeds != first["bob"].seeds
    with gradebook(course) as gb:
        assert gb.find_submission(EX0, "bob").score == 10.0
        assert gb.find_submission(EX0, "alice").score == 9.0  # the human's 1 point replaces the 2 of the cell
    assert rows(course / "grades.csv")[EX0, "alice"]["status"] == "needs manual grade"


def test_one_student_and_another_csv(course, tmp_path):
    run = grade("ex00_polar", course=course, students=["bob"], output=tmp_path / "out" / "marks.csv",
                first_slot=SLOT)
    assert [r.student for r in run.results] == ["bob"]
    assert set(rows(tmp_path / "out" / "marks.csv")) == {(EX0, "bob")}
    with pytest.raises(ValueError, match="no student carol"):
        grade("ex00", course=course, students=["carol"], first_slot=SLOT)


def test_two_runs_on_one_course_are_refused(course):
    lock = open(course / ".grading.lock", "a")  # another labkit grade holds the lock
    import fcntl

    fcntl.flock(lock, fcntl.LOCK_EX)
    try:
        with pytest.raises(ValueError, match="another `labkit grade`"):
            grade("ex00", course=course, first_slot=SLOT)
    finally:
        lock.close()
    assert not (course / "gradebook.db").exists() or grade("ex00", course=course, first_slot=SLOT).ok


@pytest.mark.parametrize(("change", "error", "match"), [
    ("spec", FileNotFoundError, "no grading spec"),
    ("release", ValueError, "stale"),
    ("hidden_in_notebook", ValueError, "hidden tests in the notebook"),
    ("unknown_test", ValueError, "matches no graded cell"),
])
def test_a_broken_exercise_stops_the_run_before_any_student(course, change, error, match):
    if change == "spec":
        (course / "grading" / f"{EX0}.py").unlink()
    elif change in ("release", "hidden_in_notebook"):
        folder = "release" if change == "release" else "source"
        path = course / folder / EX0 / f"{EX0}.ipynb"
        notebook = json.loads(path.read_text())
        cell = next(c for c in notebook["cells"] if c["id"] == "test_visible")
        extra = "\n### BEGIN HIDDEN TESTS\nassert True\n### END HIDDEN TESTS" if change != "release" else "\npass"
        cell["source"] = "".join(cell["source"]) + extra
        path.write_text(json.dumps(notebook))
    else:
        with open(course / "grading" / f"{EX0}.py", "a") as f:
            f.write("\n\ndef test_no_such_cell(beams_to_points, rng):\n    pass\n")
    with pytest.raises(error, match=match):
        grade("ex00", course=course, first_slot=SLOT)
    assert not (course / "records").exists()


def test_changed_graded_cells_after_grading_are_refused(course):
    grade("ex00", course=course, first_slot=SLOT)
    for folder in ("source", "release"):
        path = course / folder / EX0 / f"{EX0}.ipynb"
        notebook = json.loads(path.read_text())
        next(c for c in notebook["cells"] if c["id"] == "test_visible")["metadata"]["nbgrader"]["points"] = 3
        notebook["metadata"]["labkit"]["functions"]["beams_to_points"] = 11  # the exercise's new total
        path.write_text(json.dumps(notebook))
    with pytest.raises(ValueError, match="changed since it was graded"):
        grade("ex00", course=course, first_slot=SLOT)


def test_add_grade_parser_plugs_into_a_command_line():
    parser = argparse.ArgumentParser(prog="labkit")
    parser.add_argument("-q", "--quiet", action="store_true")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS)
    commands = parser.add_subparsers(dest="command", required=True)
    commands.add_parser = partial(commands.add_parser, parents=[common])  # as labkit/app/cli.py does
    add_grade_parser(commands)
    args = parser.parse_args(["grade", "ex01", "-j", "2", "-q", "--student", "a", "--student", "b"])
    assert (args.func, args.exercise, args.jobs, args.quiet, args.student) == (run_grade, "ex01", 2, True, ["a", "b"])
    args = parser.parse_args(["grade", "--check", "my.ipynb"])
    assert args.check == "my.ipynb" and args.exercise is None and not args.no_sandbox


# ---------------------------------------------------------------------------- students: --check
def test_check_runs_the_visible_tests_the_way_they_are_graded(tmp_path):
    path = tmp_path / "ex01_range_segmentation.ipynb"
    path.write_text(json.dumps(notebook_with("ex01_range_segmentation", solutions("ex01_range_segmentation"))))
    report, passed = _check_report(*check(path))
    assert passed, report
    assert "test_visible" in report and "hidden tests only" in report and "all visible tests passed" in report


def test_check_shows_a_delegating_student_why_it_fails(tmp_path):
    path = tmp_path / "my copy.ipynb"  # a name that does not say the exercise: found from its cells
    delegate = '''
import labkit


def beams_to_points(ranges, angles, range_min, range_max):
    scan = labkit.Scan(ranges=ranges, angles=angles, range_min=range_min, range_max=range_max)
    return scan.xy, scan.valid_indices
'''
    path.write_text(json.dumps(notebook_with(EX0, {"beams_to_points": delegate})))
    exercise, result = check(path)
    report, passed = _check_report(exercise, result)
    assert exercise.name == EX0 and not passed
    assert "labkit is not available when your notebook is graded" in report
    assert "some visible tests failed" in report


def test_the_command_line_checks_and_grades(course, tmp_path):
    path = tmp_path / f"{EX0}.ipynb"
    path.write_text(json.dumps(notebook_with(EX0, solutions(EX0))))
    proc = cli("--check", str(path), "--course", str(course))
    assert proc.returncode == 0 and "all visible tests passed" in proc.stdout, proc.stdout + proc.stderr
    path.write_text(json.dumps(release_notebook(EX0)))
    proc = cli("--check", str(path), "--course", str(course))
    assert proc.returncode == 1 and "NotImplementedError" in proc.stdout
    proc = cli("ex00", "--course", str(course), "-j", "2", "-q")
    assert proc.returncode == 0, proc.stderr
    assert "2 submissions graded" in proc.stdout and rows(course / "grades.csv")[EX0, "alice"]["score"] == "10"


@pytest.mark.parametrize(("args", "message"), [
    (["ex99"], "no exercise 'ex99'"),
    ([], "say what to grade"),
    (["all", "--course", "/no/such/course"], "not a course folder"),
    (["--check", "/no/such.ipynb"], "no notebook /no/such.ipynb"),
    (["ex00", "-j", "0"], "--jobs must be at least 1"),
])
def test_user_errors_are_one_line_and_status_1(course, args, message):
    proc = cli(*args, *(["--course", str(course)] if "--course" not in args else []))
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines() == [f"labkit grade: error: {proc.stderr.split('error: ', 1)[1].strip()}"]
    assert message in proc.stderr


def test_without_bwrap_the_grader_refuses_and_says_how_to_install_it(course):
    env = dict(os.environ, PATH="/nonexistent")
    proc = cli("ex00", "--course", str(course), env=env)
    assert proc.returncode == 1 and "apt-get install bubblewrap" in proc.stderr
    assert not (course / "gradebook.db").exists()


def test_the_default_course_is_exercises_in_the_working_directory(course):
    (course.parent / "exercises").symlink_to(course)
    proc = cli("ex00", "-q", "-j", "1", cwd=course.parent)
    assert proc.returncode == 0, proc.stderr


def test_progress_and_summary_go_to_the_terminal(course, capsys):
    code = run_grade(argparse.Namespace(check=None, exercise="ex00", course=str(course), jobs=1, student=None,
                                        output=None, no_sandbox=False, check_exercise=None, quiet=False))
    out = capsys.readouterr()
    assert code == 0 and "mean score" in out.out and EX0 in out.out


def test_the_gradebook_is_stamped_with_the_revision_nbgrader_would_write(tmp_path, monkeypatch):
    """labkit reads nbgrader's schema revision in-process; nbgrader runs the ``alembic`` program for it."""
    from nbgrader.api import get_alembic_version

    from labkit.grading.records import alembic_head

    monkeypatch.setenv("PATH", os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""))
    monkeypatch.chdir(tmp_path)
    assert alembic_head() == get_alembic_version()


def test_nbgrader_autograde_is_refused_with_what_to_run_instead(course):
    """nbgrader's autograde would see only the visible tests, and give the hidden tests' points away."""
    grade("ex00", course=course, first_slot=SLOT)  # the assignment is in the gradebook
    (course / "autograded").rename(course / "graded by labkit")
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""),
               JUPYTER_CONFIG_DIR=str(course / ".jupyter-config"))
    proc = subprocess.run([sys.executable, "-m", "nbgrader", "autograde", EX0], cwd=course, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode != 0
    assert "graded with `labkit grade" in proc.stdout + proc.stderr
    assert not (course / "autograded" / "alice" / EX0 / f"{EX0}.ipynb").exists()


def test_a_grader_failure_is_one_submissions_status_and_exit_1(course, monkeypatch, capsys):
    from labkit.grading import command

    real = command.grade_submission

    def failing_for_bob(job):
        if job.student == "bob":
            raise RuntimeError("a bug in the grader")
        return real(job)

    submit(course, "bob", EX0, notebook_with(EX0, solutions(EX0)))
    grade("ex00", course=course, first_slot=SLOT)  # bob has a grade from before: 10
    monkeypatch.setattr(command, "grade_submission", failing_for_bob)
    args = argparse.Namespace(check=None, exercise="ex00", course=str(course), jobs=1, student=None, output=None,
                              no_sandbox=False, check_exercise=None, quiet=True)
    assert run_grade(args) == 1
    assert "bob: the grader failed: RuntimeError: a bug in the grader" in capsys.readouterr().err
    table = rows(course / "grades.csv")
    assert (table[EX0, "bob"]["status"], table[EX0, "alice"]["status"]) == ("grader error", "graded")
    with gradebook(course) as gb:
        assert gb.find_submission(EX0, "bob").score == 10.0  # the earlier verdict stays
        assert gb.find_submission(EX0, "alice").score == 10.0


def test_a_sandbox_that_cannot_start_is_a_grader_error_not_the_students_zero(course, capsys):
    """A worker that cannot start once the run's probe passed (here: the exercise's limits leave no room for
    Python; elsewhere a full process table, a broken bwrap, a cgroup the kernel refuses) is the grader's failure:
    no verdict, the earlier grade stays, exit status 1 -- not a 0 with status "graded"."""
    submit(course, "bob", EX0, notebook_with(EX0, solutions(EX0)))
    grade("ex00", course=course, first_slot=SLOT)  # alice and bob have 10 from before
    with open(course / "grading" / f"{EX0}.py", "a", encoding="utf-8") as f:
        f.write("\n\nfrom labkit.grading.sandbox import Limits\n\nLIMITS = Limits(memory_bytes=16 << 20)\n")
    args = argparse.Namespace(check=None, exercise="ex00", course=str(course), jobs=1, student=None, output=None,
                              no_sandbox=False, check_exercise=None, quiet=True)
    assert run_grade(args) == 1
    assert "the sandbox could not start a worker" in capsys.readouterr().err
    table = rows(course / "grades.csv")
    assert (table[EX0, "alice"]["status"], table[EX0, "bob"]["status"]) == ("grader error", "grader error")
    with gradebook(course) as gb:
        assert gb.find_submission(EX0, "alice").score == gb.find_submission(EX0, "bob").score == 10.0


def _family(pid: int) -> set[int]:
    """``pid`` and its children (the grading processes of a run)."""
    found = {pid}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    if int(f.read().rpartition(")")[2].split()[1]) == pid:
                        found.add(int(entry))
            except (OSError, ValueError, IndexError):
                pass
    return found


def _running(pid: int) -> bool:
    """Whether ``pid`` is a process that has not ended (a zombie has)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


def _cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline") as f:
            return f.read()
    except OSError:
        return ""


def _start_slow_run(course: Path) -> subprocess.Popen:
    """``python -m labkit.grading ex00 -j 2`` on ``course`` with two more students whose function sleeps 3 s
    per call, in a session of its own (so that a signal to its group reaches the run and its children only)."""
    slow = solutions(EX0)["beams_to_points"].replace("):\n", "):\n    __import__('time').sleep(3)\n", 1)
    for student in ("carol", "dave"):
        submit(course, student, EX0, notebook_with(EX0, {"beams_to_points": slow}))
    return subprocess.Popen([sys.executable, "-m", "labkit.grading", "ex00", "--course", str(course), "-j", "2",
                             "-q"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def _graders(run_pid: int) -> set[int]:
    """The run's grading processes (the pool's spawned interpreters)."""
    return {pid for pid in _family(run_pid) if "spawn_main" in _cmdline(pid)}


def _cgroups_of(parent: str, pids: set[int]) -> set[str]:
    """The worker cgroups under ``parent`` made by one of ``pids`` (their names hold the maker's pid)."""
    return {name for name in os.listdir(parent) if name.startswith(cgroups.PREFIX)
            and name.split("-")[2].isdigit() and int(name.split("-")[2]) in pids}


def _left(pids: set[int], parent: str = "", names: set[str] = frozenset(), seconds: float = 5.0):
    """What is still there after waiting up to ``seconds``: the running ``pids`` and the cgroup ``names``."""
    deadline = time.monotonic() + seconds
    while True:
        running = [pid for pid in pids if _running(pid)]
        folders = [name for name in names if os.path.exists(os.path.join(parent, name))]
        if not (running or folders) or time.monotonic() > deadline:
            return running, folders
        time.sleep(0.05)


def _stop(run: subprocess.Popen) -> None:
    """Whatever a failed test left of the run: SIGKILL to its session (grading processes included)."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(run.pid, signal.SIGKILL)
    run.communicate()


@pytest.mark.parametrize("delay", [round(i * 0.05, 2) for i in range(12)])  # the start: ~0.6 s here
def test_ctrl_c_while_the_grading_processes_start(course, delay):
    """Ctrl-C ``delay`` s after the run's first grading process appeared, while the pool starts them: one
    clear line and 130, at once, and no grading process left. Staged after make test once waited past 30 s
    for the Ctrl-C test below: on the old code a grading process still in its imports printed a
    KeyboardInterrupt traceback, one whose parent stopped between fork and hand-over an EOFError traceback,
    and a Ctrl-C in the submits left the pool's exit waiting for the queued jobs. A race: on the old code 4
    of 16 moments 0.04 s apart failed in one run, so these 12 miss it about 3 % of the time."""
    run = _start_slow_run(course)
    seen, deadline = set(), time.monotonic() + 120
    try:
        while not seen and time.monotonic() < deadline and run.poll() is None:
            seen = _graders(run.pid)
            time.sleep(0.005)
        assert seen, "no grading process started"
        time.sleep(delay)
        seen |= _graders(run.pid)
        os.killpg(run.pid, signal.SIGINT)
        _, stderr = run.communicate(timeout=30)
        assert run.returncode == 130 and "labkit grade: interrupted" in stderr and "Traceback" not in stderr, stderr
        assert _left(seen) == ([], []), "grading processes outlived the run"
    finally:
        _stop(run)


@pytest.mark.skipif(not cgroups.detect().usable, reason=f"no cgroups for the workers: {cgroups.detect().problem}")
def test_a_killed_run_takes_its_grading_processes_and_workers_with_it(course):
    """SIGKILL to the run alone (an out-of-memory kill, `kill -9`): its grading processes are told by the
    kernel (PR_SET_PDEATHSIG) and remove their workers and cgroups. Before, they waited for jobs forever,
    each with a worker and a cgroup."""
    parent = cgroups.detect().parents["pids"]
    run = _start_slow_run(course)
    graders, theirs, deadline = set(), set(), time.monotonic() + 120
    try:
        while len(theirs) < 2 and time.monotonic() < deadline and run.poll() is None:
            graders |= _graders(run.pid)
            theirs |= _cgroups_of(parent, graders)
            time.sleep(0.05)
        assert len(theirs) >= 2, "the grading processes' workers never started"
        os.kill(run.pid, signal.SIGKILL)
        run.wait()
        running, folders = _left(graders, parent, theirs, seconds=20)
        assert not running, "grading processes outlived the killed run"
        assert folders == []
    finally:
        _stop(run)


@pytest.mark.skipif(not cgroups.detect().usable, reason=f"no cgroups for the workers: {cgroups.detect().problem}")
def test_ctrl_c_leaves_no_worker_cgroup_behind(course):
    """Ctrl-C (SIGINT to the run's process group, as a terminal sends it) while two jobs have workers: the run
    exits with 130 at once (not after its queue: 97 s here before the grading processes ignored SIGINT and
    were stopped by the run), saying what was saved, and no worker or cgroup of the run is left."""
    parent = cgroups.detect().parents["pids"]
    run = _start_slow_run(course)
    theirs, seen, deadline = set(), set(), time.monotonic() + 120
    try:
        while len(theirs) < 2 and time.monotonic() < deadline and run.poll() is None:
            family = _family(run.pid)
            seen |= family - {run.pid}
            theirs |= _cgroups_of(parent, family)
            time.sleep(0.05)
        assert len(theirs) >= 2, "the run's workers never started"
        os.killpg(run.pid, signal.SIGINT)
        _, stderr = run.communicate(timeout=30)
        assert run.returncode == 130 and "interrupted:" in stderr and "Traceback" not in stderr, stderr
    finally:
        if run.poll() is None:
            _stop(run)
    assert [name for name in theirs if os.path.exists(os.path.join(parent, name))] == []
    # (multiprocessing's resource tracker ends when it reads the run's end)
    assert seen and _left(seen)[0] == [], "grading processes outlived the run"


def test_a_grading_process_skips_jsonschemas_iri_grammars(tmp_path, monkeypatch):
    """Every process of a grading run imports nbgrader, hence nbformat and jsonschema, which compiles 38 IRI
    grammars at import (3 s of CPU per process) for a string format that nothing here checks. The run and its
    grading processes go without them; nbformat still reads and validates an exercise notebook."""
    notebook = tmp_path / "n.ipynb"
    notebook.write_text(json.dumps(release_notebook(EX0)), encoding="utf-8")
    code = ("import sys\nfrom labkit.grading.command import _skip_iri_grammars\n_skip_iri_grammars()\n"
            "import nbgrader.api, nbformat\nnbformat.validate(nbformat.read(sys.argv[1], as_version=4))\n"
            "print(repr(sys.modules.get('rfc3987_syntax', 'never imported')))")
    out = subprocess.run([sys.executable, "-c", code, str(notebook)], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "None", out

    import labkit.grading.command as command  # noqa: PLC0415

    called = []
    monkeypatch.setattr(command, "_skip_iri_grammars", lambda: called.append(True))
    parser = argparse.ArgumentParser()
    add_grade_parser(parser.add_subparsers())
    with pytest.raises(ValueError, match="say what to grade"):
        run_grade(parser.parse_args(["grade"]))
    assert called, "labkit grade did not skip the grammars"
