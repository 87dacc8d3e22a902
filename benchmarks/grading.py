"""Benchmark ``labkit grade``: a generated class graded with ``--jobs 1`` and ``--jobs 2``.

The class: ``--students`` students, each handing in every exercise of the course. Per exercise
and student the submission is, in turn (a fixed, seeded mix): the instructor's solution (60 %),
a plausible mistake from the exercise's spec (20 %), the blank release (10 %) or an attack
(10 %: delegating to labkit, an ndarray with a lying ``__eq__``, reading the course's files,
monkeypatching numpy, a fork bomb or 50 MB of output around a correct answer). ``--loopers K``
adds K endless loops per exercise (each costs its four tests' call timeouts).

Each ``--jobs`` value grades a fresh copy of the course (gradebook created, secret drawn) with
:func:`labkit.grading.grade` and prints submissions per minute, where one submission's time goes
(starting its worker, running the notebook's cells, waiting for the student's functions, the
trusted tests' own work), the time per exercise, and what a class of 300 students x 12 exercises
(the whole course) would take at that rate, extrapolated from the measured rate.

Run ``python benchmarks/grading.py`` (30 students, a few minutes) or ``--quick`` (5 students).
"""

from __future__ import annotations

import argparse
import random
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CLASS = 300 * 12  # the class the throughput is extrapolated to: 300 students, every exercise of the course
sys.path.insert(0, str(REPO))  # the tests' course helpers (tests/ is not installed)

from labkit.grading import grade  # noqa: E402
from labkit.grading.exercises import Course  # noqa: E402
from tests.grading_course import copy_course, notebook_with, release_notebook, solutions, submit  # noqa: E402

ATTACKS = {
    "lying array": '''
class Equal(np.ndarray):
    def __eq__(self, other):
        return True


def {name}(*args, **kwargs):
    return np.zeros(3, dtype=np.int64).view(Equal)
''',
    "reads files": '''
import glob


def {name}(*args, **kwargs):
    return [open(p).read() for p in glob.glob("/*/*/source/*/*.ipynb")]
''',
    "monkeypatch": '''
import numpy.testing
numpy.testing.assert_array_equal = lambda *args, **kwargs: None
np.allclose = lambda *args, **kwargs: True


def {name}(*args, **kwargs):
    return None
''',
}
AROUND_SOLUTION = {
    "fork bomb": '''
import os, time
for _ in range(1000):
    try:
        if os.fork() == 0:
            while True:
                time.sleep(1)
    except OSError:
        break
''',
    "output bomb": 'print("x" * 50_000_000)',
}


def build_class(course: Path, students: int, loopers: int, seed: int = 0) -> dict[str, int]:
    """Write the submissions; the number of each kind."""
    rng = random.Random(seed)
    kinds: dict[str, int] = {}
    reader = Course(course)
    for name in reader.names():
        exercise = reader.exercise(name)
        answers = solutions(name)
        mistakes = list(exercise.module.MISTAKES.values())
        first = exercise.functions[0]
        for index in range(students + loopers):
            roll = rng.random()
            before: list[str] = []
            if index >= students:
                kind, cells = "endless loop", {gid: f"def {f}(*args, **kwargs):\n    while True:\n        pass\n"
                                               for gid, f in zip(answers, exercise.functions, strict=False)}
            elif roll < 0.6:
                kind, cells = "solution", answers
            elif roll < 0.8:
                kind = "mistake"
                old, new = rng.choice(mistakes)
                cells = {gid: code.replace(old, new) for gid, code in answers.items()}
            elif roll < 0.9:
                kind, cells = "blank", None
            elif roll < 0.93:
                kind, cells = "delegate", dict(exercise.module.DELEGATE)
            else:
                kind = rng.choice([*ATTACKS, *AROUND_SOLUTION])
                if kind in ATTACKS:
                    cells = {next(iter(answers)): ATTACKS[kind].format(name=first)}
                else:
                    cells, before = answers, [AROUND_SOLUTION[kind]]
            notebook = release_notebook(name) if cells is None else notebook_with(name, cells, before=before)
            submit(course, f"student{index:03d}", name, notebook)
            kinds[kind] = kinds.get(kind, 0) + 1
    return kinds


def table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--students", type=int, default=30)
    parser.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--loopers", type=int, default=0, help="endless loops per exercise (default 0)")
    parser.add_argument("--quick", action="store_true", help="5 students")
    args = parser.parse_args()
    students = 5 if args.quick else args.students

    rates, summaries = [], []
    with tempfile.TemporaryDirectory(prefix="labkit-grading-bench-") as scratch:
        for jobs in args.jobs:
            course = copy_course(Path(scratch) / f"jobs{jobs}")
            kinds = build_class(course, students, args.loopers)
            started = time.perf_counter()
            run = grade("all", course=course, jobs=jobs)
            seconds = time.perf_counter() - started
            handed_in = [r for r in run.results if r.status != "not submitted"]
            rate = len(handed_in) / seconds * 60
            timed = [r for r in handed_in if r.timing]
            parts = {part: statistics.mean(r.timing[part] for r in timed)
                     for part in ("total_s", "start_s", "load_s", "calls_s", "trusted_s", "cpu_s")}
            class_minutes = CLASS / rate
            rates.append([str(jobs), str(len(handed_in)), f"{seconds:.1f}", f"{rate:.0f}",
                          *(f"{parts[p] * 1000:.0f}" for p in ("total_s", "start_s", "load_s", "calls_s", "trusted_s",
                                                               "cpu_s")),
                          f"{class_minutes:.1f}"])
            per_exercise = {}
            for result in timed:
                per_exercise.setdefault(result.exercise, []).append(result.timing["total_s"])
            summaries.append((jobs, kinds, per_exercise, run))
            shutil.rmtree(course, ignore_errors=True)

    print(f"# labkit grade: {students} students x {len(summaries[0][2])} exercises\n")
    print("kinds of submission: " + ", ".join(f"{k} {v}" for k, v in sorted(summaries[0][1].items())) + "\n")
    print(table(["jobs", "submissions", "seconds", "per minute", "ms per submission", "start worker", "run cells",
                 "student's calls", "trusted tests", "CPU ms", "300 x 12 (min)"], rates))
    print("\nThe millisecond columns are means per submission within one job: its wall time, split into starting "
          "the sandboxed worker (bwrap, Python, numpy), running the notebook's cells, waiting for the student's "
          "functions (with the channel) and the trusted side's own work (references, comparisons); 'CPU ms' is the "
          "CPU time the submission cost (grading process and its workers), which does not depend on what else the "
          "machine runs. 'seconds' includes the run's fixed costs (importing nbgrader, creating the gradebook, "
          "starting the grading processes).\n")
    cpu = statistics.mean(r.timing["cpu_s"] for s in summaries for r in s[3].results if r.timing)
    print(f"CPU per submission {cpu * 1000:.0f} ms: on 2 free cores a 300 x 12 class needs at least "
          f"{CLASS * cpu / 2 / 60:.1f} min of grading (plus the fixed costs).\n")
    rows = []
    for name in sorted(summaries[0][2]):
        rows.append([name, *(f"{statistics.mean(s[2][name]) * 1000:.0f}" for s in summaries)])
    print(table(["exercise", *(f"ms per submission, --jobs {s[0]}" for s in summaries)], rows))
    print("\n" + summaries[-1][3].summary())


if __name__ == "__main__":
    main()
