"""The cluster path against real ``dask scheduler`` and ``dask worker`` processes, as the README
tells a researcher to start them: on 127.0.0.1 (random free ports), the workers in working
folders of their own, not the client's.

- Relative and absolute paths give the serial run's output, in the client's folder, and nothing
  lands in a worker's folder.
- A worker that cannot see an input (a worker started in its own mount namespace, with an empty
  tmpfs over the input folder) makes that recording an error of its own; a run in which no
  recording could be read writes nothing.
- An output a worker writes where the client cannot see it is an error, not "done".

The namespace tests need ``unshare --user --mount`` (skipped with the reason where it is refused).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from labkit import read_table
from labkit.app import parallel
from labkit.app.data import write_simulation

BIN = Path(sys.executable).parent
LABKIT = [str(BIN / "labkit")]
DASK = BIN / "dask"

pytestmark = pytest.mark.skipif(not DASK.exists(), reason="the dask command line (dask[distributed]) is not installed")


class Cluster:
    """A scheduler and workers, each a process group of its own, torn down in :meth:`close`."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        folder.mkdir(exist_ok=True)
        self.procs: list[subprocess.Popen] = []
        self.file = folder / "scheduler.json"
        self._start([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(self.file)], folder, "scheduler")
        deadline = time.monotonic() + 60
        while not (self.file.exists() and self.file.stat().st_size) and time.monotonic() < deadline:
            time.sleep(0.05)
        self.address = json.loads(self.file.read_text())["address"]

    def _start(self, argv: list[str], cwd: Path, name: str) -> None:
        log = open(self.folder / f"{name}.log", "wb")  # noqa: SIM115 - closed with the process
        self.procs.append(subprocess.Popen(argv, cwd=cwd, stdout=log, stderr=subprocess.STDOUT,
                                           start_new_session=True))
        log.close()

    def worker(self, cwd: Path, hide: tuple[Path, ...] = ()) -> None:
        """A worker (one thread, no nanny) in ``cwd``; ``hide``: folders it sees as empty."""
        argv = [str(DASK), "worker", "--scheduler-file", str(self.file), "--nthreads", "1", "--no-nanny",
                "--host", "127.0.0.1", "--no-dashboard"]
        if hide:
            mounts = " && ".join(f"mount -t tmpfs -o size=16m none '{h}'" for h in hide)
            argv = ["unshare", "--user", "--map-root-user", "--mount", "sh", "-c",
                    f"{mounts} && exec {' '.join(argv)}"]
        cwd.mkdir(exist_ok=True)
        self._start(argv, cwd, f"worker-{len(self.procs)}")

    def wait_for(self, n: int) -> None:
        from distributed import Client

        with Client(self.address, timeout="30s") as client:
            client.wait_for_workers(n, timeout=60)

    def close(self) -> None:
        for p in reversed(self.procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in self.procs:  # a worker's graceful shutdown can take 20 s; nothing of theirs needs keeping
            try:
                p.wait(timeout=3)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=20)


def _unshare_works() -> bool:
    if not shutil.which("unshare"):
        return False
    probe = subprocess.run(["unshare", "--user", "--map-root-user", "--mount", "sh", "-c",
                            "mount -t tmpfs none /mnt && echo ok"], capture_output=True, text=True, timeout=30)
    return probe.stdout.strip() == "ok"


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """Two small recordings under ``client/logs``, the client's working folder, and the folders
    the cluster tests hide from a worker (``hidden_in`` holds a recording, ``hidden_out`` is empty)."""
    root = tmp_path_factory.mktemp("site")
    client = root / "client"
    for name, world, seed in (("a.bag", "hall", 1), ("b.bag", "office", 2)):
        write_simulation(world, client / "logs" / name, "ros1", seed=seed, n_scans=15)
    write_simulation("corridor", root / "hidden_in" / "c.bag", "ros1", seed=3, n_scans=15)
    (root / "hidden_out").mkdir()
    return root


@pytest.fixture(scope="module")
def cluster(site):
    """A scheduler and two workers, each in a working folder that is not the client's."""
    c = Cluster(site)
    try:
        for k in (1, 2):
            c.worker(site / f"worker{k}")
        c.wait_for(2)
        yield c
    finally:
        c.close()


def labkit_cli(*args, cwd: Path):
    p = subprocess.run([*LABKIT, "-q", *map(str, args)], capture_output=True, text=True, timeout=180, cwd=cwd)
    assert "Traceback" not in p.stderr, p.stderr
    return p


