"""``labkit view --tracks``: the tracks in the ``.rrd`` read back (``RrdReader``) and compared with
``track_scans`` run here on the same scans, with the simulator's walkers, and with the geometry of
the frames (the sensor view is the map view moved by the inverse of each scan's pose, computed here
with its own rotation); the file passes ``rerun rrd verify``; the trails hold only live tracks."""

from __future__ import annotations

import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from labkit import read_scans, sim, track_scans
from labkit.app.data import write_simulation
from labkit.app.record import record
from labkit.tracking import Detections, Tracker
from tests.test_rr import _batches as _rows
from tests.test_rr import _views

N_SCANS = 50
BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def crossing(tmp_path_factory):
    """Two walkers crossing and a rolling cylinder, 50 scans, recorded with tracks."""
    folder = tmp_path_factory.mktemp("rrtracks")
    bag, truth, _ = write_simulation("crossing_2", folder / "crossing.bag", "ros1", seed=3, n_scans=N_SCANS)
    summary = record(bag, folder / "crossing.rrd", tracks=True)
    return bag, folder / "crossing.rrd", summary


def _xy(value) -> np.ndarray:
    return np.array(value or [], dtype=np.float64).reshape(-1, 2)


def _to_sensor(points, pose) -> np.ndarray:
    """World points into the frame of a sensor at ``pose``, written out here: R(-theta) (p - t)."""
    x, y, th = pose
    c, s = np.cos(th), np.sin(th)
    d = np.asarray(points, dtype=np.float64).reshape(-1, 2) - [x, y]
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])


def test_the_logged_tracks_are_those_of_the_tracker_in_both_views(crossing):
    bag, rrd, summary = crossing
    scans = list(read_scans(bag))
    tables = [t for _, t in track_scans(scans)]
    assert tables[0].frame == "map"
    points = {view: _rows(rrd, f"/{view}/tracks/points") for view in ("map", "world")}
    arrows = _rows(rrd, "/map/tracks/velocity")
    assert sorted(points["map"]) == sorted(points["world"]) == list(range(N_SCANS))
    colour_of: dict[str, int] = {}
    n_drawn = 0
    for k, (scan, table) in enumerate(zip(scans, tables, strict=True)):
        shown = np.isin(table.status, ("confirmed", "static"))
        want = [f"id {i}" if s == "confirmed" else f"id {i} static" for i, s in zip(table.ids[shown],
                                                                                  table.status[shown], strict=True)]
        for view in ("map", "world"):
            row = points[view][k]
            assert (row["Points2D:labels"] or []) == want, (k, view)
            expected = table.states[shown, :2] if view == "map" else _to_sensor(table.states[shown, :2], scan.pose)
            np.testing.assert_allclose(_xy(row["Points2D:positions"]), expected, atol=1e-5)  # float32
            for label, colour in zip(want, row["Points2D:colors"] or [], strict=True):
                assert colour_of.setdefault(label, colour) == colour  # a track keeps its colour
        moving = table.status == "confirmed"
        np.testing.assert_allclose(_xy(arrows[k]["Arrows2D:vectors"]), 0.5 * table.states[moving, 2:], atol=1e-5)
        n_drawn += int(moving.sum())
    assert n_drawn > N_SCANS  # the walkers were followed for most of the recording
    moving_labels = [lab for lab in colour_of if not lab.endswith("static")]
    assert len({colour_of[lab] for lab in moving_labels}) == len(moving_labels)  # one colour per track
    confirmed = sorted({int(i) for t in tables for i in t.ids[t.status == "confirmed"]})
    assert list(summary.moving_tracks) == confirmed


def test_the_tracks_follow_the_simulated_walkers(crossing):
    """Against the truth: after confirmation every walker has a drawn track within 0.5 m in the map
    view, and the median distance is a few centimetres."""
    _, rrd, _ = crossing
    world = sim.scenario("crossing_2").world
    points = _rows(rrd, "/map/tracks/points")
    errors = []
    for k in range(20, N_SCANS):
        labels = points[k]["Points2D:labels"] or []
        xy = _xy(points[k]["Points2D:positions"])[[not lab.endswith("static") for lab in labels]]
        for mover in world.movers_at(k * 0.1):
            if mover.kind == "person":
                d = np.hypot(*(xy - mover.center).T)
                assert d.min() < 0.5, (k, mover.name)
                errors.append(d.min())
    assert np.median(errors) < 0.06


