"""labkit.viz.legs_rerun (notebook 08b) logs what it is given where the layout reads it (read back from the .rrd)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from labkit.viz import legs_rerun
from labkit.viz import rr as lkrr


def _read(path) -> dict:
    """{(entity, column): {scan number: value}} of the time-indexed chunks of an .rrd."""
    from rerun.chunk import RrdReader

    got: dict = {}
    for chunk in RrdReader(path).store().stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        seq = batch.column(lkrr.SEQUENCE).to_pylist()
        for name in batch.schema.names:
            if ":" in name:
                for k, v in zip(seq, batch.column(name).to_pylist(), strict=True):
                    got.setdefault((chunk.entity_path, name), {})[k] = v
    return got


def test_people_counts_times_and_log_lines_land_on_their_scans(tmp_path):
    scans = [SimpleNamespace(stamp_ns=1_000_000_000 + k * 100_000_000) for k in range(3)]
    person = SimpleNamespace(center=np.array([1.0, 2.0]))
    people = [[], [person], []]                                  # a person on scan 1 only
    detections = [[object()], [object(), object()], []]           # 1, 2 and 0 legs
    rec = lkrr.new_recording("legs test")
    rec.save(str(tmp_path / "legs.rrd"))
    times = legs_rerun.scan_times(scans)
    legs_rerun.log_people_and_metrics(rec, times, people, detections, [0.5, 0.25, 0.125],
                                      missed=[(2, (3.0, -1.0))], summary="3 scans")
    rec.flush()
    rec.disconnect()
    got = _read(tmp_path / "legs.rrd")
    assert got["/metrics/count/legs", "Scalars:scalars"] == {0: [1.0], 1: [2.0], 2: [0.0]}
    assert got["/metrics/count/people", "Scalars:scalars"] == {0: [0.0], 1: [1.0], 2: [0.0]}
    assert got["/metrics/time_ms/detect_legs", "Scalars:scalars"] == {0: [0.5], 1: [0.25], 2: [0.125]}
    assert got["/world/people", "Points2D:positions"][1] == [[1.0, 2.0]]
    assert [p for k, p in got["/world/people", "Points2D:positions"].items() if k != 1] == [[], []]
    texts = got["/log", "TextLog:text"]
    assert texts == {0: ["3 scans"], 2: ["scan 2: missed the true leg at (3.00, -1.00) m"]}
