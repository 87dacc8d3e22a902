"""labkit against the C++ split-and-merge most ROS users run, on the same scans in the same run.

The peer is ``kam3k/laser_line_extraction`` (Pfister-weighted fits, chi-square merge), built without
ROS as ``../shared/peer-cpp/README.md`` says (its harness times ``setRangeData`` + ``extractLines``
per scan, with its README parameters). This script does not fetch or build it: it runs the harness
when it exists, at ``$LABKIT_PEER_HARNESS`` or ``/tmp/peer-cpp/harness``, and says so and prints
labkit's side alone otherwise.

Scans: the Radish intel log (180 beams), the hall world simulated at 361, 722, 1441 and 2881 beams
(5 mm of range noise, :func:`common.world_scans`) and the peer's own six JSON scans (541 beams).
Timing: interleaved rounds -- the harness on a set, then labkit on the same set, round after round
-- each scan timed at its best over the rounds (a pause of the shared machine does not pass for a
slow scan), the median over the scans reported. Every labkit call gets a fresh :class:`labkit.Scan`
built outside the timer from the ranges and angles, so the points, the valid mask and the noise
estimate (cached on a Scan) are computed inside it, as the harness computes its points.

Columns: the C++ microseconds per scan, then labkit's as a ratio to them (below 1: labkit is
faster): :func:`labkit.split_and_merge` at its defaults (the noise followed) and with
:data:`labkit.noise.FIXED_LINES`, :func:`labkit.extract_features` with ``Config()`` (every feature)
and with :data:`labkit.noise.FIXED_CONFIG`. Goals (issue 33), printed met / not met:
split_and_merge default <= 0.25x the peer and extract_features default <= 0.5x at every beam count;
the default ("auto") <= 1.2x the fixed setting.

Run: ``python benchmarks/peer.py [--rounds 5] [--scans 30]``
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import struct
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from common import world_scans

import labkit
from labkit import Config, Scan, extract_features, split_and_merge
from labkit.noise import FIXED_CONFIG, FIXED_LINES

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared" / "datasets"
HARNESS_PLACES = (os.environ.get("LABKIT_PEER_HARNESS", ""), "/tmp/peer-cpp/harness")
GOAL_SM, GOAL_EF, GOAL_AUTO = 0.25, 0.5, 1.2


def harness() -> Path | None:
    for place in HARNESS_PLACES:
        if place and Path(place).is_file() and os.access(place, os.X_OK):
            return Path(place)
    return None


def scan_sets(n_scans: int) -> dict[str, list[Scan]]:
    sets: dict[str, list[Scan]] = {}
    if SHARED.is_dir():
        scans = []
        for scan in labkit.read_scans(SHARED / "carmen" / "intel-corrected.log.gz"):
            scans.append(scan)
            if len(scans) == n_scans:
                break
        sets["intel log, 180"] = scans
    for beams in (361, 722, 1441, 2881):
        sets[f"simulated, {beams}"] = world_scans("hall", beams, n_scans)
    if SHARED.is_dir():
        sets["peer's 6 JSON scans, 541"] = [labkit.read_json_scan(SHARED / "single_scans" / f"laser_scan_{k}.json")
                                            for k in range(1, 7)]
    return sets


def write_llxs(scans: list[Scan], path: Path) -> None:
    """The harness's scan file (see ``harness.cpp``): invalid beams as +inf."""
    with open(path, "wb") as f:
        f.write(b"LLXS" + struct.pack("<II", 1, len(scans)))
        for s in scans:
            ranges = np.where(s.valid, s.ranges, np.inf).astype("<f8")
            f.write(struct.pack("<Idd", s.n_beams, s.range_min, min(s.range_max, 1e300)))
            f.write(s.angles.astype("<f8").tobytes())
            f.write(ranges.tobytes())


def time_peer(exe: Path, scan_file: Path, out: Path, repeat: int) -> np.ndarray:
    """The harness's best microseconds per scan over ``repeat`` passes (after a warm pass)."""
    subprocess.run([str(exe), str(scan_file), "time", str(out), str(repeat)], check=True, capture_output=True)
    rows = [line.split() for line in out.read_text().splitlines() if line.strip()]
    return np.array([float(r[1]) for r in rows])


