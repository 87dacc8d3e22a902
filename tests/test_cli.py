"""The labkit command line, run as users run it (a subprocess of the installed script)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from labkit import read_scans
from tests.cli_here import in_process

LABKIT = [sys.executable, "-m", "labkit.app.cli"]


def run(*args, cwd=None, ok=True):
    """``labkit -q ARGS``: in this process (a fresh one costs seconds of imports per call; the process-level
    behaviour -- Ctrl-C, pipes, the installed script -- is tests/test_cli_safety.py's), or in a process of
    its own when it must run in another folder (``cwd``)."""
    if cwd is not None:
        proc = subprocess.run([*LABKIT, "-q", *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=300)
    else:
        proc = in_process(*args)
    if ok:
        assert proc.returncode == 0, proc.stderr
    return proc


def run_here(*args) -> None:
    """The command line in this process (a fresh process costs seconds of imports per call): for tests
    that check what a command computes, not how it starts or exits."""
    from labkit.app.cli import main

    assert main(["-q", *map(str, args)]) == 0


def test_console_script_is_installed():
    exe = Path(sys.executable).parent / "labkit"
    assert exe.exists() or shutil.which("labkit")


def test_simulate_convert_info_view(tmp_path):
    run("simulate", "office", "-o", tmp_path / "office.bag", "--scans", "20")
    assert (tmp_path / "office.truth.jsonl").exists()
    assert len(list(read_scans(tmp_path / "office.bag"))) == 20
    out = run("convert", tmp_path / "office.bag", tmp_path / "office.mcap").stdout
    assert "wrote 40 messages of 2 topics (20 scans)" in out  # the scans and their odometry
    info = run("info", tmp_path / "office.mcap").stdout
    assert "/scan" in info and "sensor_msgs/msg/LaserScan" in info and "20 messages" in info
    out = run("view", tmp_path / "office.bag", "-o", tmp_path / "office.rrd").stdout
    assert "wrote 20 scans and ground truth for 20" in out and (tmp_path / "office.rrd").exists()
    # an existing output is not overwritten without --force
    bad = run("convert", tmp_path / "office.bag", tmp_path / "office.mcap", ok=False)
    assert bad.returncode == 2 and "exists; pass -f" in bad.stderr
    run("convert", tmp_path / "office.bag", tmp_path / "office.mcap", "--force")


def test_errors_say_what_to_do(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    p = run("view", tmp_path / "notes.txt", "-o", tmp_path / "x.rrd", ok=False)
    assert p.returncode == 2 and "supported formats: ros1" in p.stderr and "Traceback" not in p.stderr
    p = run("simulate", "atrium", "-o", tmp_path / "a.bag", ok=False)
    assert p.returncode == 2 and "hall" in p.stderr
    p = run("info", tmp_path / "missing.bag", ok=False)
    assert p.returncode == 2 and "does not exist" in p.stderr
    p = subprocess.run([*LABKIT], capture_output=True, text=True)
    assert p.returncode == 2 and "COMMAND" in p.stderr


def test_info_describes_the_scans(tmp_path):
    """Beams, field of view, duration, scan rate and pose sources of a bag the test writes: 50
    scans of 271 beams over -135..135 deg at 20 Hz, with odometry."""
    from rosbags import rosbag1

    from labkit.io import salvage

    ts = salvage.typestore(True)
    t = ts.types
    bag = tmp_path / "r.bag"
    with rosbag1.Writer(bag) as writer:
        scan = writer.add_connection("/front", "sensor_msgs/msg/LaserScan", typestore=ts)
        odom = writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
        for k in range(50):
            ns = 5 * 10**9 + k * 50_000_000
            stamp = t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            msg = t["sensor_msgs/msg/LaserScan"](
                header=t["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id="laser"), angle_min=-np.radians(135),
                angle_max=np.radians(135), angle_increment=np.radians(1.0), time_increment=0.0, scan_time=0.05,
                range_min=0.0, range_max=10.0, ranges=np.full(271, 3.0, np.float32),
                intensities=np.zeros(0, np.float32))
            writer.write(scan, ns, ts.serialize_ros1(msg, "sensor_msgs/msg/LaserScan"))
            quat = t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
            pose = t["geometry_msgs/msg/Pose"](position=t["geometry_msgs/msg/Point"](x=0.1 * k, y=0.0, z=0.0),
                                               orientation=quat)
            zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
            o = t["nav_msgs/msg/Odometry"](
                header=t["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id="odom"), child_frame_id="laser",
                pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                twist=t["geometry_msgs/msg/TwistWithCovariance"](
                    twist=t["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=np.zeros(36)))
            writer.write(odom, ns, ts.serialize_ros1(o, "nav_msgs/msg/Odometry"))
    out = run("info", bag).stdout
    assert "scans (/front): 50\n" in out
    assert "beams: 271\n" in out
    assert "field of view: 270 deg (-135 to 135 deg, 1 deg per beam)" in out
    assert "duration: 2.45 s, 20 scans/s" in out  # 49 steps of 50 ms
    assert "poses: odometry /odom (50 of 50 scans have one; laser: odometry /odom (odom -> laser))" in out


def test_view_of_a_truncated_bag_writes_the_rrd_and_fails(tmp_path):
    run("simulate", "hall", "-o", tmp_path / "h.bag", "--scans", "40")
    bag = tmp_path / "h.bag"
    bag.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2])
    p = run("view", bag, "-o", tmp_path / "h.rrd", ok=False)
    assert p.returncode == 1
    assert "h.bag is damaged at byte" in p.stderr and "the file ends" in p.stderr and "Traceback" not in p.stderr
    assert (tmp_path / "h.rrd").exists() and "wrote" in p.stdout


def test_demo_writes_its_outputs(tmp_path):
    out = run("demo", "-o", tmp_path / "out").stdout
    assert (tmp_path / "out" / "demo.rrd").stat().st_size > 0
    assert (tmp_path / "out" / "demo.png").stat().st_size > 0
    assert "600 scans of 361 beams" in out and "rerun" in out and "make lab" in out


@pytest.mark.parametrize("args", [["--help"], ["view", "--help"], ["simulate", "--help"]])
def test_help(args):
    assert "usage" in run(*args).stdout


def test_extract_writes_one_record_per_scan_with_the_pipelines_features(tmp_path):
    """The JSON lines hold, per scan, exactly what extract_features finds in that scan."""
    from labkit import extract_features, read_features

    run("simulate", "hall", "-o", tmp_path / "h.bag", "--scans", "15")
    out = run("extract", tmp_path / "h.bag", "-o", tmp_path / "h.features.jsonl").stdout
    assert "wrote features of 15 scans" in out and "lines" in out
    records = list(read_features(tmp_path / "h.features.jsonl"))
    assert [r["scan"] for r in records] == list(range(15))
    for record, scan in zip(records, read_scans(tmp_path / "h.bag"), strict=True):
        want = extract_features(scan).as_record()
        assert record["stamp_ns"] == scan.stamp_ns and record["counts"] == want["counts"]
        assert [f["type"] for f in record["features"]] == [f["type"] for f in want["features"]]
        for got, exp in zip(record["features"], want["features"], strict=True):
            assert (got["first"] if "first" in got else None) == exp.get("first")
            for key in ("start", "end", "center", "r", "alpha", "radius"):
                if key in exp:
                    np.testing.assert_allclose(got[key], exp[key], rtol=1e-12, atol=1e-12)


def test_extract_to_stdout_and_with_a_config_file(tmp_path):
    run("simulate", "office", "-o", tmp_path / "o.bag", "--scans", "5")
    run("config", "-o", tmp_path / "c.toml")
    text = (tmp_path / "c.toml").read_text()
    assert "[lines]" in text and 'method = "iepf"' in text
    (tmp_path / "c.toml").write_text(text.replace('method = "iepf"', 'method = "angular"'))
    p = run("extract", tmp_path / "o.bag", "--config", tmp_path / "c.toml")
    lines = p.stdout.splitlines()
    assert len(lines) == 5 and all(json.loads(ln)["features"] is not None for ln in lines)
    assert "lines by angular" in p.stderr
    # a typo in the config is named, with the keys that exist
    (tmp_path / "bad.toml").write_text("[lines]\nsplit_threshold = 0.1\n")
    bad = run("extract", tmp_path / "o.bag", "--config", tmp_path / "bad.toml", ok=False)
    assert bad.returncode == 2 and "lines.split_threshold" in bad.stderr and "split_threshold_m" in bad.stderr
    missing = run("extract", tmp_path / "o.bag", "--config", tmp_path / "none.toml", ok=False)
    assert missing.returncode == 2 and "labkit config -o" in missing.stderr


def test_range_noise_makes_every_stage_follow_the_noise(tmp_path):
    """``--range-noise auto|M|fixed``: the features are extract_features' with the noise-following
    keys (written out here as the README lists them), estimated from each scan (also with no
    flag: the default) or from the given noise, or with the papers' fixed thresholds; ``labkit
    config --range-noise`` writes the same setting; a bad value is refused."""
    from labkit import Config, extract_features, read_features

    bag, out = tmp_path / "o.bag", tmp_path / "o.jsonl"
    run("simulate", "office", "-o", bag, "--scans", "6")
    scans = list(read_scans(bag))

    def setting(sigma, method):
        return Config().updated({
            "lines.method": method, "segmentation.range_sigma_m": sigma, "circles.range_sigma_m": sigma,
            "legs.range_sigma_m": sigma, "lines.split_threshold_m": "auto", "lines.range_sigma_m": sigma,
            "lines.place_confidence": 0.8, "lines.ransac.threshold_m": "auto", "lines.ransac.range_sigma_m": sigma,
            "lines.ransac.place_confidence": 0.8})

    def features(records):
        return [[(f["type"], f.get("first"), round(f.get("r", f.get("radius", 0.0)), 9)) for f in r["features"]]
                for r in records]

    def fixed(method):  # the papers' thresholds, the defaults before "auto"
        return Config().updated({
            "lines.method": method, "segmentation.range_sigma_m": 0.01, "circles.range_sigma_m": 0.0,
            "legs.range_sigma_m": 0.0, "lines.split_threshold_m": 0.05, "lines.range_sigma_m": 0.01,
            "lines.place_confidence": 0.0, "lines.ransac.threshold_m": 0.03, "lines.ransac.range_sigma_m": None,
            "lines.ransac.place_confidence": 0.0})

    for method in ("iepf", "ransac"):
        old = features(extract_features(s, fixed(method)).as_record() for s in scans)
        for value, sigma in ((None, "auto"), ("auto", "auto"), ("0.02", 0.02), ("fixed", None)):
            run_here("extract", bag, *(("--range-noise", value) if value else ()), "--method", method, "-o", out,
                     "-f")
            got = features(read_features(out))
            want = old if value == "fixed" else features(
                extract_features(s, setting(sigma, method)).as_record() for s in scans)
            assert got == want and (got == old) == (value == "fixed"), (value, method)
    run("config", "--range-noise", "0.02", "-o", tmp_path / "c.toml")
    assert Config.load(tmp_path / "c.toml") == setting(0.02, "iepf").updated(
        {"lines.angular.direction_window": "auto", "lines.angular.range_sigma_m": 0.02,
         "lines.incremental.max_error_m": "auto", "lines.incremental.range_sigma_m": 0.02,
         "lines.incremental.place_confidence": 0.8, "lines.hough.threshold_m": "auto",
         "lines.hough.range_sigma_m": 0.02, "lines.hough.place_confidence": 0.8})
    for bad in ("0", "-0.01", "loud", "nan"):
        p = run("extract", bag, "--range-noise", bad, ok=False)
        assert p.returncode == 2 and "--range-noise" in p.stderr.splitlines()[-1], bad


def test_extract_from_a_truncated_bag_keeps_every_scan_before_the_fault(tmp_path):
    run("simulate", "hall", "-o", tmp_path / "h.bag", "--scans", "40")
    bag = tmp_path / "h.bag"
    bag.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2])
    readable = 0
    try:
        for _ in read_scans(bag):
            readable += 1
    except ValueError:
        pass
    p = run("extract", bag, "-o", tmp_path / "h.jsonl", ok=False)
    assert p.returncode == 1 and "h.bag is damaged" in p.stderr
    assert 10 < readable < 40
    assert len((tmp_path / "h.jsonl").read_text().splitlines()) == readable


def test_bench_prints_a_stage_table(tmp_path):
    out = run("bench", "--scans", "30").stdout
    for stage in ("segmentation", "legs", "circles", "lines", "corners", "total"):
        assert stage in out
    assert "30 scans of 361 beams" in out and "bag -> features -> .rrd" in out
