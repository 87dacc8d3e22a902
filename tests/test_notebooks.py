"""The course notebooks: stored clean, free of path tricks, and their "your turn" cells tried.

Every ``notebooks/*.ipynb`` with "your turn" cells is executed headless by nbclient up to its
last "your turn" check (every notebook runs to the end, twice, in JupyterLab: tests/test_browser.py),
in a fresh kernel that runs *this* interpreter (so it sees the labkit installed here), with a temporary working
directory (so whatever a notebook writes, e.g. ``out/``, lands there and not in the
repository), and with ``LABKIT_SHARED_DATASETS`` pointing at ``../shared/datasets`` when that
folder exists (so the real-data sections run). Those tests are marked ``slow``.

The fast tests check what is committed: notebooks and exercise sources are valid nbformat 4
with no outputs (STYLE.md item 11) and no ``sys.path`` manipulation (STYLE.md item 1).
"""

from __future__ import annotations

import importlib
import json
import os
import queue
import re
import sys
import time
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError, CellTimeoutError, DeadKernelError

from docs import executed_notebooks
from docs.executed_notebooks import sliced_waits
from tests.conftest import SHARED_DATASETS

REPO = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))
EXERCISE_SOURCES = sorted(
    p for p in (REPO / "exercises" / "source").rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts
)
STORED = NOTEBOOKS + EXERCISE_SOURCES

KERNEL_NAME = "python3"
CELL_TIMEOUT_S = 300  # per cell; a hung kernel fails its notebook, not the run
SLOW_STEP_S = 30  # a cell (or the kernel's start or stop) this slow is listed at the end of the run

_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_PATH_TRICK = re.compile(
    r"\bsys\.path\s*(?:\.\s*(?:append|insert|extend)\s*\(|\+=|=(?!=))"  # sys.path.append(...), sys.path = ...
    r"|\bsite\.addsitedir\s*\("
)


def _rel(path: Path) -> str:
    return str(path.relative_to(REPO))


def _code_cells(nb) -> list[tuple[int, nbformat.NotebookNode]]:
    return [(i, c) for i, c in enumerate(nb.cells) if c.cell_type == "code"]


# ---------------------------------------------------------------------------- kernel
@pytest.fixture(scope="session")
def kernel_dir(tmp_path_factory) -> Path:
    """A Jupyter data dir with a ``python3`` kernelspec that launches this interpreter.

    jupyter_client looks kernelspecs up on ``JUPYTER_PATH`` first, so this one wins over a
    ``python3`` spec in the user's home (which may point at another Python) and over the
    one in the venv (whose ``argv[0] == "python"`` jupyter_client would swap for
    ``sys.executable`` anyway).
    """
    root = tmp_path_factory.mktemp("jupyter")
    spec = root / "kernels" / KERNEL_NAME
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": f"Python 3 ({sys.executable})",
        "language": "python",
        "metadata": {"debugger": False},
    }))
    return root


@pytest.fixture
def this_python_kernel(kernel_dir, monkeypatch) -> str:
    """Make ``kernel_name="python3"`` resolve to :func:`kernel_dir`'s spec; return the name."""
    monkeypatch.setenv("JUPYTER_PATH", os.pathsep.join(filter(None, [str(kernel_dir),
                                                                     os.environ.get("JUPYTER_PATH")])))
    return KERNEL_NAME


def _execute(nb, workdir: Path, kernel_name: str):
    client = NotebookClient(nb, timeout=CELL_TIMEOUT_S, kernel_name=kernel_name,
                            resources={"metadata": {"path": str(workdir)}})
    return client.execute()


def test_sliced_waits_find_a_message_whose_wake_up_was_missed(monkeypatch):
    """A channel that, like pyzmq's asyncio poll after a missed wake-up, sees a message only when
    the wait that was under way when it arrived times out: sliced, the wait returns it within a
    slice, not at the end of the cell's timeout; with no message it still ends at that timeout."""
    import asyncio
    from types import SimpleNamespace

    monkeypatch.setattr(executed_notebooks, "POLL_SLICE_S", 0.05)

    class MissedWakeUp:
        def __init__(self, arrives_after_s):
            self.arrives = time.monotonic() + arrives_after_s

        async def get_msg(self, timeout=None):
            started = time.monotonic()
            if started >= self.arrives:
                return "reply"
            await asyncio.sleep(timeout)  # the wake-up is missed: only the timeout ends the wait
            if time.monotonic() >= self.arrives:
                return "reply"
            raise queue.Empty

    kc = SimpleNamespace(shell_channel=MissedWakeUp(0.1), iopub_channel=MissedWakeUp(1e9))
    sliced_waits(kc)
    started = time.monotonic()
    assert asyncio.run(kc.shell_channel.get_msg(timeout=5.0)) == "reply"
    assert time.monotonic() - started < 1.0
    started = time.monotonic()
    with pytest.raises(queue.Empty):
        asyncio.run(kc.iopub_channel.get_msg(timeout=0.3))
    assert 0.3 <= time.monotonic() - started < 1.0


