"""rerun recordings: read the .rrd back and check entities, timelines and scan counts."""

from __future__ import annotations

import os
from collections import defaultdict

import numpy as np
import pytest

from labkit import sim, write_bag
from labkit.data import write_simulation
from labkit.viz import rr as lkrr


def rrd_rows(path):
    """{entity path: (rows on the scan timeline, timelines)} from an .rrd file."""
    from rerun.chunk import RrdReader

    rows, timelines = defaultdict(int), {}
    for chunk in RrdReader(path).store().stream():
        if chunk.is_static:
            rows[chunk.entity_path] += 0
            timelines[chunk.entity_path] = set()
            continue
        rows[chunk.entity_path] += chunk.num_rows
        timelines[chunk.entity_path] = set(chunk.timeline_names)
    return rows, timelines


def test_importing_sets_the_offline_asset_mode():
    assert os.environ["RERUN_NOTEBOOK_ASSET"] == "serve-local"


def test_record_a_simulated_bag_with_truth(tmp_path):
    bag, _, n = write_simulation("hall", tmp_path / "hall.bag", n_scans=30)
    summary = lkrr.record(bag, tmp_path / "hall.rrd")
    assert (summary.n_scans, summary.n_truth, summary.error) == (30, 30, None)
    rows, timelines = rrd_rows(tmp_path / "hall.rrd")
    for entity in ["/world/scan/points", "/world/scan/invalid", "/world/segments", "/metrics/valid_beams",
                   "/metrics/segments", "/world/truth/walls", "/world/truth/circles", "/world/truth/legs"]:
        assert rows[entity] == 30, entity
        assert {"ros_time", "scan"} <= timelines[entity]
    assert "log_time" not in timelines["/world/scan/points"]
    for static in ["/world", "/world/sensor", "/description"]:
        assert static in rows and timelines[static] == set()


def test_points_in_the_rrd_are_the_valid_beams(tmp_path):
    from rerun.chunk import RrdReader

    scans = [s for s, _ in sim.simulate("office", seed=0, n_scans=12)]  # NaN dropouts
    write_bag(scans, tmp_path / "o.bag")
    lkrr.record(tmp_path / "o.bag", tmp_path / "o.rrd", segment_threshold_m=None)
    got = {}
    for chunk in RrdReader(tmp_path / "o.rrd").store().stream():
        if chunk.entity_path == "/world/scan/points":
            batch = chunk.to_record_batch()
            seq = batch.column("scan").to_pylist()
            pos = batch.column("Points2D:positions").to_pylist()
            for k, p in zip(seq, pos, strict=True):
                got[k] = np.array(p, dtype=np.float64).reshape(-1, 2)
    assert sorted(got) == list(range(12))
    for k, s in enumerate(scans):
        np.testing.assert_allclose(got[k], s.xy, rtol=1e-6, atol=1e-6)  # float32 in rerun


def test_a_damaged_bag_still_gives_an_rrd_with_every_readable_scan(tmp_path):
    scans = [s for s, _ in sim.simulate("hall", seed=0, n_scans=40)]
    bag = tmp_path / "cut.bag"
    write_bag(scans, bag)
    bag.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2])
    summary = lkrr.record(bag, tmp_path / "cut.rrd")
    assert summary.error is not None and "cut.bag" in str(summary.error)
    rows, _ = rrd_rows(tmp_path / "cut.rrd")
    assert rows["/world/scan/points"] == summary.n_scans == summary.error.n_read
    assert 10 < summary.n_scans < 40


def test_the_rrd_carries_the_default_layout(tmp_path):
    """The saved file opens with a 2D scan view, metric time series, a log and the notes."""
    from rerun.chunk import RrdReader

    bag, _, _ = write_simulation("office", tmp_path / "o.bag", n_scans=3)
    lkrr.record(bag, tmp_path / "o.rrd")
    reader = RrdReader(tmp_path / "o.rrd")
    (store,) = reader.blueprints()
    views = {}
    for chunk in reader.store(store=store).stream():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:class_identifier" in batch.schema.names:
            kind = batch.column("ViewBlueprint:class_identifier").to_pylist()[0][0]
            origin = batch.column("ViewBlueprint:space_origin").to_pylist()[0][0]
            views[kind] = origin.strip("/")
    assert views == {"2D": "", "TimeSeries": "metrics", "TextLog": "log", "TextDocument": "description"}


@pytest.mark.parametrize("n", [1, 300])
def test_log_scans_batches_keep_the_sequence(tmp_path, n):
    rec = lkrr.new_recording("t")
    rec.save(tmp_path / "b.rrd")
    scans = [s for s, _ in sim.simulate("office", seed=0, n_scans=n)]
    assert lkrr.log_scans(rec, scans, start_index=5) == n
    rec.flush()
    rec.disconnect()
    rows, _ = rrd_rows(tmp_path / "b.rrd")
    assert rows["/world/scan/points"] == n
