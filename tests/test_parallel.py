"""Many recordings on Dask (labkit.app.parallel): the same results as the serial run, one output per
input or one table, a damaged recording reported while the others finish, refusals before
anything runs, and Ctrl-C that leaves only finished outputs and valid partials.

One local cluster (two worker processes) serves the whole module; the command line is tested
against it through --scheduler, and once with its own cluster (--workers 2)."""

from __future__ import annotations

import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import labkit
from labkit import sim, write_bag
from labkit.app import parallel
from labkit.app.data import write_simulation

LABKIT = [str(Path(sys.executable).parent / "labkit")]


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """Five recordings in three formats, one of them cut short."""
    d = tmp_path_factory.mktemp("recordings")
    for name, world, fmt, n in (("a.bag", "hall", "ros1", 40), ("b.mcap", "corridor", "mcap", 50),
                                ("c", "office", "ros2", 30), ("d.bag", "office", "ros1", 25)):
        write_simulation(world, d / name, fmt, seed=len(name) + n, n_scans=n)
    scans = [s for s, _ in sim.simulate("hall", seed=9, n_scans=40)]
    write_bag(scans, d / "e-cut.bag")
    cut = d / "e-cut.bag"
    cut.write_bytes(cut.read_bytes()[: cut.stat().st_size // 2])
    (d / "notes.txt").write_text("not a recording")
    return d


def labkit_cli(*args, **kw):
    p = subprocess.run([*LABKIT, "-q", *map(str, args)], capture_output=True, text=True, timeout=300, **kw)
    assert "Traceback" not in p.stderr, p.stderr
    return p


def test_the_folder_holds_the_recordings(recordings):
    names = [p.name for p in parallel.recordings_in([recordings])]
    assert names == ["a.bag", "b.mcap", "c", "d.bag", "e-cut.bag"]  # not the truth files, not notes.txt


def test_one_table_on_dask_is_the_serial_table(recordings, client, tmp_path):
    on_dask = parallel.extract_many([recordings], tmp_path / "dask.parquet", client=client)
    serial = parallel.extract_many([recordings], tmp_path / "serial.parquet", workers=0)
    assert [r.status for r in on_dask] == [r.status for r in serial] == ["done"] * 4 + ["damaged"]
    assert len({r.worker for r in on_dask}) == 2 and {r.worker for r in serial} == {"local"}
    a, b = labkit.read_table(tmp_path / "dask.parquet"), labkit.read_table(tmp_path / "serial.parquet")
    pd.testing.assert_frame_equal(a, b)
    assert (tmp_path / "dask.parquet").read_bytes() == (tmp_path / "serial.parquet").read_bytes()
    # and both are what the API gives, recording by recording, concatenated in input order
    parts = []
    for p in parallel.recordings_in([recordings]):
        scans = []
        try:
            scans.extend(labkit.read_scans(p))
        except labkit.CorruptFileError:
            pass
        parts.append(labkit.features_table(labkit.extract_all(scans), scans, recording=p.name, method="iepf"))
    pd.testing.assert_frame_equal(a, pd.concat(parts, ignore_index=True))
    assert a.recording.unique().tolist() == ["a.bag", "b.mcap", "c", "d.bag", "e-cut.bag"]
    assert a.world_x.notna().all()  # the simulator's bags carry their poses


def _records(path: Path) -> list[dict]:
    out = []
    for line in path.read_text().splitlines():
        record = json.loads(line)
        record.pop("timings_ms")  # seconds differ from run to run
        out.append(record)
    return out


def test_one_output_per_input_on_dask_is_the_serial_output(recordings, client, tmp_path):
    on_dask = parallel.extract_many([recordings], tmp_path / "dask", client=client)
    serial = parallel.extract_many([recordings], tmp_path / "serial", workers=0)
    for r, s in zip(on_dask, serial, strict=True):
        assert Path(r.output).name == Path(s.output).name and Path(r.output).suffix == ".jsonl"
        assert _records(Path(r.output)) == _records(Path(s.output))
        assert (r.n_scans, r.counts) == (s.n_scans, s.counts)
    damaged = on_dask[-1]
    assert damaged.status == "damaged" and "e-cut.bag is damaged" in damaged.error
    assert 10 < damaged.n_scans < 40 and len(_records(Path(damaged.output))) == damaged.n_scans
    assert parallel.report(on_dask, file=io.StringIO()) == 1
    assert sorted(p.name for p in (tmp_path / "dask").iterdir()) == [
        "a.features.jsonl", "b.features.jsonl", "c.features.jsonl", "d.features.jsonl", "e-cut.features.jsonl"]


def test_evaluate_on_dask_gives_the_serial_rows(recordings, client):
    from labkit.app.experiments import LINE_EXTRACTORS

    extractors = {k: LINE_EXTRACTORS[k] for k in ("incremental", "RANSAC")}
    on_dask = parallel.evaluate_many([recordings], extractors, n_scans=15, client=client)
    serial = parallel.evaluate_many([recordings], extractors, n_scans=15, workers=0)

    def rows(results):
        return [{k: v for k, v in row.items() if k != "scans_per_s"} for r in results for row in r.rows]

    assert rows(on_dask) == rows(serial) and len(rows(serial)) == 10
    # 15 scans lie before the cut, but the bag's one chunk says at its header that it runs past the
    # file's end: the walker knows the file is damaged before its first scan, and says so
    assert [r.status for r in on_dask] == [r.status for r in serial] == ["done"] * 4 + ["damaged"]
    assert "e-cut.bag is damaged" in on_dask[-1].error and on_dask[-1].n_scans == 15


def test_cli_on_an_existing_scheduler_and_on_its_own_cluster(recordings, client, tmp_path):
    p = labkit_cli("extract", recordings, "-o", tmp_path / "s.parquet", "--scheduler", client.scheduler.address)
    assert p.returncode == 1 and "e-cut.bag is damaged" in p.stderr, p.stderr  # one damaged recording: status 1
    assert "from 5 recordings" in p.stdout and "the Dask scheduler at tcp://" in p.stdout
    assert len([ln for ln in p.stderr.splitlines() if ln.startswith("labkit: error:")]) == 1
    good = [recordings / n for n in ("a.bag", "b.mcap", "c")]
    p = labkit_cli("extract", *good, "-o", tmp_path / "own", "--workers", "2")
    assert p.returncode == 0 and "a local Dask cluster of 2 workers" in p.stdout, p.stderr
    serial = parallel.extract_many(good, tmp_path / "serial", workers=0)
    for r in serial:
        assert _records(tmp_path / "own" / Path(r.output).name) == _records(Path(r.output))
    p = labkit_cli("evaluate", *good, "--scans", "5", "--method", "incremental", "--scheduler",
                   client.scheduler.address)
    assert p.returncode == 0 and all(f"| {g.name} | incremental |" in p.stdout for g in good)


def test_refusals_come_before_anything_runs(recordings, tmp_path):
    bags = [recordings / "a.bag", recordings / "d.bag"]
    p = labkit_cli("extract", *bags, "-o", tmp_path / "x.jsonl")
    assert p.returncode == 2 and "need -o FOLDER" in p.stderr
    p = labkit_cli("extract", *bags, recordings / "notes.txt", "-o", tmp_path / "out")
    assert p.returncode == 2 and "supported formats" in p.stderr and not (tmp_path / "out").exists()
    p = labkit_cli("extract", *bags, "--topic", "/nothing", "-o", tmp_path / "out")
    assert p.returncode == 2 and "/nothing" in p.stderr and not (tmp_path / "out").exists()
    (tmp_path / "empty").mkdir()
    p = labkit_cli("extract", tmp_path / "empty", "-o", tmp_path / "out")
    assert p.returncode == 2 and "holds no recordings" in p.stderr
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "a.features.jsonl").write_text("mine\n")
    p = labkit_cli("extract", *bags, "-o", tmp_path / "out")
    assert p.returncode == 2 and "exists; pass -f" in p.stderr
    assert sorted(x.name for x in (tmp_path / "out").iterdir()) == ["a.features.jsonl"]


def _writing(out: Path) -> bool:
    """True while some recording's temporary output under ``out`` already holds records (a temporary
    folder can be renamed away while this looks, which counts as not yet)."""
    try:
        return any(f.is_file() and f.stat().st_size > 0 for tmp in out.glob(".*.labkit-*") for f in tmp.rglob("*"))
    except FileNotFoundError:
        return False


def test_ctrl_c_leaves_finished_outputs_and_valid_partials_only(tmp_path):
    """Ctrl-C in a terminal reaches the whole process group, the Dask workers included. It is sent
    while a recording is part-way written, so that one must come back as a valid partial; every other
    recording is finished (all its records) or was not started (and says so)."""
    n_scans = 1500
    inputs = tmp_path / "in"
    write_simulation("corridor", inputs / "c0.bag", "ros1", seed=0, n_scans=n_scans)
    for k in range(1, 4):  # four recordings (copies: what is read does not matter here, simulating took 10 s)
        shutil.copyfile(inputs / "c0.bag", inputs / f"c{k}.bag")
    out = tmp_path / "out"
    proc = subprocess.Popen([*LABKIT, "-q", "extract", inputs, "-o", out, "--workers", "2"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 120
    while not (out.is_dir() and _writing(out)) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.skip("the run finished before Ctrl-C arrived")
    assert proc.returncode == 130 and "Traceback" not in stderr, stderr
    left = sorted(p.name for p in out.iterdir())
    assert not [n for n in left if ".labkit-" in n], left  # no temporary output anywhere
    assert any(".partial." in n for n in left), (left, stderr)
    partial_records = []
    for k in range(4):
        mine = [n for n in left if n.startswith(f"c{k}.")]
        assert len(mine) <= 1, mine
        if not mine:  # not started: the summary names it
            assert f"c{k}.bag" in stderr and "nothing was written" in stderr, stderr
            continue
        records = [json.loads(line) for line in (out / mine[0]).read_text().splitlines()]  # each file is valid
        if ".partial." in mine[0]:
            # a recording the other worker had only just opened may hold no record yet
            assert len(records) < n_scans
            partial_records.append(len(records))
        else:
            assert len(records) == n_scans
    assert max(partial_records) > 0, partial_records  # the one that was part-way written kept its records


# ---------------------------------------------------------------------------- one long recording, every core
def test_split_ranges_cut_only_what_is_longer_than_its_share():
    # the Radish set on two workers: freiburg-079 (4,791 of 8,725 scans) is longer than its share, 4,362.5
    assert parallel.split_ranges([4791, 1941, 910, 440, 406, 237], 2) == [[(0, 2396), (2396, 4791)]] + [None] * 5
    assert parallel.split_ranges([1000, 10], 4, min_scans=100) == [[(0, 250), (250, 500), (500, 750), (750, 1000)],
                                                                   None]
    assert parallel.split_ranges([300] * 8, 2) == [None] * 8  # equal recordings: one task each, as before
    assert parallel.split_ranges([None, 5000], 2) == [None, [(0, 2500), (2500, 5000)]]  # unknown size: whole
    assert parallel.split_ranges([5000], 1) == [None]
    assert parallel.split_ranges([999], 2) == [None]  # two pieces would be shorter than MIN_PIECE_SCANS
    rng = np.random.default_rng(0)
    for _ in range(200):  # the ranges cover each recording exactly, in order, none shorter than min_scans
        sizes = rng.integers(1, 5000, rng.integers(1, 6)).tolist()
        workers, least = int(rng.integers(1, 9)), int(rng.integers(1, 300))
        for n, pieces in zip(sizes, parallel.split_ranges(sizes, workers, min_scans=least), strict=True):
            if pieces is None:
                continue
            assert pieces[0][0] == 0 and pieces[-1][1] == n
            assert all(a[1] == b[0] for a, b in zip(pieces, pieces[1:], strict=False))
            assert all(b - a >= least for a, b in pieces) and len(pieces) <= workers


@pytest.fixture
def long_log(tmp_path):
    """A CARMEN log of 200 scans whose line for scan 150 is malformed (written by the test), and two short bags."""
    from tests.test_scan_ranges import carmen_log

    log = carmen_log(tmp_path / "long.log", 200, bad_line=150)
    for name, world, n in (("p.bag", "hall", 25), ("q.bag", "office", 30)):
        write_simulation(world, tmp_path / name, "ros1", seed=n, n_scans=n)
    return [log, tmp_path / "p.bag", tmp_path / "q.bag"]


class _Steps:
    """A progress-bar factory that keeps the steps it was advanced by (one per task)."""

    def __init__(self) -> None:
        self.steps: list[int] = []

    def __call__(self, total, unit):
        outer = self

        class Bar:
            def update(self, n):
                outer.steps.append(n)

            def close(self):
                pass

        return Bar()


@pytest.mark.parametrize("strict", [False, True])
def test_a_split_recording_gives_the_serial_output_row_for_row(long_log, client, tmp_path, monkeypatch, strict):
    monkeypatch.setattr(parallel, "MIN_PIECE_SCANS", 50)
    bar = _Steps()
    on_dask = parallel.extract_many(long_log, tmp_path / "dask", client=client, strict=strict, progress=bar)
    serial = parallel.extract_many(long_log, tmp_path / "serial", workers=0, strict=strict)
    assert sorted(bar.steps) == [25, 30, 100, 100]  # the log of 200 ran as two ranges of 100
    for r, s in zip(on_dask, serial, strict=True):
        assert (r.status, r.error, r.n_scans, r.n_rows, r.counts) == (s.status, s.error, s.n_scans, s.n_rows, s.counts)
        assert _records(Path(r.output)) == _records(Path(s.output))
    assert on_dask[0].status == "damaged" and on_dask[0].n_scans == (150 if strict else 199)
    assert sorted(p.name for p in (tmp_path / "dask").iterdir()) == [
        "long.features.jsonl", "p.features.jsonl", "q.features.jsonl"]  # no parts left behind
    table, serial_table = tmp_path / "dask.parquet", tmp_path / "serial.parquet"
    parallel.extract_many(long_log, table, client=client, strict=strict, scans=slice(10, None))
    parallel.extract_many(long_log, serial_table, workers=0, strict=strict, scans=slice(10, None))
    a, b = labkit.read_table(table), labkit.read_table(serial_table)
    pd.testing.assert_frame_equal(a, b)
    assert a[a.recording == "long.log"].scan.min() >= 10 and len(a[a.recording == "long.log"]) > 0


def test_ctrl_c_keeps_what_the_ranges_of_a_split_recording_wrote(tmp_path, client, monkeypatch):
    """Ctrl-C (here: raised at the client when the first task finishes) while a split recording runs:
    its output is unchanged (not there), and what its ranges wrote is one partial file: the whole of
    the range that finished, and records equal to the pipeline's on the same scans."""
    from tests.test_scan_ranges import carmen_log

    monkeypatch.setattr(parallel, "MIN_PIECE_SCANS", 50)
    log = carmen_log(tmp_path / "long.log", 1000)  # two ranges of 500 (other.log, 300 scans, is not split)
    # The first range is quick (no valid beam) and the second slow (1441 beams a scan), so the interrupt at
    # the end of the first always finds the second running: with ranges of one speed the second was at times
    # done before it, and the recording whole (seen in make test).
    rng = np.random.default_rng(7)
    lines = log.read_text().splitlines()
    for i, k in enumerate(k for k, line in enumerate(lines) if line.startswith("FLASER")):
        words = lines[k].split()
        readings = ["0.000"] * 180 if i < 500 else [f"{r:.3f}" for r in rng.uniform(0.5, 8.0, 1441)]
        lines[k] = " ".join(["FLASER", str(len(readings)), *readings, *words[182:]])
    log.write_text("\n".join(lines) + "\n")
    other = carmen_log(tmp_path / "other.log", 300, seed=1)

    def interrupting(total, unit):
        class Bar:
            def update(self, n):
                if n == 500:  # a range of long.log (other.log's 300 may finish first)
                    raise KeyboardInterrupt

            def close(self):
                pass

        return Bar()

    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt) as info:  # when the first range of long.log is done
        parallel.extract_many([log, other], out, client=client, progress=interrupting)
    results = info.value.results
    assert results[0].status == "interrupted", results[0]
    left = sorted(p.name for p in out.iterdir())
    assert "long.features.jsonl" not in left and not [n for n in left if ".labkit-" in n], left
    partial = Path(results[0].output)
    assert partial.parent == out and partial.name.startswith("long.") and ".partial." in partial.name
    kept = {r["scan"]: r for r in _records(partial)}
    assert set(range(500)) <= set(kept) or set(range(500, 1000)) <= set(kept), sorted(kept)
    scans = list(labkit.read_scans(log))
    for k in list(kept)[::25]:
        record = {"scan": k, **labkit.extract_features(scans[k]).as_record()}
        record.pop("timings_ms")
        assert json.loads(json.dumps(labkit.io.feature_files.json_safe(record))) == kept[k]