@pytest.mark.slow
def test_kernel_runs_this_interpreter(this_python_kernel, tmp_path):
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(
        "import sys; print(sys.executable); print(sys.prefix)")])
    _execute(nb, tmp_path, this_python_kernel)
    executable, prefix = nb.cells[0].outputs[0]["text"].split()
    assert (executable, prefix) == (sys.executable, sys.prefix)


# ---------------------------------------------------------------------------- notebooks run
YOUR_TURN, YOUR_TURN_CHECK = "your-turn", "your-turn-check"


def _tags(cell) -> list[str]:
    return list(cell.get("metadata", {}).get("tags", []))


def your_turn_pairs(nb) -> list[tuple[int, int]]:
    """(stub index, check index) for every cell tagged ``your-turn``: its check is the next
    code cell tagged ``your-turn-check``."""
    pairs = []
    for i, cell in enumerate(nb.cells):
        if YOUR_TURN in _tags(cell):
            j = next((k for k in range(i + 1, len(nb.cells)) if YOUR_TURN_CHECK in _tags(nb.cells[k])), None)
            assert j is not None, f"your-turn cell {i} ({cell.get('id')}) has no your-turn-check cell after it"
            pairs.append((i, j))
    return pairs


def _fills(path: Path) -> dict:
    """The ``FILLS`` of ``tests/your_turn/nbNN.py`` for ``NN_*.ipynb`` ({} when there is none)."""
    module_path = REPO / "tests" / "your_turn" / f"nb{path.name[:2]}.py"
    if not module_path.exists():
        return {}
    module = importlib.import_module(f"tests.your_turn.nb{path.name[:2]}")
    return module.FILLS


def _output_text(cell) -> str:
    return "".join(o.get("text", "") for o in cell.get("outputs", []) if o.get("output_type") == "stream")


def _run_your_turn(client, nb, stub: int, check: int, fill) -> None:
    """Mistake (check fails with the hint), correct fill (check passes), then the stub as shipped."""
    shipped = nb.cells[stub].source
    cid = nb.cells[stub].get("id")
    try:
        nb.cells[stub].source = fill.mistake
        client.execute_cell(nb.cells[stub], stub)
        try:
            client.execute_cell(nb.cells[check], check)
        except CellExecutionError as exc:
            # the error's own name and message (str(exc) also holds the cell's source, hints included)
            name, message = exc.ename, _ANSI.sub("", exc.evalue)
            assert name == "YourTurnError" and fill.hint in message, (
                f"cell {cid}: the planted mistake failed the check with {name}: {message[-1500:]}, "
                f"not with YourTurnError and the hint {fill.hint!r}")
        else:
            raise AssertionError(f"cell {cid}: the check passed the planted mistake:\n{fill.mistake}")
        nb.cells[stub].source = fill.correct
        client.execute_cell(nb.cells[stub], stub)
        client.execute_cell(nb.cells[check], check)
        assert "well done" in _output_text(nb.cells[check]), (
            f"cell {cid}: the correct fill-in did not pass the check: {_output_text(nb.cells[check])!r}")
    finally:
        nb.cells[stub].source = shipped
    client.execute_cell(nb.cells[stub], stub)
    client.execute_cell(nb.cells[check], check)
    assert "not done yet" in _output_text(nb.cells[check]), (
        f"cell {cid}: with the stub as shipped the check should go on with labkit's version; "
        f"it printed {_output_text(nb.cells[check])!r}")


