"""The readers on the real public recordings in ../shared/datasets (skipped when absent)."""

from __future__ import annotations

import numpy as np
import pytest

from labkit import read_scans
from labkit.geometry import transform_points
from labkit.io.carmen import read_carmen

pytestmark = pytest.mark.shared

# scans per log and beams per scan, from ../shared/datasets/README.md
CARMEN = {
    "intel": (910, 180),
    "aces": (440, 180),
    "csail": (406, 361),
    "freiburg-079": (4791, 360),
    "infinite-corridor": (1941, 180),
    "orebro": (237, 181),
}


@pytest.mark.parametrize("log", sorted(CARMEN))
def test_every_radish_log_reads_completely(shared_datasets, log):
    n_scans, n_beams = CARMEN[log]
    path = shared_datasets / "carmen" / f"{log}-corrected.log.gz"
    stream = read_scans(path)
    assert stream.format == "carmen" and stream.topic == "FLASER" and stream.count == n_scans
    scans = list(stream)
    assert len(scans) == n_scans
    assert {s.n_beams for s in scans} == {n_beams}
    first = scans[0]
    assert np.isclose(first.angles[0], -np.pi / 2)
    assert np.isclose(first.angles[-1], np.pi / 2 if n_beams % 2 else np.pi / 2 - np.pi / n_beams)
    assert all(s.pose is not None for s in scans)
    # the "no return" value (81.83 m in intel, 50 m in aces, ...) is found and masked
    everything = np.concatenate([s.ranges for s in scans])
    valid = np.concatenate([s.valid for s in scans])
    assert everything[valid].max() < everything.max() - 0.1
    assert 0.5 < valid.mean() < 1.0


def _overlap_error(scans, increment):
    """Median distance (m) of each scan's points to the previous scan's points, both placed
    in the world with the logs' corrected poses, if beams were ``increment`` apart."""
    errs = []
    for a, b in zip(scans[:-1], scans[1:], strict=True):
        pts = []
        for s in (a, b):
            ang = -np.pi / 2 + increment * np.arange(s.n_beams)
            ok = s.valid
            pts.append(transform_points(np.stack([s.ranges[ok] * np.cos(ang[ok]),
                                                  s.ranges[ok] * np.sin(ang[ok])], axis=1), s.pose))
        d = np.sqrt(((pts[1][:, None, :] - pts[0][None, :, :]) ** 2).sum(-1)).min(axis=1)
        errs.append(np.median(d))
    return float(np.mean(errs))


@pytest.mark.parametrize("log", ["intel", "orebro"])
def test_the_angular_step_rule_fits_the_data(shared_datasets, log):
    """FLASER does not store its angular step. labkit uses pi/n for even n (180, 360 beams)
    and pi/(n-1) for odd n (181, 361); consecutive scans placed with the corrected poses
    overlap better with that choice than with the other one."""
    scans = list(read_carmen(shared_datasets / "carmen" / f"{log}-corrected.log.gz"))[:200:2]
    n = scans[0].n_beams
    chosen = _overlap_error(scans, scans[0].angle_increment)
    other = _overlap_error(scans, np.pi / (n - 1) if n % 2 == 0 else np.pi / n)
    assert chosen < other


def test_ros1_bag_mapping1(shared_datasets):
    stream = read_scans(shared_datasets / "bags" / "Mapping1.bag")
    assert stream.topic == "/base_scan" and stream.count == 1727
    scans = list(stream)
    assert len(scans) == 1727 and {s.n_beams for s in scans} == {90}
    s = scans[0]
    assert np.isclose(s.angles[0], -np.radians(135), atol=1e-6) and np.isclose(s.angles[-1], np.radians(135),
                                                                               atol=1e-6)
    assert s.range_max == 5.0 and not s.valid[s.ranges >= 5.0].any()  # 5 m readings: no return
    stamps = np.array([s.stamp_ns for s in scans])
    assert np.all(np.diff(stamps) > 0)
    assert np.isclose((stamps[-1] - stamps[0]) * 1e-9, 172.6, atol=0.2)


@pytest.mark.parametrize("k", range(1, 7))
def test_json_single_scans(shared_datasets, k):
    (s,) = read_scans(shared_datasets / "single_scans" / f"laser_scan_{k}.json")
    assert s.n_beams == 541
    assert np.isclose(s.angle_min, -np.radians(135), atol=1e-6)
    assert np.isclose(s.angle_increment, np.radians(0.5), atol=1e-9)
    assert not s.valid[s.ranges == 0.0].any()  # zero readings are invalid
    assert s.valid.sum() > 400
