"""``labkit track``: a recording's tracks as a CSV table, checked against the simulator's movers and
against the library's own stream read back independently (the csv module, not labkit's reader)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from labkit import read_scans, sim, track_scans
from labkit.app.cli import main
from labkit.app.data import write_simulation
from labkit.io.track_files import TRACK_COLUMNS, read_tracks

N_SCANS = 40


@pytest.fixture(scope="module")
def crossing_bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp("track")
    bag, _truth, _n = write_simulation("crossing_2", folder / "crossing.bag", "ros1", seed=3, n_scans=N_SCANS)
    return bag


def test_track_writes_every_track_of_every_scan(crossing_bag, tmp_path, capsys):
    out = tmp_path / "tracks.csv"
    assert main(["track", "-q", str(crossing_bag), "-o", str(out)]) == 0
    said = capsys.readouterr().out
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == TRACK_COLUMNS
    # the same stream through the library, row for row
    tables = [t for _, t in track_scans(read_scans(crossing_bag))]
    expected = [(k, t.stamp_ns, t.frame, int(t.ids[i]), t.kinds[i], t.status[i], *t.states[i], int(t.hits[i]))
                for k, t in enumerate(tables) for i in range(len(t.ids))]
    got = [(int(r["scan"]), int(r["stamp_ns"]), r["frame"], int(r["id"]), r["kind"], r["status"], float(r["x"]),
            float(r["y"]), float(r["vx"]), float(r["vy"]), int(r["hits"])) for r in rows]
    assert got == expected  # floats written with repr: exact
    assert list(read_tracks(out))[0]["id"] == got[0][3]
    assert f"wrote tracks of {N_SCANS} scans" in said and f"({len(rows)} rows" in said
    # the simulator's truth: both walkers have a confirmed person track near them at the last scan
    sc = sim.scenario("crossing_2")
    last = [r for r in got if r[0] == N_SCANS - 1 and r[5] == "confirmed" and r[4] == "person"]
    walkers = [m for m in sc.world.movers_at((N_SCANS - 1) * 0.1) if m.kind == "person"]
    assert len(walkers) == 2
    for walker in walkers:
        assert min(np.hypot(r[6] - walker.center[0], r[7] - walker.center[1]) for r in last) < 0.5, walker.name


def test_track_keeps_the_recording_numbers_of_a_range_and_refuses_what_it_should(crossing_bag, tmp_path, capsys):
    out = tmp_path / "range.csv"
    assert main(["track", "-q", str(crossing_bag), "-o", str(out), "--scans", "30:"]) == 0
    scans = {r["scan"] for r in read_tracks(out)}
    assert min(scans) == 30 and max(scans) == N_SCANS - 1
    capsys.readouterr()
    assert main(["track", "-q", str(crossing_bag), "-o", str(out)]) == 2  # exists: -f needed
    assert "exists" in capsys.readouterr().err
    assert main(["track", "-q", str(crossing_bag), "-o", str(out), "-f"]) == 0
    other = tmp_path / "notes.csv"
    other.write_text("a,b\n1,2\n")
    assert main(["track", "-q", str(crossing_bag), "-o", str(other), "-f"]) == 2  # not a tracks table: kept
    assert other.read_text() == "a,b\n1,2\n"
    assert main(["track", "-q", str(crossing_bag), "-o", str(crossing_bag), "-f"]) == 2  # never the input
