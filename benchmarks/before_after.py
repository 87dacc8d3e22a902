"""This checkout's labkit against an older one, call for call: the default pipeline and the IAV
detectors per scan, before and after a change that should cost nothing.

Both packages are imported into one process (the older one under the name ``labkit_before``, from a
copy of the folder given), and every timed call alternates between them, in an order that flips
from round to round, so that whatever else the machine does falls on both alike. Every timed call
gets a fresh :class:`labkit.Scan` of its own package (built before the clock starts), so that the
points, the validity mask and the range-noise estimate, which a scan caches, are computed inside
the call as for a scan just read.

Scans: the simulated ``hall`` world (columns, a bench, a rolling cylinder, a walking student: legs)
at 361 and 722 beams over 180 degrees with 5 mm of range noise, spread over the scenario's 60 s.

Run, for example against the commit before issue 32::

    git archive 134c1e4 labkit | tar -x -C /tmp/old
    python benchmarks/before_after.py --before /tmp/old/labkit

Each call is timed twice: on the wall clock, and in the CPU time of the calling thread
(``time.thread_time``), which a shared machine's other work does not add to (the machine this was
written on runs four engineers' tests on two cores). A scan's time is its best over the rounds.
Prints, per function and beam count and for each clock, the median over the scans of that best time,
before and after, and the ratio of their sums (after / before); then the ratio of each round's sums
for the CPU clock (how much one pass over the scans varies).
"""

from __future__ import annotations

import argparse
import gc
import importlib
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import world_scans

import labkit

BEAMS = (361, 722)
FUNCTIONS = ("extract_features", "detect_circles", "detect_legs")


def load(package: Path, name: str):
    """The labkit package at ``package`` (a folder holding ``__init__.py``), imported as ``name``."""
    if not (package / "__init__.py").is_file():
        raise SystemExit(f"{package} is not a package folder (no __init__.py); give the path of its labkit/")
    where = Path(tempfile.mkdtemp(prefix=f"{name}_"))
    shutil.copytree(package, where / name, ignore=shutil.ignore_patterns("__pycache__"))
    sys.path.insert(0, str(where))
    return importlib.import_module(name)


def time_call(fn, scan) -> tuple[float, float]:
    """Seconds of ``fn(scan)`` on the wall clock and in this thread's CPU time."""
    gc.disable()
    try:
        c0, t0 = time.thread_time(), time.perf_counter()
        fn(scan)
        t1, c1 = time.perf_counter(), time.thread_time()
        return t1 - t0, c1 - c0
    finally:
        gc.enable()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", type=Path, required=True, help="the older labkit package folder (.../labkit)")
    ap.add_argument("--after", type=Path, help="another labkit package folder instead of this checkout's (the same "
                                               "as --before measures how far the two sides differ by chance)")
    ap.add_argument("--scans", type=int, default=30, help="scans per beam count")
    ap.add_argument("--rounds", type=int, default=7, help="passes over the scans, each timing before and after")
    args = ap.parse_args()
    before = load(args.before.resolve(), "labkit_before")
    after = labkit if args.after is None else load(args.after.resolve(), "labkit_after")
    sides = {"before": before, "after": after}
    print(f"{platform.processor() or platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}; "
          f"{args.scans} scans x {args.rounds} rounds per row, fresh Scan per call\n")
    print("| function | beams | wall: before (us) | after (us) | after / before | CPU: before (us) | after (us) | "
          "after / before | CPU, per round |")
    print("|---|---|---|---|---|---|---|---|---|")
    for beams in BEAMS:
        raw = [dict(ranges=s.ranges.copy(), angles=s.angles.copy(), range_min=s.range_min, range_max=s.range_max,
                    stamp_ns=s.stamp_ns) for s in world_scans("hall", beams, args.scans)]
        for name in FUNCTIONS:
            fns = {side: getattr(mod, name) for side, mod in sides.items()}
            for side, mod in sides.items():  # warm up: imports, caches of the records, the first numpy calls
                for fields in raw[:3]:
                    fns[side](mod.Scan(**fields))
            times = {side: np.empty((args.rounds, len(raw), 2)) for side in sides}  # round, scan, (wall, cpu)
            for k in range(args.rounds):
                order = list(sides) if k % 2 == 0 else list(sides)[::-1]
                for i, fields in enumerate(raw):
                    for side in order:
                        scan = sides[side].Scan(**fields)
                        times[side][k, i] = time_call(fns[side], scan)
                gc.collect()
            best = {side: t.min(axis=0) for side, t in times.items()}  # per scan and clock
            cells = []
            for clock in (0, 1):
                b, a = best["before"][:, clock], best["after"][:, clock]
                cells.append(f"{np.median(b) * 1e6:.0f} | {np.median(a) * 1e6:.0f} | {a.sum() / b.sum():.3f}")
            rounds = times["after"][:, :, 1].sum(axis=1) / times["before"][:, :, 1].sum(axis=1)
            print(f"| {name} | {beams} | {cells[0]} | {cells[1]} | {rounds.min():.3f}-{rounds.max():.3f} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
