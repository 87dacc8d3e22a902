"""The course notebooks with their outputs, for the docs, without running them twice.

The notebooks are stored without outputs (STYLE.md item 11); the tests execute every one of them
(tests/test_notebooks.py). That run keeps its executed copy here, keyed on the notebook as stored
(the SHA-256 of its bytes), so the docs render those outputs instead of running the course again:
``docs/_build/executed/<stem>.<key>.ipynb``. A notebook whose copy is missing or older than its
source (edited since the tests ran) is executed by the docs build itself, once, and kept the same way.
The outputs follow the notebook's source, not labkit's: after a change to the library alone, run the
notebook tests (or delete ``docs/_build/executed/``) to refresh them; ``make test`` always does.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
STORE = REPO / "docs" / "_build" / "executed"
SHARED_DATASETS = REPO.parent / "shared" / "datasets"


def key(notebook: Path) -> str:
    """The key of a stored notebook: the first 16 hex digits of the SHA-256 of its bytes."""
    return hashlib.sha256(Path(notebook).read_bytes()).hexdigest()[:16]


def stored(notebook: Path) -> Path:
    """Where the executed copy of ``notebook`` as it is now is kept (whether or not it exists)."""
    notebook = Path(notebook)
    return STORE / f"{notebook.stem}.{key(notebook)}.ipynb"


def keep(notebook: Path, executed) -> Path:
    """Keep ``executed`` (a ``nbformat.NotebookNode``, run top to bottom) as the copy of ``notebook``.

    Written under a temporary name, then renamed: a reader never sees half a notebook, and two
    processes keeping the same notebook at once leave one whole copy. Older copies of the same
    notebook are removed.
    """
    import nbformat

    target = stored(notebook)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=".tmp", dir=target.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as out:
        nbformat.write(executed, out)
    os.replace(tmp, target)
    for old in target.parent.glob(f"{Path(notebook).stem}.*.ipynb"):
        if old != target:
            old.unlink(missing_ok=True)
    return target


def execute(notebook: Path, *, timeout_s: int = 600) -> Path:
    """Run ``notebook`` top to bottom in a fresh kernel of this interpreter, in a temporary folder, and
    keep it (:func:`keep`). Raises nbclient's ``CellExecutionError`` when a cell fails."""
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(notebook, as_version=4)
    env_before = os.environ.get("LABKIT_SHARED_DATASETS")
    if SHARED_DATASETS.is_dir() and env_before is None:
        os.environ["LABKIT_SHARED_DATASETS"] = str(SHARED_DATASETS)
    try:
        with tempfile.TemporaryDirectory(prefix="labkit-docs-") as cwd:
            client = NotebookClient(nb, timeout=timeout_s, kernel_name="python3", resources={"metadata": {"path": cwd}})
            with client.setup_kernel():
                sliced_waits(client.kc)
                for index, cell in enumerate(nb.cells):
                    client.execute_cell(cell, index)
    finally:
        if env_before is None:
            os.environ.pop("LABKIT_SHARED_DATASETS", None)
    return keep(notebook, nb)


POLL_SLICE_S = 2.0


def sliced_waits(kc) -> None:
    """Wait for each kernel message in slices of at most ``POLL_SLICE_S`` seconds.

    pyzmq's asyncio poll can miss a socket's wake-up and then sleeps for the whole timeout it was
    given: nbclient passes a cell's whole timeout, so a missed wake-up costs that (10 minutes here)
    although the reply is there (tests/test_notebooks.py met it and does the same). The total wait
    and what happens when it runs out are nbclient's as before."""
    import queue
    import time

    for channel in (kc.shell_channel, kc.iopub_channel):
        async def get_msg(timeout=None, *, _get=channel.get_msg):
            deadline = None if timeout is None else time.monotonic() + timeout
            while True:
                left = POLL_SLICE_S if deadline is None else deadline - time.monotonic()
                try:
                    return await _get(timeout=max(0.0, min(POLL_SLICE_S, left)))
                except queue.Empty:
                    if deadline is not None and time.monotonic() >= deadline:
                        raise

        channel.get_msg = get_msg
