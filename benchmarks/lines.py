"""Per-scan cost of line extraction, and the split step against a Ramer-Douglas-Peucker peer.

For 361 / 721 / 1441 / 2881 beams over 180 degrees (0.5 / 0.25 / 0.125 / 0.0625 deg steps),
scans of the simulated ``office`` world along its trajectory (LMS200-like 5 mm noise):

* ``segment``: adaptive range segmentation (:func:`labkit.segment_labels`)
* ``fit``: one weighted polar fit per range segment (:func:`labkit.fit_line_polar`)
* ``s&m``: :func:`labkit.split_and_merge` (segmentation, IEPF split, merge, covariances)
* ``+corners``: the same plus :func:`labkit.find_corners`
* ``split only``: split-and-merge without merging (``merge=None``)
* ``rdp``: the PyPI ``rdp`` package's Ramer-Douglas-Peucker on each range segment with the
  same 5 cm tolerance -- the split step alone, with no fitting, merging or covariance

Times are the median per scan, each scan at its best of ``--repeat`` passes. The last columns
are ratios in the same run: how the cost grows with beams (vs 361), and s&m against rdp.

Run: ``python benchmarks/lines.py [--scans 30] [--repeat 3]``
"""

from __future__ import annotations

import argparse

import numpy as np
from common import per_scan, world_scans
from rdp import rdp

from labkit import find_corners, fit_line_polar, segment_labels, split_and_merge
from labkit.segmentation import segments_from_labels

BEAMS = (361, 721, 1441, 2881)


def fit_segments(scan):
    for seg in segments_from_labels(scan, segment_labels(scan, adaptive=True)):
        if seg.n_points >= 2:
            fit_line_polar(scan.ranges[seg.indices], scan.angles[seg.indices])


def rdp_segments(scan):
    for seg in segments_from_labels(scan, segment_labels(scan, adaptive=True)):
        rdp(seg.points, epsilon=0.05)


def with_corners(scan):
    find_corners(split_and_merge(scan))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scans", type=int, default=30)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    stages = {
        "segment": lambda s: segment_labels(s, adaptive=True),
        "fit": fit_segments,
        "s&m": split_and_merge,
        "+corners": with_corners,
        "split only": lambda s: split_and_merge(s, merge=None),
        "rdp": rdp_segments,
    }
    rows = {}
    for n in BEAMS:
        scans = world_scans("office", n, args.scans)
        rows[n] = {name: per_scan(fn, scans, args.repeat)[0] for name, fn in stages.items()}
        rows[n]["lines"] = float(np.mean([len(split_and_merge(s)) for s in scans]))

    print(f"office world, 180 deg, median per scan over {args.scans} scans (each the best of {args.repeat})\n")
    head = "| beams | " + " | ".join(f"{k} (us)" for k in stages) + " | lines/scan | s&m vs 361 | s&m / rdp |"
    print(head)
    print("|" + "---|" * (len(stages) + 4))
    base = rows[361]["s&m"]
    for n, r in rows.items():
        cells = " | ".join(f"{r[k] * 1e6:.0f}" for k in stages)
        print(f"| {n} | {cells} | {r['lines']:.1f} | {r['s&m'] / base:.2f}x | {r['s&m'] / r['rdp']:.2f} |")


if __name__ == "__main__":
    main()
