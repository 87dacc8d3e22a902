"""``labkit view`` of a long recording in flat memory (issue 30): what grows with the recording is the
``.rrd`` footer, a list of every chunk that rerun keeps in memory until the file is closed, so
``record_scans`` writes few chunks per scan; and gathering the columns into chunks loses, reorders or
changes nothing. The memory itself is measured in ``benchmarks/io.py`` (minutes, not seconds)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import rerun as rr

from labkit import Scan, sim
from labkit.pipeline import Config
from labkit.sim import GroundTruth
from labkit.viz import rr as lkrr
from tests.test_rr import _batches

BIN = Path(sys.executable).parent


def _chunks(path) -> Counter:
    """{entity path: chunks on the scan timeline}, read back from the file."""
    from rerun.chunk import RrdReader

    return Counter(c.entity_path for c in RrdReader(path).store().stream() if not c.is_static)


def _long_recording(n: int):
    """``n`` scans of 41 beams (every 13th of the simulated hall's), with a pose each and the simulator's
    truth: every kind of entity ``labkit view`` writes, fast."""
    base = list(sim.simulate("hall", seed=0, n_scans=50))
    scans, truths = [], []
    for k in range(n):
        scan, truth = base[k % len(base)]
        stamp = 1_000_000_000 + k * 40_000_000
        scans.append(Scan(ranges=scan.ranges[::13], angles=scan.angles[::13], range_max=scan.range_max, stamp_ns=stamp,
                          pose=(0.01 * k, 0.0, 0.0)))
        truths.append(dataclasses.replace(truth, stamp_ns=stamp))
    return scans, truths


def test_a_long_recording_writes_few_chunks_and_every_scan(tmp_path):
    """rerun 0.41 keeps about 5 KiB of footer per chunk in memory until the file is closed (measured:
    ``benchmarks/io.py``; in a labkit recording of 541-beam scans, 1.4-1.9 KiB per scan at one chunk per
    entity per batch of 128 scans, some 0.3 chunks per scan). The goal, <= 300 MB at 100,000 scans, leaves
    the footer a few tens of MB: at most 0.05 more chunks per scan, beyond each entity's first (25 MiB at
    100,000 scans). Before the chunks were gathered, this recording had 0.29."""
    n = 600
    scans, truths = _long_recording(n)
    out = tmp_path / "long.rrd"
    truth = GroundTruth({}, {t.stamp_ns: t for t in truths})
    summary = lkrr.record_scans(scans, out, name="long", truth=truth, config=Config())
    assert (summary.n_scans, summary.n_truth) == (n, n)
    chunks = _chunks(out)
    assert len(chunks) >= 30, chunks  # the map, features, counts, times and truth are all there
    assert (sum(chunks.values()) - len(chunks)) / n <= 0.05, chunks  # the chunks that come with more scans
    # every scan, in its place: the valid beams of scan k are those of the k-th scan given
    valid = _batches(out, "/metrics/valid_beams")
    assert sorted(valid) == list(range(n))
    assert [valid[k]["Scalars:scalars"][0] for k in range(n)] == [float(s.valid.sum()) for s in scans]
    points = _batches(out, "/world/scan/points")
    for k in (0, 127, 128, 511, 512, n - 1):  # batch boundaries
        np.testing.assert_allclose(np.array(points[k]["Points2D:positions"]), scans[k].xy, rtol=1e-6, atol=1e-6)
    walls = _batches(out, "/world/truth/walls")
    assert sorted(walls) == list(range(n))
    assert all(len(walls[k]["LineStrips2D:labels"]) == len(truths[k].walls) for k in range(0, n, 99))
    p = subprocess.run([str(BIN / "rerun"), "rrd", "verify", str(out)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr


def test_gathered_columns_keep_every_row_when_the_columns_change(tmp_path):
    """An entity whose columns change between two sends (labels, then none) is written as it was sent;
    a static send and heavy columns go out at once, and flush sends what waits."""
    from labkit.viz.rr.entities import _Chunked

    rec = rr.RecordingStream("test")
    rec.save(tmp_path / "c.rrd")
    chunked = _Chunked(rec)

    def send(first: int, n: int, labels: bool, k: int = 2) -> None:
        idx = np.arange(first, first + n)
        pos = np.column_stack([idx.repeat(k), np.zeros(n * k)])
        cols = rr.Points2D.columns(positions=pos, labels=[f"p{i}" for i in idx.repeat(k)]) if labels else \
            rr.Points2D.columns(positions=pos)
        chunked.send_columns("e", indexes=[rr.TimeColumn("scan", sequence=idx)], columns=cols.partition([k] * n))

    send(0, 10, True)
    send(10, 5, True)
    send(15, 7, False)
    send(22, 3, True)
    big = _Chunked.CHUNK_BYTES // 8  # points of 8 bytes: one send of this many goes out at once
    send(25, 2, False, k=big)
    assert "e" not in chunked._pending
    chunked.send_columns("s", indexes=[], columns=rr.Points2D.columns(positions=[[1.0, 2.0]]))  # static
    send(27, 4, True)
    chunked.flush()
    rec.disconnect()
    rows = _batches(tmp_path / "c.rrd", "/e")
    assert sorted(rows) == list(range(31))
    for k, row in rows.items():
        n_points = big if k in (25, 26) else 2
        assert [p[0] for p in row["Points2D:positions"]] == [float(k)] * n_points, k
        assert (row.get("Points2D:labels") is not None) == (k < 15 or 22 <= k < 25 or k >= 27), k
    assert _chunks(tmp_path / "c.rrd")["/e"] == 5  # 0-14 together, 15-21, 22-24, 25-26, 27-30
