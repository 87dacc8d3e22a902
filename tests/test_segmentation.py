"""Range segmentation against a plain-loop reference and the simulator's ground truth."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit import Scan, range_segments, segment_labels, sim


def reference_runs(scan: Scan, threshold: float, min_points: int) -> list[list[int]]:
    """Segmentation written as a loop over beams, straight from the definition: the kept
    segments' beams in scan order (a seam-crossing one as N-k..N-1, 0..m), in label order."""
    n = scan.n_beams
    runs, current = [], []
    for i in range(n):
        if not scan.valid[i]:
            if current:
                runs.append(current)
            current = []
            continue
        if current and np.hypot(*(scan.points[i] - scan.points[current[-1]])) >= threshold:
            runs.append(current)
            current = []
        if current and current[-1] != i - 1:
            runs.append(current)
            current = []
        current.append(i)
    if current:
        runs.append(current)
    if scan.is_full_circle and len(runs) > 1 and runs[0][0] == 0 and runs[-1][-1] == n - 1:
        if np.hypot(*(scan.points[0] - scan.points[n - 1])) < threshold:
            runs[0] = runs.pop() + runs[0]
    kept = [r for r in runs if len(r) >= min_points]
    kept.sort(key=lambda r: min(r))
    return kept


def reference_labels(scan: Scan, threshold: float, min_points: int) -> np.ndarray:
    labels = np.full(scan.n_beams, -1)
    for k, r in enumerate(reference_runs(scan, threshold, min_points)):
        labels[r] = k
    return labels


ranges_strategy = st.lists(
    st.one_of(st.floats(0.2, 5.0), st.sampled_from([np.nan, 0.0, np.inf, 30.0])), min_size=0, max_size=60
)


@settings(max_examples=300)
@given(ranges=ranges_strategy, threshold=st.floats(0.01, 1.0), min_points=st.integers(1, 5),
       full=st.booleans())
def test_matches_the_loop_reference(ranges, threshold, min_points, full):
    n = len(ranges)
    step = 2 * np.pi / max(n, 1) if full else np.radians(1.0)
    scan = Scan(ranges=ranges, angles=-np.pi + step * np.arange(n), range_max=30.0)
    got = segment_labels(scan, threshold_m=threshold, min_points=min_points, adaptive=False)
    want = reference_labels(scan, threshold, min_points)
    np.testing.assert_array_equal(got, want)
    segments = range_segments(scan, threshold_m=threshold, min_points=min_points, adaptive=False)
    assert [s.indices.tolist() for s in segments] == reference_runs(scan, threshold, min_points)


def test_invalid_beams_break_segments_and_isolated_points_go():
    s = Scan(ranges=[1.0, 1.0, np.nan, 1.0, 1.0, 3.0, 1.0, 1.0], angles=np.radians(np.arange(8)))
    assert segment_labels(s).tolist() == [0, 0, -1, 1, 1, -1, 2, 2]
    segs = range_segments(s)
    assert [(g.first, g.last, g.n_points) for g in segs] == [(0, 1, 2), (3, 4, 2), (6, 7, 2)]


def test_segment_crossing_the_seam_of_a_full_circle():
    n = 360
    ranges = np.full(n, 4.0)  # beams 7 cm apart at 4 m
    ranges[100:200] = 2.0  # an object in front; the 4 m wall runs behind, across the seam
    s = Scan.from_angle_increment(ranges, -np.pi, 2 * np.pi / n)
    segs = range_segments(s)
    assert len(segs) == 2
    seam = next(g for g in segs if g.first > g.last)
    assert seam.first == 200 and seam.last == 99 and seam.n_points == 260
    assert np.all(np.diff(seam.indices) % n == 1)  # consecutive beams along the segment


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf])
def test_rejects_bad_threshold(bad):
    with pytest.raises(ValueError, match="threshold_m"):
        segment_labels(Scan(ranges=[1.0], angles=[0.0]), threshold_m=bad)


def test_rejects_bad_min_points():
    with pytest.raises(ValueError, match="min_points"):
        segment_labels(Scan(ranges=[1.0], angles=[0.0]), min_points=0)


def test_degenerate_scans():
    assert segment_labels(Scan(ranges=[], angles=[])).tolist() == []
    assert segment_labels(Scan(ranges=[1.0], angles=[0.0])).tolist() == [-1]
    assert segment_labels(Scan(ranges=[np.nan] * 4, angles=[0, 1, 2, 3])).tolist() == [-1] * 4
    assert range_segments(Scan(ranges=[np.nan] * 4, angles=[0, 1, 2, 3])) == []


def test_separate_objects_in_the_simulator_are_separate_segments():
    """Beams on different objects at different depths never share a segment (a column in
    front of a wall), and one object seen in one piece is one segment."""
    world = sim.World("t", walls=(sim.Wall((6.0, -20.0), (6.0, 20.0)),), circles=(sim.Column((3.0, 0.0), 0.3),))
    lidar = sim.LIDARS["lms200"]
    scan, truth = sim.scan_at(world, lidar, (0.0, 0.0, 0.0))
    labels = segment_labels(scan, threshold_m=0.08)
    column = truth.hits == 1
    assert len(set(labels[column])) == 1 and labels[column][0] >= 0
    assert not set(labels[column]) & set(labels[truth.hits == 0])
