"""Smaller command-line items: ``simulate --sensor/--beams`` and ``bench`` naming what it read."""

from __future__ import annotations

import json

import numpy as np

from labkit import read_scans
from tests.test_scan_ranges import carmen_log


def test_simulate_another_sensor_and_beam_count(tmp_path, labkit_cli):
    p = labkit_cli("simulate", "hall", "-o", tmp_path / "h.bag", "--sensor", "lms200", "--beams", "722", "--scans", "3")
    assert p.returncode == 0, p.stderr
    scans = list(read_scans(tmp_path / "h.bag"))
    assert len(scans) == 3 and {s.n_beams for s in scans} == {722}
    # 722 beams over the LMS200's 180 degrees, first and last beam at -90 and +90 degrees (float32 in the bag)
    np.testing.assert_allclose(scans[0].angles, np.linspace(-np.pi / 2, np.pi / 2, 722), atol=2e-6)
    header = json.loads((tmp_path / "h.truth.jsonl").read_text().splitlines()[0])
    assert header["lidar"]["n_beams"] == 722
    p = labkit_cli("simulate", "corridor", "-o", tmp_path / "c.bag", "--sensor", "xv11", "--beams", "720",
                   "--scans", "2")
    assert p.returncode == 0, p.stderr
    scan = next(iter(read_scans(tmp_path / "c.bag")))
    np.testing.assert_allclose(scan.angles, -np.pi + np.arange(720) * (2 * np.pi / 720), atol=2e-6)  # full circle
    assert labkit_cli("simulate", "hall", "-o", tmp_path / "x.bag", "--beams", "1").returncode == 2
    assert labkit_cli("simulate", "--bundled", "-o", tmp_path / "d", "--sensor", "xv11").returncode == 2


def test_bench_names_the_kind_of_input(tmp_path, labkit_cli):
    log = carmen_log(tmp_path / "run.log", 8)
    p = labkit_cli("bench", log, "--scans", "5")
    assert p.returncode == 0, p.stderr
    assert "CARMEN .log/.gz -> features -> .rrd" in p.stdout and "bag ->" not in p.stdout, p.stdout
    p = labkit_cli("bench", "--scans", "10:14")
    assert p.returncode == 0 and "4 scans" in p.stdout and ".bag -> features -> .rrd" in p.stdout, p.stdout
