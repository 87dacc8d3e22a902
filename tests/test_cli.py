"""The labkit command line, run as users run it (a subprocess of the installed script)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from labkit import read_scans

LABKIT = [sys.executable, "-m", "labkit.cli"]


def run(*args, cwd=None, ok=True):
    proc = subprocess.run([*LABKIT, "-q", *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=300)
    if ok:
        assert proc.returncode == 0, proc.stderr
    return proc


def test_console_script_is_installed():
    exe = Path(sys.executable).parent / "labkit"
    assert exe.exists() or shutil.which("labkit")


def test_simulate_convert_info_view(tmp_path):
    run("simulate", "office", "-o", tmp_path / "office.bag", "--scans", "20")
    assert (tmp_path / "office.truth.jsonl").exists()
    assert len(list(read_scans(tmp_path / "office.bag"))) == 20
    out = run("convert", tmp_path / "office.bag", tmp_path / "office.mcap").stdout
    assert "wrote 20 scans" in out
    info = run("info", tmp_path / "office.mcap").stdout
    assert "/scan" in info and "sensor_msgs/msg/LaserScan" in info and "20 messages" in info
    out = run("view", tmp_path / "office.bag", "-o", tmp_path / "office.rrd").stdout
    assert "wrote 20 scans and ground truth for 20" in out and (tmp_path / "office.rrd").exists()
    # an existing output is not overwritten without --force
    bad = run("convert", tmp_path / "office.bag", tmp_path / "office.mcap", ok=False)
    assert bad.returncode == 1 and "exists" in bad.stderr
    run("convert", tmp_path / "office.bag", tmp_path / "office.mcap", "--force")


def test_errors_say_what_to_do(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    p = run("view", tmp_path / "notes.txt", "-o", tmp_path / "x.rrd", ok=False)
    assert p.returncode == 1 and "supported formats: ros1" in p.stderr and "Traceback" not in p.stderr
    p = run("simulate", "atrium", "-o", tmp_path / "a.bag", ok=False)
    assert p.returncode == 1 and "hall" in p.stderr
    p = run("info", tmp_path / "missing.bag", ok=False)
    assert p.returncode == 1 and "does not exist" in p.stderr
    p = subprocess.run([*LABKIT], capture_output=True, text=True)
    assert p.returncode == 2 and "COMMAND" in p.stderr


def test_view_of_a_truncated_bag_writes_the_rrd_and_fails(tmp_path):
    run("simulate", "hall", "-o", tmp_path / "h.bag", "--scans", "40")
    bag = tmp_path / "h.bag"
    bag.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2])
    p = run("view", bag, "-o", tmp_path / "h.rrd", ok=False)
    assert p.returncode == 1
    assert "h.bag is damaged" in p.stderr and "scan(s) before the fault were read" in p.stderr
    assert (tmp_path / "h.rrd").exists() and "wrote" in p.stdout


def test_demo_writes_its_outputs(tmp_path):
    out = run("demo", "-o", tmp_path / "out").stdout
    assert (tmp_path / "out" / "demo.rrd").stat().st_size > 0
    assert (tmp_path / "out" / "demo.png").stat().st_size > 0
    assert "600 scans of 361 beams" in out and "rerun" in out and "make lab" in out


@pytest.mark.parametrize("args", [["--help"], ["view", "--help"], ["simulate", "--help"]])
def test_help(args):
    assert "usage" in run(*args).stdout
