"""Shared by the grading tests: a throw-away copy of the course and submissions written into it.

The tests never grade inside the repository: :func:`copy_course` copies the trusted part of
``exercises/`` (sources, release, specs, nbgrader config) into a temporary folder, and
:func:`submit` writes a student's notebook under its ``submitted/`` the way ``nbgrader collect``
lays it out. Notebooks are built from the committed release, with the solution cells replaced by
the instructor's solution (:func:`solutions`), a mistake in it (:func:`with_mistake`) or any code.
"""

from __future__ import annotations

import json
import shutil
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXERCISES = REPO / "exercises"
SOLUTION_MARKERS = ("### BEGIN SOLUTION", "### END SOLUTION")


def read_notebook(path: Path) -> dict:
    return json.loads(Path(path).read_text(encoding="utf-8"))


def cell_source(cell: dict) -> str:
    source = cell["source"]
    return source if isinstance(source, str) else "".join(source)


def grade_id(cell: dict) -> str | None:
    return cell.get("metadata", {}).get("nbgrader", {}).get("grade_id")


def cells_by_grade_id(notebook: dict) -> dict[str, dict]:
    return {grade_id(c): c for c in notebook["cells"] if grade_id(c) is not None}


def names() -> list[str]:
    return sorted(p.name for p in (EXERCISES / "source").iterdir() if (p / f"{p.name}.ipynb").is_file())


def source_notebook(name: str) -> dict:
    return read_notebook(EXERCISES / "source" / name / f"{name}.ipynb")


def release_notebook(name: str) -> dict:
    return read_notebook(EXERCISES / "release" / name / f"{name}.ipynb")


def solutions(name: str) -> dict[str, str]:
    """The instructor's answer: each solution cell of the source without its marker lines."""
    return {
        gid: "\n".join(line for line in cell_source(cell).splitlines() if line.strip() not in SOLUTION_MARKERS)
        for gid, cell in cells_by_grade_id(source_notebook(name)).items()
        if cell["metadata"]["nbgrader"].get("solution")
    }


def with_mistake(name: str, old: str, new: str) -> dict[str, str]:
    answers = solutions(name)
    found = sum(code.count(old) for code in answers.values())
    assert found == 1, f"{name}: {old!r} occurs {found} times in the solution, not once"
    return {gid: code.replace(old, new) for gid, code in answers.items()}


def notebook_with(name: str, answers: dict[str, str], *, extra: list[str] = (), before: list[str] = ()) -> dict:
    """The release of ``name`` with ``answers`` (grade id -> code) in its solution cells, and extra code
    cells (without metadata) after the last cell (``extra``) or before the first (``before``)."""
    notebook = json.loads(json.dumps(release_notebook(name)))
    cells = cells_by_grade_id(notebook)
    for gid, code in answers.items():
        cells[gid]["source"] = textwrap.dedent(code).strip("\n")
    plain = [{"cell_type": "code", "metadata": {}, "source": textwrap.dedent(code).strip("\n"), "outputs": [],
              "execution_count": None} for code in (*before, *extra)]
    notebook["cells"] = plain[:len(before)] + notebook["cells"] + plain[len(before):]
    return notebook


def copy_course(destination: Path) -> Path:
    """The trusted part of exercises/ (no gradebook, submissions or records) in ``destination``."""
    destination.mkdir(parents=True)
    for part in ("source", "release", "grading"):
        shutil.copytree(EXERCISES / part, destination / part, ignore=shutil.ignore_patterns("__pycache__",
                                                                                            ".ipynb_checkpoints"))
    shutil.copy(EXERCISES / "nbgrader_config.py", destination / "nbgrader_config.py")
    return destination


def submit(course: Path, student: str, name: str, notebook: dict | str | bytes, *, file: str | None = None) -> Path:
    """Write a submission: a notebook (dict), or the file's raw text/bytes (for broken notebooks)."""
    folder = course / "submitted" / student / name
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / (file or f"{name}.ipynb")
    if isinstance(notebook, dict):
        path.write_text(json.dumps(notebook, indent=1), encoding="utf-8")
    elif isinstance(notebook, bytes):
        path.write_bytes(notebook)
    else:
        path.write_text(notebook, encoding="utf-8")
    return path


def once_per_session(tmp_path_factory, name: str, build):
    """``build(folder)``'s result, computed by one pytest process of the session and shared with the
    others (pytest-xdist runs a module's tests in several processes, each of which would otherwise
    build a module-scoped fixture again). ``build`` gets an empty folder and returns a picklable value."""
    import fcntl
    import os
    import pickle

    shared = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        shared = shared.parent  # the session's folder, above each worker's own
    folder = shared / f"shared-{name}"
    with open(shared / f"shared-{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = shared / f"shared-{name}.pickle"
        if not done.exists():
            folder.mkdir()
            value = build(folder)
            done.write_bytes(pickle.dumps(value))
        return pickle.loads(done.read_bytes())


class LocalSession:
    """The interface of :class:`labkit.grading.sandbox.Session`, with the student's code run in this process.

    For the tests' own code only (the instructor's solution and mistakes, an attacker's table written by a
    test): nothing is isolated. Arguments and results cross the grader's wire format as they would from a
    worker (copies, plain values), and an exception comes back as its first built-in class, so the trusted
    tests see what they would see from the sandbox, many times faster.
    """

    def __init__(self, cells: list[str]) -> None:
        self.cells = cells
        self.namespace: dict = {"__name__": "__main__"}
        self.cell_errors: list[dict] | None = None
        self.timed_out = self.crashed = False
        self.calls = 0
        from types import SimpleNamespace

        self.timing = SimpleNamespace(start_s=0.0, load_s=0.0, calls_s=0.0, workers=0, worker_cpu_s=0.0)

    def load(self) -> None:
        if self.cell_errors is not None:
            return
        self.cell_errors = []
        for index, code in enumerate(self.cells):
            try:
                exec(compile(code, f"<cell {index}>", "exec"), self.namespace)
            except Exception as error:  # noqa: BLE001 -- as in the worker: noted, the next cell runs
                self.cell_errors.append({"cell": index, "error": type(error).__name__, "message": str(error)})

    def begin_test(self, budget_s: float) -> None:
        pass

    def call(self, name: str, args: tuple, kwargs: dict):
        from labkit.grading import protocol

        self.load()
        self.calls += 1
        function = self.namespace.get(name)
        if not callable(function):
            raise NameError(f"{name} is not defined in your notebook (keep the function's name and signature)")
        args, kwargs = protocol.decode(protocol.encode(list(args))), protocol.decode(protocol.encode(dict(kwargs)))
        try:
            result = function(*args, **kwargs)
        except Exception as error:  # noqa: BLE001 -- rebuilt as a built-in, as the wire does
            raise protocol.rebuild_exception(protocol.exception_names(error), str(error)) from None
        return protocol.decode(json.loads(json.dumps(protocol.encode(result))))

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc_info) -> None:
        pass