def time_labkit(fn, scans: list[Scan]) -> np.ndarray:
    """Microseconds of ``fn`` per scan, each call on a fresh Scan built outside the timer."""
    out = np.empty(len(scans))
    for i, s in enumerate(scans):
        fresh = Scan(ranges=s.ranges, angles=s.angles, range_min=s.range_min, range_max=s.range_max)
        t0 = time.perf_counter()
        fn(fresh)
        out[i] = (time.perf_counter() - t0) * 1e6
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds (each scan's best is kept)")
    ap.add_argument("--scans", type=int, default=30, help="scans per set (the JSON set has 6)")
    ap.add_argument("--peer-repeat", type=int, default=3, help="timed passes of the harness per round")
    args = ap.parse_args()
    exe = harness()
    config, fixed = Config(), Config().updated(FIXED_CONFIG)
    methods = {
        "sm": lambda s: split_and_merge(s),
        "sm_fixed": lambda s: split_and_merge(s, **FIXED_LINES),
        "ef": lambda s: extract_features(s, config),
        "ef_fixed": lambda s: extract_features(s, fixed),
    }
    sets = scan_sets(args.scans)
    if not SHARED.is_dir():
        print(f"note: {SHARED} is absent: the Radish and JSON scans are left out")
    if exe is None:
        print("note: the C++ harness was not found (set LABKIT_PEER_HARNESS, or build it to /tmp/peer-cpp/harness "
              "as ../shared/peer-cpp/README.md says): labkit's side alone, in microseconds")
    else:
        print(f"C++ peer: {exe} (kam3k/laser_line_extraction, its README parameters)")
    for s in next(iter(sets.values()))[:2]:  # compile or load the engines before timing
        for fn in methods.values():
            fn(Scan(ranges=s.ranges, angles=s.angles, range_min=s.range_min, range_max=s.range_max))
    best = {name: {m: np.full(len(scans), np.inf) for m in ("peer", *methods)} for name, scans in sets.items()}
    with tempfile.TemporaryDirectory() as tmp:
        files = {}
        for k, (name, scans) in enumerate(sets.items()):
            files[name] = Path(tmp) / f"set{k}.llxs"
            write_llxs(scans, files[name])
        gc.disable()
        try:
            for _ in range(args.rounds):
                for name, scans in sets.items():
                    if exe is not None:
                        b = best[name]
                        b["peer"] = np.minimum(b["peer"], time_peer(exe, files[name], Path(tmp) / "t.txt",
                                                                    args.peer_repeat))
                    for m, fn in methods.items():
                        best[name][m] = np.minimum(best[name][m], time_labkit(fn, scans))
                gc.collect()
        finally:
            gc.enable()
    med = {name: {m: float(np.median(v)) for m, v in b.items()} for name, b in best.items()}
    print(f"\n{args.rounds} interleaved rounds, each scan at its best, median over the scans; fresh Scan per call")
    if exe is not None:
        print(f"{'scans':28s} {'C++ us':>7s} {'split_and_merge':>15s} {'FIXED_LINES':>11s} {'extract_features':>16s} "
              f"{'FIXED_CONFIG':>12s}   (ratio labkit / C++)")
        for name, m in med.items():
            p = m["peer"]
            print(f"{name:28s} {p:7.0f} {m['sm'] / p:15.2f} {m['sm_fixed'] / p:11.2f} {m['ef'] / p:16.2f} "
                  f"{m['ef_fixed'] / p:12.2f}")
    print(f"\n{'scans':28s} {'split_and_merge us':>18s} {'FIXED_LINES us':>14s} {'extract_features us':>19s} "
          f"{'FIXED_CONFIG us':>15s} {'sm auto/fixed':>13s} {'ef auto/fixed':>13s}")
    for name, m in med.items():
        print(f"{name:28s} {m['sm']:18.0f} {m['sm_fixed']:14.0f} {m['ef']:19.0f} {m['ef_fixed']:15.0f} "
              f"{m['sm'] / m['sm_fixed']:13.2f} {m['ef'] / m['ef_fixed']:13.2f}")
    print("\ngoals (issue 33):")
    worst_auto = max(max(m["sm"] / m["sm_fixed"], m["ef"] / m["ef_fixed"]) for m in med.values())
    if exe is not None:
        worst_sm = max(m["sm"] / m["peer"] for m in med.values())
        worst_ef = max(m["ef"] / m["peer"] for m in med.values())
        print(f"  split_and_merge default <= {GOAL_SM}x the peer at every beam count: worst {worst_sm:.2f}x -> "
              f"{'met' if worst_sm <= GOAL_SM else 'not met'}")
        print(f"  extract_features default <= {GOAL_EF}x the peer at every beam count: worst {worst_ef:.2f}x -> "
              f"{'met' if worst_ef <= GOAL_EF else 'not met'}")
    else:
        print("  the goals against the peer need the harness")
    print(f"  default (auto) <= {GOAL_AUTO}x the fixed setting: worst {worst_auto:.2f}x -> "
          f"{'met' if worst_auto <= GOAL_AUTO else 'not met'}")
    if not math.isfinite(worst_auto):
        raise SystemExit("no timing")


if __name__ == "__main__":
    main()
