"""Per-scan cost of the IAV circle detector and the leg detector, against split-and-merge.

For 361 / 722 / 1441 beams over 180 degrees (steps of 180 / (N - 1) degrees: 0.5, 0.2497,
0.125), scans of the simulated ``hall`` world (Xavier et al.'s static test: columns, a
bench, a rolling cylinder and a walking student; static sensor, 5 mm range noise) spread
over the scenario's 60 s:

* ``segment``: the detectors' range segmentation, :func:`labkit.segment_labels` at 0.08 m
  (``range_segments``, which also builds a record per segment, costs about 200 us more)
* ``circles``: :func:`labkit.circles.iav_circles.detect_circles` (segmentation included)
* ``arc-like``: the same with ``arc_like=True``
* ``legs``: :func:`labkit.circles.legs.detect_legs` (segmentation included)
* ``legs+people``: legs and :func:`labkit.circles.legs.pair_legs`
* ``s&m``: :func:`labkit.split_and_merge` with its defaults, when ``labkit.lines.split_merge`` exists

Times are the median and the largest per-scan time over the scans, each scan timed at its
best of ``--repeat`` passes.
The ratio columns compare circles and legs with split-and-merge in the same run. Xavier
et al. (2005, Sec. IV-D) report 1.082 ms as the worst time for circles per 360-beam scan on
a 500 MHz Celeron; the last line says how far below that this machine's worst time is.

Run: ``python benchmarks/circles.py [--scans 60] [--repeat 5]``
"""

from __future__ import annotations

import argparse
import platform

import numpy as np
from common import per_scan, world_scans

from labkit.circles.iav_circles import detect_circles
from labkit.circles.legs import detect_legs, pair_legs
from labkit.segmentation import segment_labels

try:
    from labkit.lines.split_merge import split_and_merge
except ImportError:  # the line extractor is optional here
    split_and_merge = None

BEAMS = (361, 722, 1441)
PAPER_WORST_CIRCLES_S = 1.082e-3  # Xavier et al. 2005, Sec. IV-D, 360 beams, Celeron 500 MHz


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scans", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()

    stages = {
        "segment": lambda s: segment_labels(s, threshold_m=0.08, adaptive=False),
        "circles": detect_circles,
        "arc-like": lambda s: detect_circles(s, arc_like=True),
        "legs": detect_legs,
        "legs+people": lambda s: pair_legs(detect_legs(s)),
    }
    if split_and_merge is not None:
        stages["s&m"] = split_and_merge
    rows = {}
    for n in BEAMS:
        scans = world_scans("hall", n, args.scans)
        for s in scans:  # warm the cached properties, as a reader would have
            _ = s.points, s.valid
        rows[n] = {name: per_scan(fn, scans, args.repeat) for name, fn in stages.items()}
        rows[n]["n_circles"] = float(np.mean([len(detect_circles(s)) for s in scans]))
        rows[n]["n_legs"] = float(np.mean([len(detect_legs(s)) for s in scans]))

    print(f"hall world, 180 deg, median (largest) per scan over {args.scans} scans, each the best of "
          f"{args.repeat} passes; "
          f"{platform.processor() or platform.machine()}, Python {platform.python_version()}, "
          f"numpy {np.__version__}\n")
    head = "| beams | " + " | ".join(f"{k} (us)" for k in stages) + " | circles/scan | legs/scan |"
    if split_and_merge is not None:
        head += " circles / s&m | legs / s&m |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for n, r in rows.items():
        cells = " | ".join(f"{r[k][0] * 1e6:.0f} ({r[k][1] * 1e6:.0f})" for k in stages)
        line = f"| {n} | {cells} | {r['n_circles']:.1f} | {r['n_legs']:.1f} |"
        if split_and_merge is not None:
            line += f" {r['circles'][0] / r['s&m'][0]:.2f} | {r['legs'][0] / r['s&m'][0]:.2f} |"
        print(line)
    worst = rows[361]["circles"][1]
    print(f"\nWorst circles time at 361 beams: {worst * 1e3:.3f} ms, {PAPER_WORST_CIRCLES_S / worst:.1f}x below "
          f"Xavier et al.'s 1.082 ms (360 beams, Celeron 500 MHz, C++).")


if __name__ == "__main__":
    main()
