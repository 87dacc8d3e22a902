"""Features as a table (labkit.tables): one row per feature, the world frame checked against the
simulator's walls, Parquet files read back by pandas itself, and written safely."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import labkit
from labkit import evaluation, extract_all, features_table, read_scans, sim, write_bag
from labkit._safe import OutputInterrupted
from labkit.geometry import line_through_points, transform_points
from labkit.tables import COLUMNS, write_features_table

LABKIT = [str(Path(sys.executable).parent / "labkit")]


@pytest.fixture(scope="module")
def office():
    data = list(sim.simulate("office", seed=2, n_scans=60))
    scans = [s for s, _ in data]
    return scans, [t for _, t in data], list(extract_all(scans))


def test_one_row_per_feature_with_its_parameters(office):
    scans, _, feats = office
    df = features_table(feats, scans, recording="office", method="iepf")
    assert list(df.columns) == ["recording", "method", *COLUMNS]
    want = {"line": sum(len(f.lines) for f in feats), "corner": sum(len(f.corners) for f in feats),
            "leg": sum(len(f.legs) for f in feats), "person": sum(len(f.people) for f in feats)}
    got = df.groupby("kind").size()
    assert all(got.get(k, 0) == v for k, v in want.items()) and want["line"] > 100 and want["leg"] > 0
    assert len(df) == sum(sum(len(getattr(f, layer)) for layer in f.LAYERS) for f in feats)
    k = 7
    lines = df[(df.scan == k) & (df.kind == "line")].sort_values("index")
    for (_, row), ln in zip(lines.iterrows(), feats[k].lines, strict=True):
        assert (row.r, row.alpha, row["first"], row["last"], row.n_points) == (ln.r, ln.alpha, ln.first, ln.last,
                                                                              ln.n_points)
        assert (row.x0, row.y0, row.x1, row.y1) == (*ln.start, *ln.end)
        assert (row.var_r, row.var_alpha, row.cov_r_alpha) == (ln.covariance[0, 0], ln.covariance[1, 1],
                                                               ln.covariance[0, 1])
    assert (df.stamp_ns == df.scan.map(lambda i: scans[i].stamp_ns)).all()
    assert df["first"].dtype == "Int64" and df.loc[df.kind == "person", "first"].isna().all()
    assert df.loc[df.kind == "corner", "corner_kind"].isin(["convex", "concave"]).all()


def test_world_frame_lines_sit_on_the_worlds_walls_as_they_do_in_the_sensor_frame(office):
    """For every line matched to a wall (by labkit.evaluation, in the sensor frame): its world end
    points are as far from that wall of the simulator's world (a line through its end points, in
    world coordinates) as its sensor-frame end points are from the wall the simulator saw (its
    sensor-frame truth); and they lie on the world-frame line (world_r, world_alpha)."""
    scans, truths, feats = office
    df = features_table(feats, scans)
    walls = sim.make_world("office").walls
    checked = 0

    def distance(x, y, r, alpha):
        return x * math.cos(alpha) + y * math.sin(alpha) - r

    for k, (f, truth) in enumerate(zip(feats, truths, strict=True)):
        m = evaluation.match_lines(f.lines, truth)
        rows = df[(df.scan == k) & (df.kind == "line")].set_index("index")
        for i, j in m.pairs:
            seen = truth.walls[j]
            w = walls[seen.wall_id]
            r, alpha = line_through_points(w.start, w.end)
            got = rows.loc[i]
            for end in ("0", "1"):
                x, y, wx, wy = got[f"x{end}"], got[f"y{end}"], got[f"world_x{end}"], got[f"world_y{end}"]
                assert abs(abs(distance(wx, wy, r, alpha)) - abs(distance(x, y, seen.r, seen.alpha))) < 1e-6
                assert abs(distance(wx, wy, got.world_r, got.world_alpha)) < 1e-9
            assert got.world_r >= 0 and -math.pi < got.world_alpha <= math.pi
            checked += 1
    assert checked > 200


def test_world_points_are_the_sensor_points_moved_by_the_pose(office):
    scans, _, feats = office
    df = features_table(feats, scans)
    for kind in ("corner", "leg", "line"):
        sub = df[df.kind == kind]
        poses = sub[["pose_x", "pose_y", "pose_theta"]].to_numpy()
        want = np.array([transform_points(p, pose) for p, pose in zip(sub[["x", "y"]].to_numpy(), poses,
                                                                      strict=True)])
        np.testing.assert_allclose(sub[["world_x", "world_y"]].to_numpy(), want, atol=1e-9)
    truth_poses = np.array([s.pose for s in scans])
    np.testing.assert_allclose(df[["pose_x", "pose_y", "pose_theta"]].to_numpy(), truth_poses[df.scan.to_numpy()])


def test_without_scans_or_poses_the_world_columns_are_empty(office):
    _, _, feats = office
    df = features_table(feats[:5])
    assert "recording" not in df.columns and df.world_x.isna().all() and df.pose_x.isna().all()
    with pytest.raises(ValueError, match="disagree"):
        features_table(feats[:5], office[0][1:6])


def test_parquet_holds_the_same_table_and_pandas_reads_it(office, tmp_path):
    scans, _, feats = office
    out = tmp_path / "o.parquet"
    n, rows = write_features_table(zip(scans, feats, strict=True), out, recording="office", method="iepf",
                                   chunk_scans=7)  # several row groups
    assert out.read_bytes()[:4] == b"PAR1" and n == 60
    back = pd.read_parquet(out)  # pandas' own reader
    want = features_table(feats, scans, recording="office", method="iepf")
    assert len(back) == rows == len(want)
    pd.testing.assert_frame_equal(labkit.read_table(out), want)
    np.testing.assert_array_equal(back.world_r.to_numpy(), want.world_r.to_numpy())


def test_an_interrupted_table_is_a_valid_partial(office, tmp_path):
    scans, _, feats = office

    def pairs():
        for k, pair in enumerate(zip(scans, feats, strict=True)):
            if k == 25:
                raise KeyboardInterrupt
            yield pair

    with pytest.raises(OutputInterrupted) as info:
        write_features_table(pairs(), tmp_path / "i.parquet", chunk_scans=10)
    assert info.value.partial == tmp_path / "i.partial.parquet" and not (tmp_path / "i.parquet").exists()
    assert sorted(pd.read_parquet(info.value.partial).scan.unique()) == list(range(25))


def run(*args):
    return subprocess.run([*LABKIT, "-q", *map(str, args)], capture_output=True, text=True, timeout=300)


def test_cli_extract_to_parquet(tmp_path):
    scans = [s for s, _ in sim.simulate("hall", seed=1, n_scans=25)]
    write_bag(scans, tmp_path / "h.bag")
    p = run("extract", tmp_path / "h.bag", "-o", tmp_path / "h.parquet")
    assert p.returncode == 0 and "wrote features of 25 scans" in p.stdout, p.stderr
    want = features_table(extract_all(scans), scans, recording="h.bag", method="iepf")
    pd.testing.assert_frame_equal(labkit.read_table(tmp_path / "h.parquet"), want)
    assert run("extract", tmp_path / "h.bag", "-o", tmp_path / "h.parquet").returncode == 2  # exists, no -f
    assert run("extract", tmp_path / "h.bag", "-o", tmp_path / "h.parquet", "-f").returncode == 0
    (tmp_path / "notes.parquet").write_text("my notes")
    p = run("extract", tmp_path / "h.bag", "-o", tmp_path / "notes.parquet", "-f")
    assert p.returncode == 2 and "is not a Parquet table" in p.stderr and (tmp_path / "notes.parquet").read_text() == \
        "my notes"


def test_cli_a_damaged_recording_gives_a_table_of_every_readable_scan(tmp_path):
    scans = [s for s, _ in sim.simulate("hall", seed=1, n_scans=40)]
    bag = tmp_path / "cut.bag"
    write_bag(scans, bag)
    bag.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2])
    readable = []
    with pytest.raises(labkit.CorruptFileError):
        readable.extend(read_scans(bag))
    p = run("extract", bag, "-o", tmp_path / "cut.parquet")
    assert p.returncode == 1 and "cut.bag is damaged" in p.stderr and "Traceback" not in p.stderr
    df = pd.read_parquet(tmp_path / "cut.parquet")
    want = features_table(extract_all(readable), readable, recording="cut.bag", method="iepf")
    assert df.scan.max() == len(readable) - 1 and len(df) == len(want)
