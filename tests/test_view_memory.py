"""What ``labkit view`` keeps in memory for a long recording (issue 30): the poses read before the scans
cost a few bytes each, not a Python object each. The peak itself is measured in ``benchmarks/io.py``."""

from __future__ import annotations

import tracemalloc

import numpy as np

from labkit.poses import PoseTrack, interpolate_poses


def test_a_pose_track_answers_one_stamp_at_a_time_in_a_few_bytes_per_pose():
    # a 100,000-scan recording's odometry: a reader asks the pose of every scan with PoseTrack.at. Its lookup
    # table is two flat arrays (8 + 24 bytes a pose); a list of tuples of floats was some 190 bytes a pose
    # (18 MiB here, kept for the whole view)
    n = 100_000
    stamps = np.arange(n, dtype=np.int64) * 40_000_000
    rng = np.random.default_rng(0)
    poses = np.column_stack([np.cumsum(rng.normal(0, 0.01, n)), np.cumsum(rng.normal(0, 0.01, n)),
                             rng.uniform(-np.pi, np.pi, n)])
    track = PoseTrack.from_samples(stamps, poses)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        first = track.at(int(stamps[10]) + 20_000_000)  # builds the table
        kept = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert kept / n <= 48, f"{kept / n:.0f} bytes kept per pose"
    # the same numbers as the array interpolation (its own code: labkit.poses.interpolate_poses)
    at = np.array([0, 10, 10 * 40_000_000 + 20_000_000, 77_777 * 40_000_000 + 1_234_567, (n - 1) * 40_000_000])
    expected = interpolate_poses(track.stamps_ns, track.poses, at)
    got = np.array([track.at(int(t)) for t in at])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert first == tuple(got[2]) and all(isinstance(v, float) for v in first)
    assert track.at(-10**12) is None and track.at(n * 40_000_000 + 10**12) is None
