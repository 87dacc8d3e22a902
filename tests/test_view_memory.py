"""What ``labkit view`` keeps in memory for a long recording (issue 30): the poses read before the scans
cost a few bytes each, not a Python object each; the command line does not load pandas. The peak itself is
measured in ``benchmarks/io.py``."""

from __future__ import annotations

import os
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np

from labkit.poses import PoseTrack, interpolate_poses

BIN = Path(sys.executable).parent


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


def test_the_command_line_view_writes_the_same_recording_without_importing_pandas(tmp_path):
    # pyarrow imports pandas (some 45 MiB) at its first array conversion only to ask whether the data are
    # pandas objects; the command line's view lets it find none. What it writes is what the library writes
    # in a process that has pandas (this one); and pandas still works in that process afterwards
    from labkit.app.data import write_simulation
    from labkit.app.record import record
    from tests.test_rr import _batches

    bag, _, _ = write_simulation("corridor", tmp_path / "c.bag", "ros1", seed=0, n_scans=40)
    script = (
        "import sys\n"
        "from labkit.app.cli import main\n"
        f"rc = main(['view', {str(bag)!r}, '-o', {str(tmp_path / 'cli.rrd')!r}, '-q'])\n"
        "print(rc, 'pandas' in sys.modules)\n"
        "import pandas as pd, pyarrow as pa\n"
        "print(pa.Table.from_pandas(pd.DataFrame({'a': [1, 2]})).num_rows)\n"
    )
    # (numpy's engines there, not numba's: the same features bit for bit, and the process starts in half the time)
    env = {**os.environ, "LABKIT_NO_JIT": "1"}
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, env=env)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split()[-3:] == ["0", "False", "2"], p.stdout
    record(bag, tmp_path / "lib.rrd")
    for entity in ("/world/scan/points", "/world/lines", "/world/legs", "/world/truth/walls", "/metrics/count/lines",
                   "/map/sensor", "/map/accumulated/points"):
        cli, lib = _batches(tmp_path / "cli.rrd", entity), _batches(tmp_path / "lib.rrd", entity)
        assert sorted(cli) == sorted(lib) and len(cli) >= 4, entity
        for k in cli:  # (each row's id is new)
            assert {**cli[k], "rerun.controls.RowId": None} == {**lib[k], "rerun.controls.RowId": None}, (entity, k)
    v = subprocess.run([str(BIN / "rerun"), "rrd", "verify", str(tmp_path / "cli.rrd")], capture_output=True, text=True,
                       timeout=120)
    assert v.returncode == 0, v.stdout + v.stderr
