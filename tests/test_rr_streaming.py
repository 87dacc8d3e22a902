"""``labkit view`` streams: the ``.rrd`` is written as the scans are read (the ground truth read along
with them), is complete and valid (``rerun rrd verify``, read back with ``RrdReader``), keeps a
range's scan numbers, warns when the stamps do not advance, and a full disk is one line and exit
status 3 with no file left. Memory figures: ``benchmarks/io.py``."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from labkit import Scan
from labkit.app.data import write_simulation
from labkit.app.record import record
from labkit.viz import rr as lkrr
from labkit.viz.rr.recording import _TruthFeed
from tests.test_rr import _batches, _blueprint, rrd_rows

BIN = Path(sys.executable).parent
SHARED = Path(__file__).resolve().parents[2] / "shared" / "datasets"


def test_the_rrd_is_complete_and_valid(tmp_path):
    bag, truth, _ = write_simulation("hall", tmp_path / "h.bag", n_scans=40)
    summary = record(bag, tmp_path / "h.rrd")
    assert (summary.n_scans, summary.n_truth) == (40, 40)
    p = subprocess.run([str(BIN / "rerun"), "rrd", "verify", str(tmp_path / "h.rrd")], capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0 and "verified without error" in p.stdout + p.stderr, p.stdout + p.stderr
    rows, _ = rrd_rows(tmp_path / "h.rrd")
    n_truth_lines = len(truth.read_text().splitlines()) - 1  # the header, then one line per scan
    assert rows["/world/scan/points"] == 40 and rows["/world/truth/walls"] == n_truth_lines == 40
    assert rows["/world/lines"] == 40


def test_a_range_keeps_the_recordings_scan_numbers_and_its_truth(tmp_path):
    bag, _, _ = write_simulation("hall", tmp_path / "h.bag", n_scans=30)
    summary = record(bag, tmp_path / "r.rrd", scans=slice(10, 20))
    assert (summary.n_scans, summary.n_truth) == (10, 10)
    assert sorted(_batches(tmp_path / "r.rrd", "/world/scan/points")) == list(range(10, 20))
    assert sorted(_batches(tmp_path / "r.rrd", "/world/truth/walls")) == list(range(10, 20))


def test_truth_is_read_along_with_the_scans():
    """The truth of each batch of scans is read when that batch is logged, not before: what has been
    read ahead stays within one truth of the batch's end, whatever the length of the recording."""
    read = []

    def truths():
        for k in range(2000):
            read.append(k)
            yield SimpleNamespace(stamp_ns=10 * k)

    feed = _TruthFeed(truths())
    for first in range(0, 2000, 256):
        stamps = [10 * k for k in range(first, min(first + 256, 2000)) if k % 7]  # scans k % 7 == 0 were lost
        got = feed.take(stamps)
        assert [t.stamp_ns for t in got] == stamps
        assert len(read) <= first + 257 and len(feed.ahead) <= 1


def _scans(stamps):
    angles = np.linspace(-1.0, 1.0, 20)
    return [Scan(ranges=np.full(20, 2.0), angles=angles, stamp_ns=int(s)) for s in stamps]


def test_collapsed_stamps_warn_and_the_viewer_opens_on_the_scan_timeline(tmp_path):
    with pytest.warns(lkrr.StampsCollapsedWarning, match="9 of 12 scans have a time stamp no later.*'scan' timeline"):
        lkrr.record_scans(_scans([5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 6, 7]), tmp_path / "c.rrd", name="c")
    assert _blueprint(tmp_path / "c.rrd", "TimePanelBlueprint:timeline") == [("scan",)]
    logged = _batches(tmp_path / "c.rrd", "/log")
    assert any("WARN" in str(row.get("TextLog:level")) and "'scan' timeline" in str(row.get("TextLog:text"))
               for row in logged.values())
    lkrr.record_scans(_scans(range(0, 120, 10)), tmp_path / "ok.rrd", name="ok")  # no warning (they are errors)
    assert _blueprint(tmp_path / "ok.rrd", "TimePanelBlueprint:timeline") == []


@pytest.mark.skipif(not (SHARED / "carmen" / "infinite-corridor-corrected.log.gz").exists(),
                    reason="the Radish logs are not in ../shared/datasets")
def test_view_warns_on_the_infinite_corridor(tmp_path):
    log = SHARED / "carmen" / "infinite-corridor-corrected.log.gz"
    p = subprocess.run([str(BIN / "labkit"), "-q", "view", str(log), "-o", str(tmp_path / "ic.rrd"), "--no-features",
                        "--scans", ":300"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    notes = [ln for ln in p.stderr.splitlines() if ln.startswith("labkit: note:")]
    assert len(notes) == 1 and "of 300 scans have a time stamp no later" in notes[0] and "'scan' timeline" in notes[0]


def _unshare_works() -> bool:
    if not shutil.which("unshare"):
        return False
    probe = subprocess.run(["unshare", "--user", "--map-root-user", "--mount", "sh", "-c",
                            "mount -t tmpfs none /mnt && echo ok"], capture_output=True, text=True, timeout=30)
    return probe.stdout.strip() == "ok"


API_ON_A_FULL_DISK = """
import errno, sys
from labkit.app.record import record
try:
    record(sys.argv[1], sys.argv[2] + "/api.rrd", features=False)
except OSError as exc:
    print("OSError", errno.errorcode[exc.errno], exc.filename)
"""


@pytest.mark.skipif(not _unshare_works(), reason="unshare --user --mount is refused here: no small file system to fill")
def test_a_full_disk_is_one_line_and_exit_status_3(tmp_path):
    """A 256 KB tmpfs (in a mount namespace of its own) fills while the .rrd of the hall is written."""
    bag, _, _ = write_simulation("hall", tmp_path / "h.bag", n_scans=80)
    small = tmp_path / "small"
    small.mkdir()
    script = (f"mount -t tmpfs -o size=256k none '{small}' && "
              f"'{BIN / 'labkit'}' -q view '{bag}' --no-features -o '{small}/x.rrd'; echo rc=$?; "
              f"echo left: $(ls -A '{small}'); "
              f"'{sys.executable}' -c '{API_ON_A_FULL_DISK}' '{bag}' '{small}' 2>/dev/null; "  # rerun's own log lines
              f"echo left: $(ls -A '{small}')")
    p = subprocess.run(["unshare", "--user", "--map-root-user", "--mount", "sh", "-c", script], capture_output=True,
                       text=True, timeout=300)
    assert "rc=3" in p.stdout, p.stdout + p.stderr
    assert p.stderr.splitlines() == [f"labkit: error: {small}/x.rrd: No space left on device"], p.stderr
    assert f"OSError ENOSPC {small}/api.rrd" in p.stdout, p.stdout
    assert [ln for ln in p.stdout.splitlines() if ln.startswith("left:")] == ["left:", "left:"]  # nothing left behind