def test_trails_are_the_last_seconds_of_each_track_and_events_are_on_the_timeline(crossing):
    bag, rrd, _ = crossing
    tables = [t for _, t in track_scans(read_scans(bag))]
    trails = _rows(rrd, "/map/tracks/trails")
    events = _rows(rrd, "/tracks/events")
    history: dict[int, list] = defaultdict(list)  # id -> (stamp, x, y)
    n_trails = 0
    for k, table in enumerate(tables):
        for i, s, state in zip(table.ids, table.status, table.states, strict=True):
            if s != "deleted":
                history[int(i)].append((table.stamp_ns, *state[:2]))
        expected = []
        for i in table.ids[table.status == "confirmed"]:
            past = [(x, y) for t, x, y in history[int(i)] if t >= table.stamp_ns - 3_000_000_000]
            if len(past) >= 2:
                expected.append(np.array(past))
        got = [np.array(s, dtype=np.float64) for s in trails[k]["LineStrips2D:strips"] or []]
        assert len(got) == len(expected), k
        n_trails += len(got)
        for g, e in zip(got, expected, strict=True):
            np.testing.assert_allclose(g, e, atol=1e-5)
        said = events.get(k, {}).get("TextLog:text") or []
        assert len(said) == len(table.events), k
        for (what, tid), text in zip(table.events, said, strict=True):
            assert text.startswith(f"track {tid} ") and {"birth": "born", "confirm": "moving", "static": "static",
                                                          "delete": "deleted"}[what] in text
    assert any(t.events for t in tables) and n_trails > N_SCANS


def test_the_recording_verifies_and_opens_with_a_track_log(crossing):
    _, rrd, _ = crossing
    p = subprocess.run([str(BIN / "rerun"), "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and "verified without error" in p.stdout + p.stderr, p.stdout + p.stderr

    assert ("TextLog", "tracks/events") in _views(rrd)


def test_a_deleted_track_leaves_no_trail_behind_and_trails_keep_only_their_seconds():
    """Memory: one target seen for 6 s then gone; the logger keeps 3 s of its trail, and nothing of it
    once the tracker deletes it."""
    import rerun as rr

    from labkit.viz.rr.tracks import TrackLogger

    rec = rr.RecordingStream("labkit-test")
    rec.memory_recording()
    logger = TrackLogger(rec, ("world",), trail_s=3.0)
    tracker = Tracker(frame="sensor")
    dt = 100_000_000
    longest = 0
    for k in range(100):
        seen = [[1.0 + 0.1 * k, 2.0]] if k < 60 else np.zeros((0, 2))
        table = tracker.step(Detections(k * dt, ("person",) * len(seen), seen))
        logger.send([(k, table)])
        longest = max(longest, max((len(t) for t in logger.trails.values()), default=0))
    assert longest == 31  # 3 s at 10 scans/s, both ends included
    assert logger.trails == {} and logger.confirmed == {1}


def test_the_command_line_draws_tracks_and_refuses_them_without_features(crossing, tmp_path, labkit_cli):
    bag, _, summary = crossing
    p = labkit_cli("view", bag, "-o", tmp_path / "t.rrd", "--tracks", "--scans", "10:30")
    assert p.returncode == 0, p.stderr
    assert "moving targets confirmed:" in p.stdout
    p = labkit_cli("view", bag, "-o", tmp_path / "u.rrd", "--tracks", "--no-features")
    assert p.returncode != 0 and "--tracks needs the features" in p.stderr
    assert not (tmp_path / "u.rrd").exists()


def test_log_tracks_numbers_the_scans_and_draws_the_confirmed_tracks(tmp_path):
    """The notebook's call: tables of a hand-made walk logged from scan 5 on, read back."""
    from labkit.viz import rr as lkrr

    tracker = Tracker(frame="sensor")
    tables = [tracker.step(Detections(k * 100_000_000, ("person",), [[1.0 + 0.1 * k, 2.0]])) for k in range(20)]
    rec = lkrr.new_recording("walk")
    rec.save(tmp_path / "walk.rrd")
    assert lkrr.log_tracks(rec, tables, start_index=5) == 20
    rec.flush()
    rec.disconnect()
    points = _rows(tmp_path / "walk.rrd", "/world/tracks/points")
    assert sorted(points) == list(range(5, 25))
    said = {"confirmed": "", "static": " static"}
    for k, table in enumerate(tables):
        shown = np.isin(table.status, ("confirmed", "static"))
        assert (points[k + 5]["Points2D:labels"] or []) == [f"id {i}{said[s]}" for i, s in zip(
            table.ids[shown], table.status[shown], strict=True)]
        np.testing.assert_allclose(_xy(points[k + 5]["Points2D:positions"]), table.states[shown, :2], atol=1e-5)
    assert points[24]["Points2D:labels"] == ["id 1"]  # static at first, then moving
