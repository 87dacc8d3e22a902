"""Reading and writing speed of labkit's I/O against rosbags itself, in one run.

    .venv/bin/python benchmarks/io.py [--repeat 3] [--scans 2000]

For each bag format, a simulated recording (LMS111-like, 541 beams) is written with
labkit, then read three ways: rosbags alone (AnyReader + deserialize, the floor labkit
builds on), labkit's ``read_scans`` (which also builds a validated ``Scan`` per message),
and the CARMEN/JSON-lines readers for scale. The ratio column is labkit's time over
rosbags' time for the same file: the cost of turning messages into Scans.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from labkit import read_scans, sim, write_scans
from labkit.viz import rr as lkrr


def best_of(repeat: int, fn) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def rosbags_only(path: Path) -> int:
    n = 0
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        for conn, _, raw in reader.messages():
            reader.deserialize(raw, conn.msgtype)
            n += 1
    return n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scans", type=int, default=2000)
    args = ap.parse_args()

    sc = sim.scenario("corridor")
    t0 = time.perf_counter()
    scans = [s for s, _ in sim.simulate(sc, seed=0, n_scans=args.scans)]
    t_sim = time.perf_counter() - t0
    n = len(scans)
    print(f"{n} scans of {scans[0].n_beams} beams; simulated at {n / t_sim:,.0f} scans/s\n")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for label, name in [("ROS1 .bag", "a.bag"), ("MCAP", "b.mcap"), ("ROS2 sqlite3", "c_ros2"),
                            ("JSON lines", "d.jsonl")]:
            path = tmp / name
            t_write = best_of(1, lambda p=path: write_scans(scans, p, overwrite=True))
            t_labkit = best_of(args.repeat, lambda p=path: sum(1 for _ in read_scans(p)))
            if name.endswith(".jsonl"):
                t_peer = float("nan")
            else:
                t_peer = best_of(args.repeat, lambda p=path: rosbags_only(p))
            rows.append((label, n / t_write, n / t_peer, n / t_labkit, t_labkit / t_peer))
        t_rrd = best_of(1, lambda: lkrr.record(tmp / "a.bag", tmp / "a.rrd"))
    print(f"{'format':14s} {'write/s':>10s} {'rosbags read/s':>15s} {'labkit read/s':>14s} {'labkit/rosbags':>15s}")
    for label, w, peer, ours, ratio in rows:
        print(f"{label:14s} {w:10,.0f} {peer:15,.0f} {ours:14,.0f} {ratio:15.2f}")
    print(f"\nbag -> .rrd (labkit view, with range segments): {n / t_rrd:,.0f} scans/s")
    print(f"(reads: best of {args.repeat} runs)")


if __name__ == "__main__":
    main()