def run_notebook(nb, workdir: Path, kernel_name: str, fills: dict, *, to_the_end: bool = True) -> list[str]:
    """Run ``nb`` top to bottom, cell by cell; every "your turn" pair is tried three ways
    (:func:`_run_your_turn`) before the notebook goes on as shipped. With ``to_the_end=False`` the run
    stops after the last "your turn" check (the browser test runs every notebook to the end, twice).
    Returns its slow steps (cells, the kernel's start or stop, over ``SLOW_STEP_S``) as "cell 12: 45 s"."""
    pairs = dict(your_turn_pairs(nb))
    checks = set(pairs.values())
    last = len(nb.cells) - 1 if to_the_end or not checks else max(checks)
    missing = [nb.cells[i].get("id") for i in pairs if nb.cells[i].get("id") not in fills]
    assert not missing, f"your-turn cells without a fill-in in tests/your_turn/: {missing}"
    client = NotebookClient(nb, timeout=CELL_TIMEOUT_S, kernel_name=kernel_name,
                            resources={"metadata": {"path": str(workdir)}})
    steps = _timed(client)
    started = time.monotonic()
    with client.setup_kernel():
        sliced_waits(client.kc)
        steps.append(("kernel start", time.monotonic() - started))
        for i, cell in enumerate(nb.cells[:last + 1]):
            if i in checks:
                continue  # run with its stub
            if i in pairs:
                _run_your_turn(client, nb, i, pairs[i], fills[cell.get("id")])
                continue
            client.execute_cell(cell, i)
        stopping = time.monotonic()
    steps.append(("kernel stop", time.monotonic() - stopping))
    return [f"{step}: {seconds:.0f} s" for step, seconds in steps if seconds > SLOW_STEP_S]


def _timed(client) -> list[tuple[str, float]]:
    """Time every ``client.execute_cell`` call: ("cell N", seconds) appended to the list returned."""
    steps, execute = [], client.execute_cell

    def execute_cell(cell, index, *args, **kwargs):
        started = time.monotonic()
        try:
            return execute(cell, index, *args, **kwargs)
        finally:
            steps.append((f"cell {index}", time.monotonic() - started))

    client.execute_cell = execute_cell
    return steps


TRIED = [p for p in NOTEBOOKS if your_turn_pairs(nbformat.read(p, as_version=4))]


@pytest.mark.slow
@pytest.mark.parametrize("path", TRIED, ids=[p.name for p in TRIED])
def test_your_turn_trials(path, this_python_kernel, tmp_path, monkeypatch, record_property):
    """Every "your turn" check fails a planted mistake with its hint and passes a correct fill-in
    (tests/your_turn/), and the notebook goes on with the stub as shipped: the notebook runs as shipped,
    cell by cell, up to its last check. (Every notebook runs to the end, twice, as shipped, in
    tests/test_browser.py.) Its slow steps are listed at the end of the run (conftest's ``slow_steps``):
    a notebook that takes 10 s alone once took 300 s in the full suite without failing."""
    if SHARED_DATASETS.is_dir():  # the notebooks' real-data sections run too (they skip without it)
        monkeypatch.setenv("LABKIT_SHARED_DATASETS", str(SHARED_DATASETS.resolve()))
    nb = nbformat.read(path, as_version=4)
    workdir = tmp_path / "cwd"
    workdir.mkdir()
    try:
        record_property("slow_steps", run_notebook(nb, workdir, this_python_kernel, _fills(path), to_the_end=False))
        return
    except (CellExecutionError, CellTimeoutError, DeadKernelError, AssertionError) as exc:
        error = f"{type(exc).__name__}: {_ANSI.sub('', str(exc))}"
    executed = tmp_path / path.name  # outside the except block: the report shows the error once
    nbformat.write(nb, executed)
    pytest.fail(f"{_rel(path)} failed; executed copy in {executed}\n\n{error}", pytrace=False)


#: Lessons split off a longer one that kept its own your-turn cells: one your-turn cell of their own is enough.
ONE_YOUR_TURN = {"08b_legs.ipynb": 1, "09b_configurations_and_cli.ipynb": 1}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_your_turn_cells(path):
    """Every lesson after the tour has at least two "your turn" cells (one in :data:`ONE_YOUR_TURN`), each
    with its check and a fill-in (a correct one and a planted mistake) in tests/your_turn/."""
    nb = nbformat.read(path, as_version=4)
    pairs = your_turn_pairs(nb)
    if path.name.startswith("00_"):
        return
    least = ONE_YOUR_TURN.get(path.name, 2)
    assert len(pairs) >= least, f"{_rel(path)} has {len(pairs)} your-turn cells; it needs {least}"
    fills = _fills(path)
    for stub, _ in pairs:
        cell = nb.cells[stub]
        assert "NotImplementedError" in cell.source, f"{_rel(path)} cell {cell.get('id')}: the stub must raise it"
        assert cell.get("id") in fills, f"{_rel(path)} cell {cell.get('id')} has no fill-in in tests/your_turn/"


