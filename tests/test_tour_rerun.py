"""labkit.viz.tour_rerun (notebook 00) logs the stage times and the log lines where the layout reads them
(read back from the .rrd, against values worked out by hand)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from labkit.viz import rr as lkrr  # noqa: I001 (before rerun)
from labkit.viz import tour_rerun
from tests.test_legs_rerun import _read


def _scan(k: int, valid: list[bool]) -> SimpleNamespace:
    stamp_ns = 5_000_000_000 + k * 100_000_000                  # 10 Hz from t = 5 s
    return SimpleNamespace(stamp_ns=stamp_ns, stamp_s=stamp_ns / 1e9, valid=np.array(valid))


def test_times_on_every_scan_and_a_line_every_few_scans(tmp_path):
    scans = [_scan(k, [True, True, True, k != 2]) for k in range(5)]  # scan 2 has one invalid beam
    labels = [np.array([0, 0, 1, 1]), np.array([0, 1, 2, 3]), np.array([0, 0, 0, -1]),
              np.array([-1, -1, -1, -1]), np.array([0, 1, 1, 1])]
    rec = lkrr.new_recording("tour test")
    rec.save(str(tmp_path / "tour.rrd"))
    n = tour_rerun.log_segmentation_times(rec, scans, labels, [0.5, 0.25, 0.125, 1.0, 2.0], t0=5.0, every=2)
    rec.flush()
    rec.disconnect()
    got = _read(tmp_path / "tour.rrd")
    assert n == 3                                                  # scans 0, 2 and 4
    assert got["/metrics/time_ms/segmentation", "Scalars:scalars"] == {
        0: [0.5], 1: [0.25], 2: [0.125], 3: [1.0], 4: [2.0]}
    assert got["/log", "TextLog:text"] == {0: ["t =  0.0 s: 2 segments, 0 invalid beams"],
                                           2: ["t =  0.2 s: 1 segments, 1 invalid beams"],
                                           4: ["t =  0.4 s: 2 segments, 0 invalid beams"]}
