"""Reading and writing speed of labkit's I/O against rosbags itself, and the memory of ``labkit view``.

    .venv/bin/python benchmarks/io.py [--repeat 3] [--scans 2000] [--memory-scans 10000 100000]

For each bag format, a simulated recording (LMS111-like, 541 beams) is written with
labkit, then read three ways: rosbags alone (AnyReader + deserialize, the floor labkit
builds on), labkit's ``read_scans`` (which also builds a validated ``Scan`` per message),
and the CARMEN/JSON-lines readers for scale. The ratio column is labkit's time over
rosbags' time for the same file: the cost of turning messages into Scans.

Memory: the peak resident memory of ``labkit view`` (the command line: read, extract every feature,
write the ``.rrd`` with the ground truth beside the recording) of the first 10,000 and of all 100,000
scans of one simulated recording (the corridor, 541 beams), each in a fresh process, beside two
floors: a process that has only imported what ``view`` imports, and one that has also extracted one
scan's features (labkit's numba engines loaded: some 150 MiB, 100 of them llvmlite's library mapped
from disk). Each is run with numba's engines and without (``LABKIT_NO_JIT=1``), and printed as total,
anonymous and file-backed memory, with the view's scans per second. The goal (issue 30): <= 300 MB at
100,000 scans and flat in the number of scans; the last lines say whether it is met, counting all
resident memory or only the anonymous part. One thing that grows with the recording is the ``.rrd``
footer, which rerun keeps in memory until the file is closed (see ``labkit.viz.rr.entities._Chunked``).
``--memory-scans 0`` skips it (the 100,000-scan recording takes minutes to simulate and to view on
idle cores, hours on a loaded machine: ``--memory-scans 1000 4000`` prints the growth per scan
between the two and what it gives at 100,000 scans).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from labkit import read_scans, sim, write_scans
from labkit.app.record import record


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


# The peak is this process's own high-water mark (VmHWM): getrusage's ru_maxrss of a child counts the
# parent's resident memory at the fork as well. The peaks of its anonymous and file-backed parts have no
# high-water mark: a thread samples them every 20 ms (a peak shorter than that can be missed).
VIEW = """
import json, sys, threading, time
FIELDS = ("VmHWM", "RssAnon", "RssFile")
peak = dict.fromkeys(FIELDS, 0)
def sample():
    with open("/proc/self/status") as fh:
        for line in fh:
            key = line.split(":")[0]
            if key in FIELDS:
                peak[key] = max(peak[key], int(line.split()[1]))
def sampler():
    while True:
        sample()
        time.sleep(0.02)
threading.Thread(target=sampler, daemon=True).start()
bag, out, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
from labkit.app.cli import _arrow_without_pandas, main
_arrow_without_pandas()  # as labkit view does, before rerun
import labkit.app.record
seconds = 0.0
if n > 0:
    t0 = time.perf_counter()
    assert main(["view", bag, "-o", out, "--scans", f"0:{n}", "-q"]) == 0
    seconds = time.perf_counter() - t0
elif n < 0:  # the pipeline's floor: one scan's features (numba's engines loaded unless LABKIT_NO_JIT), nothing written
    from labkit import Config, extract_features, read_scans
    extract_features(next(iter(read_scans(bag))), Config())
sample()
print(json.dumps({"total": peak["VmHWM"] / 1024, "anon": peak["RssAnon"] / 1024, "file": peak["RssFile"] / 1024,
                  "seconds": seconds}))