# ---------------------------------------------------------------------------- a notebook a student finishes
MAX_CELLS, MAX_WORDS = 46, 3000  # issue 34: "at most ~45 cells and ~3,000 words" of prose
MAX_CODE_LINES = 10  # issue 34: "plotting goes to `labkit.viz` so a code cell is 3-10 lines"
#: Notebooks not yet split to the limits: (cells, words) as they stand, which may shrink and never grow.
OVER_THE_LIMIT: dict[str, tuple[int, int]] = {}


def _markdown_words(nb) -> int:
    return sum(len(c.source.split()) for c in nb.cells if c.cell_type == "markdown")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_a_notebook_a_student_finishes(path):
    """A numbered title, one objective in one sentence right under it, "What you should now be able to do"
    at the end, and a size a student gets through (issue 34, item 3)."""
    nb = nbformat.read(path, as_version=4)
    number = re.match(r"(\d\d[a-z]?)_", path.name).group(1)
    lines = [line for line in nb.cells[0].source.splitlines() if line.strip()]
    assert nb.cells[0].cell_type == "markdown" and lines[0].startswith(f"# {number} · "), (
        f"{_rel(path)}: the first cell must start with the numbered title '# {number} · ...', not {lines[0]!r}")
    objective = lines[1]
    assert objective.startswith("**Objective:** ") and objective.endswith(".") and ". " not in objective, (
        f"{_rel(path)}: the title must be followed by one objective in one sentence, '**Objective:** ...', "
        f"not {objective!r}")
    last = [c for c in nb.cells if c.cell_type == "markdown"][-1].source
    assert "## What you should now be able to do" in last, (
        f"{_rel(path)}: no 'What you should now be able to do' at the end")
    max_cells, max_words = OVER_THE_LIMIT.get(path.name, (MAX_CELLS, MAX_WORDS))
    assert len(nb.cells) <= max_cells and _markdown_words(nb) <= max_words, (
        f"{_rel(path)}: {len(nb.cells)} cells and {_markdown_words(nb)} words of prose, more than {max_cells} "
        f"and {max_words}: split it by topic or tighten it")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_code_cells_a_student_reads(path):
    """No code cell is longer than :data:`MAX_CODE_LINES` non-empty lines (issue 34, item 3): drawing goes to
    ``labkit.viz``, printouts and bookkeeping to ``labkit.course_reports``, imports are grouped."""
    nb = nbformat.read(path, as_version=4)
    long = [(c.get("id"), n) for _, c in _code_cells(nb)
            if (n := sum(1 for line in c.source.splitlines() if line.strip())) > MAX_CODE_LINES]
    assert not long, f"{_rel(path)}: code cells (id, non-empty lines) over {MAX_CODE_LINES} lines: {long}"


# ---------------------------------------------------------------------------- stored clean
@pytest.mark.parametrize("path", STORED, ids=[_rel(p) for p in STORED])
def test_stored_without_outputs(path):
    nb = nbformat.read(path, as_version=nbformat.NO_CONVERT)
    assert nb.nbformat == 4, f"{_rel(path)} is nbformat {nb.nbformat}, expected 4"
    nbformat.validate(nb)  # raises ValidationError naming the offending field
    dirty = [i for i, c in _code_cells(nb) if c.outputs or c.execution_count is not None]
    assert not dirty, (f"{_rel(path)}: code cells {dirty} have outputs or an execution count; clear them "
                       "(e.g. `jupyter nbconvert --clear-output --inplace`) before committing")
    assert "widgets" not in nb.metadata, f"{_rel(path)} stores widget state (an output): clear it"


@pytest.mark.parametrize("path", STORED, ids=[_rel(p) for p in STORED])
def test_no_sys_path_tricks(path):
    nb = nbformat.read(path, as_version=4)
    found = [(i, line.strip()) for i, c in _code_cells(nb) for line in c.source.splitlines()
             if _PATH_TRICK.search(line)]
    assert not found, (f"{_rel(path)} manipulates the import path (STYLE.md item 1: `import labkit` "
                       f"from the installed package): {found}")