def _records(path: Path) -> list[dict]:
    return [{k: v for k, v in json.loads(line).items() if k != "timings_ms"} for line in path.read_text().splitlines()]


def _left_in(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if not p.name.endswith(".log"))


def test_relative_paths_give_the_serial_table_in_the_clients_folder(site, cluster):
    client = site / "client"
    p = labkit_cli("extract", "logs/a.bag", "logs/b.bag", "-o", "rel.parquet", "--scheduler", cluster.address,
                   cwd=client)
    assert p.returncode == 0, p.stderr
    assert "from 2 recordings" in p.stdout
    serial = site / "serial.parquet"
    parallel.extract_many([client / "logs" / "a.bag", client / "logs" / "b.bag"], serial, workers=0)
    on_cluster, serial = read_table(client / "rel.parquet"), read_table(serial)
    assert len(serial) > 0 and sorted(serial.recording.unique()) == ["a.bag", "b.bag"]
    pd.testing.assert_frame_equal(on_cluster, serial)
    for k in (1, 2):  # nothing was written where the workers run
        assert _left_in(site / f"worker{k}") == []
    assert sorted(x.name for x in client.iterdir()) == ["logs", "rel.parquet"]


def test_absolute_inputs_and_a_relative_output_folder(site, cluster, monkeypatch):
    client = site / "client"
    logs = (client / "logs").resolve()
    monkeypatch.chdir(client)
    results = parallel.extract_many([logs / "a.bag", logs / "b.bag"], "outdir", scheduler=cluster.address)
    assert [r.status for r in results] == ["done", "done"]
    assert [r.output for r in results] == [str(client / "outdir" / f"{n}.features.jsonl") for n in "ab"]
    serial = site / "serial-out"
    parallel.extract_many([logs / "a.bag", logs / "b.bag"], serial, workers=0)
    assert sorted(x.name for x in (client / "outdir").iterdir()) == ["a.features.jsonl", "b.features.jsonl"]
    for name in ("a.features.jsonl", "b.features.jsonl"):
        assert _records(client / "outdir" / name) == _records(serial / name)
    for k in (1, 2):
        assert _left_in(site / f"worker{k}") == []


@pytest.fixture(scope="module")
def blind(site):
    """A scheduler and one worker that sees ``hidden_in`` and ``hidden_out`` as empty folders."""
    if not _unshare_works():
        pytest.skip("unshare --user --mount is refused here: a worker blind to a folder cannot be made")
    c = Cluster(site / "blind")
    try:
        c.worker(site / "blind" / "worker", hide=(site / "hidden_in", site / "hidden_out"))
        c.wait_for(1)
        yield c
    finally:
        c.close()


def test_a_run_whose_worker_sees_no_input_writes_nothing(site, blind):
    client = site / "client"
    c = site / "hidden_in" / "c.bag"
    p = labkit_cli("extract", c, "-o", "blind.parquet", "--scheduler", blind.address, cwd=client)
    assert p.returncode == 2, p.stderr
    assert f"{c}: no such file or folder on the Dask worker tcp://127.0.0.1:" in p.stderr
    assert not (client / "blind.parquet").exists()
    results = parallel.extract_many([c], client / "blind-out", scheduler=blind.address)
    assert [r.status for r in results] == ["refused"] and "on the Dask worker" in results[0].error
    assert not (client / "blind-out").exists()
    assert [x for x in client.iterdir() if x.name.startswith(".")] == []


def test_an_input_one_worker_cannot_see_is_an_error_of_its_own(site, blind):
    client = site / "client"
    results = parallel.extract_many([client / "logs" / "a.bag", site / "hidden_in" / "c.bag"], client / "mixed.parquet",
                                    scheduler=blind.address)
    assert [r.status for r in results] == ["done", "refused"]
    assert "c.bag: no such file or folder on the Dask worker" in results[1].error
    table = read_table(client / "mixed.parquet")
    assert table.recording.unique().tolist() == ["a.bag"] and len(table) > 0


def test_an_output_the_client_cannot_see_is_not_done(site, blind):
    out = site / "hidden_out"
    p = labkit_cli("extract", "logs/a.bag", "logs/b.bag", "-o", out / "t.parquet", "--scheduler", blind.address,
                   cwd=site / "client")
    assert p.returncode == 3, p.stderr
    assert "this machine does not see it" in p.stderr
    assert list(out.iterdir()) == []
    results = parallel.extract_many([site / "client" / "logs" / "a.bag"], out / "per-input", scheduler=blind.address)
    assert [r.status for r in results] == ["system"] and "this machine does not see it" in results[0].error
    assert list(out.iterdir()) == []