"""

GOAL_MIB = 300e6 / 2**20


def view_memory(counts: list[int], bag: Path | None = None) -> None:
    """Peak RSS of labkit view (the command line) of the first n scans of one simulated recording (``bag``,
    else simulated here: the corridor, with its ground truth), each in a fresh process, with numba's engines
    and without (``LABKIT_NO_JIT=1``)."""
    import json
    import os

    from labkit.app.data import write_simulation

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if bag is None:
            t0 = time.perf_counter()
            bag, _, _ = write_simulation("corridor", tmp / "long.bag", "ros1", seed=0, n_scans=max(counts))
            print(f"\nsimulated {max(counts):,} scans of 541 beams (and their ground truth) in "
                  f"{time.perf_counter() - t0:.0f} s")
        rows = []
        for n in [0, -1, *counts]:
            for jit in (True, False):  # interleaved: the two modes of one count run back to back
                env = {k: v for k, v in os.environ.items() if k != "LABKIT_NO_JIT"}
                if not jit:
                    env["LABKIT_NO_JIT"] = "1"
                out = tmp / f"v{n}_{jit}.rrd"
                p = subprocess.run([sys.executable, "-c", VIEW, str(bag), str(out), str(n)], capture_output=True,
                                   text=True, check=True, env=env)
                if n > 0:
                    assert f"wrote {n} scans and ground truth for {n} " in p.stdout, p.stdout
                rows.append((n, jit, json.loads(p.stdout.splitlines()[-1]), out.stat().st_size / 1e6 if n > 0 else 0.0))
                out.unlink(missing_ok=True)
    print("\n## Peak resident memory of labkit view (features and ground truth), a fresh process each\n")
    print("total: VmHWM; anonymous and file-backed (mostly shared libraries, e.g. llvmlite's LLVM): the largest "
          "sampled every 20 ms\n")
    print("| scans | numba | peak total (MiB) | peak anonymous (MiB) | peak file-backed (MiB) | .rrd (MB) | scans/s |")
    print("|---|---|---|---|---|---|---|")
    for n, jit, m, size in rows:
        label = f"{n:,}" if n > 0 else "none: imports only" if n == 0 else "none: one scan's features (the floor)"
        rate = f"{n / m['seconds']:,.0f}" if n > 0 else ""
        print(f"| {label} | {'yes' if jit else 'no (LABKIT_NO_JIT=1)'} | {m['total']:,.0f} | {m['anon']:,.0f} | "
              f"{m['file']:,.0f} | {size:,.0f} | {rate} |")
    print(f"\ngoal (issue 30): <= 300 MB ({GOAL_MIB:,.0f} MiB) at 100,000 scans, flat in the number of scans")
    for jit in (True, False):
        mine = [(n, m) for n, j, m, _ in rows if j == jit and n > 0]
        floor = next(m for n, j, m, _ in rows if j == jit and n < 0)
        mode = "with numba" if jit else "LABKIT_NO_JIT=1"
        for key, what in (("total", "total"), ("anon", "anonymous only")):
            if len(mine) > 1:  # the growth per scan between the smallest and the largest count, and where it leads
                (n0, m0), (n1, m1) = mine[0], mine[-1]
                slope = (m1[key] - m0[key]) / (n1 - n0)
                at = m1[key] + slope * (100_000 - n1)
                trend = f"slope {slope * 1024:+.2f} KiB per scan between {n0:,} and {n1:,} scans, so "
            else:
                (n1, m1), at, trend = mine[-1], mine[-1][1][key], ""
            print(f"  {mode}, {what}: {trend}{at:,.0f} MiB at 100,000 scans (the floor: {floor[key]:,.0f} MiB): "
                  f"{'met' if at <= GOAL_MIB else 'NOT met'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scans", type=int, default=2000)
    ap.add_argument("--memory-scans", type=int, nargs="+", default=[10000, 100000],
                    help="view this many scans for the memory table (0: skip it)")
    ap.add_argument("--memory-bag", type=Path, help="a recording of at least that many scans, with its ground truth "
                    "(`labkit simulate corridor -o long.bag --scans 100000`; default: simulated here)")
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
        t_rrd = best_of(1, lambda: record(tmp / "a.bag", tmp / "a.rrd"))
    print(f"{'format':14s} {'write/s':>10s} {'rosbags read/s':>15s} {'labkit read/s':>14s} {'labkit/rosbags':>15s}")
    for label, w, peer, ours, ratio in rows:
        print(f"{label:14s} {w:10,.0f} {peer:15,.0f} {ours:14,.0f} {ratio:15.2f}")
    print(f"\nbag -> .rrd (labkit view, with range segments): {n / t_rrd:,.0f} scans/s")
    print(f"(reads: best of {args.repeat} runs)")
    counts = [n for n in args.memory_scans if n > 0]
    if counts:
        view_memory(sorted(counts), args.memory_bag)


if __name__ == "__main__":
    main()
