"""Every feature of the reference scans, hashed: a refactoring that changes no behaviour leaves
every line of the dump unchanged.

The sets: the bundled recordings (``data/hall.bag``, ``data/corridor.mcap``, ``data/office``),
scans of the simulated worlds at 361, 722, 1441 and 2881 beams (5 mm and 2 cm of range noise), the
peer's six JSON scans and the first 300 scans of the six Radish logs (``../shared/datasets``, when
present). For every scan: :func:`labkit.extract_features` with the default :class:`labkit.Config`
and with :data:`labkit.noise.FIXED_CONFIG`, and every registered line extractor called alone at its
defaults. Each feature is written exactly: floats as ``float.hex``, arrays as their dtype, shape and
bytes (hashed), so one flipped bit shows.

Run before and after a change and compare::

    python benchmarks/feature_dump.py -o /tmp/before.txt
    ...
    python benchmarks/feature_dump.py -o /tmp/after.txt
    diff /tmp/before.txt /tmp/after.txt      # one line per set and method, then one per scan

Only the public API is used, so the script runs unchanged on both sides of a refactoring.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import sys
from pathlib import Path

import numpy as np
from common import world_scans

import labkit
from labkit.lines import LINE_EXTRACTORS
from labkit.noise import FIXED_CONFIG

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared" / "datasets"
RADISH = ("aces", "csail", "freiburg-079", "infinite-corridor", "intel", "orebro")


def _put(h, value) -> None:
    """Feed one value into the hash, exactly and with its type."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(type(value).__name__.encode())
        for f in dataclasses.fields(value):
            if f.name == "timings":
                continue
            h.update(f.name.encode())
            _put(h, getattr(value, f.name))
    elif isinstance(value, np.ndarray):
        h.update(f"{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (list, tuple)):
        h.update(f"{type(value).__name__}{len(value)}".encode())
        for v in value:
            _put(h, v)
    elif isinstance(value, dict):
        for k in sorted(value):
            h.update(str(k).encode())
            _put(h, value[k])
    elif isinstance(value, (float, np.floating)):
        h.update(float(value).hex().encode())
    elif isinstance(value, (bool, int, np.integer, str, type(None))):
        h.update(repr(value if not isinstance(value, np.integer) else int(value)).encode())
    else:
        raise TypeError(f"cannot hash a {type(value).__name__}")


def digest(value) -> str:
    h = hashlib.sha256()
    _put(h, value)
    return h.hexdigest()[:16]


def reference_sets(radish_scans: int) -> dict[str, list]:
    sets: dict[str, list] = {}
    for name in ("hall.bag", "corridor.mcap", "office"):
        sets[name] = list(labkit.read_scans(ROOT / "data" / name))
    for world in ("hall", "corridor", "office"):
        for beams in (361, 722, 1441, 2881):
            for noise in (0.005, 0.02):
                sets[f"{world}-{beams}-{noise * 1000:g}mm"] = world_scans(world, beams, 12, noise_std_m=noise)
    if SHARED.is_dir():
        sets["json"] = [labkit.read_json_scan(SHARED / "single_scans" / f"laser_scan_{k}.json") for k in range(1, 7)]
        for log in RADISH:
            scans = []
            for scan in labkit.read_scans(SHARED / "carmen" / f"{log}-corrected.log.gz"):
                scans.append(scan)
                if len(scans) == radish_scans:
                    break
            sets[log] = scans
    else:
        print(f"note: {SHARED} is absent: the real scans are left out", file=sys.stderr)
    return sets


def methods() -> dict[str, object]:
    fixed = labkit.Config().updated(FIXED_CONFIG)
    out = {"pipeline": lambda s: labkit.extract_features(s),
           "pipeline-fixed": lambda s: labkit.extract_features(s, fixed)}
    out["segment_labels"] = lambda s: labkit.segment_labels(s)
    out["range_noise"] = lambda s: labkit.estimate_range_noise(s)
    out["circles"] = lambda s: labkit.detect_circles(s)
    out["arcs"] = lambda s: labkit.detect_arcs(s)
    out["legs"] = lambda s: labkit.detect_legs(s)
    for name, entry in sorted(LINE_EXTRACTORS.items()):
        out[f"lines-{name}"] = lambda s, entry=entry: entry.run(s)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", type=Path, required=True, help="the dump (text, one line per hash)")
    ap.add_argument("--radish-scans", type=int, default=300, help="scans read from each Radish log")
    args = ap.parse_args()
    sets = reference_sets(args.radish_scans)
    lines = []
    for set_name, scans in sets.items():
        for method, fn in methods().items():
            per_scan = [digest(fn(s)) for s in scans]
            lines.append(f"{set_name} {method} {len(scans)} scans {digest(per_scan)}")
            lines += [f"  {set_name} {method} scan {i} {d}" for i, d in enumerate(per_scan)]
        print(f"{set_name}: {len(scans)} scans", file=sys.stderr)
    tmp = args.output.with_name(args.output.name + ".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(args.output)
    print(f"{sum(len(s) for s in sets.values())} scans, {len(methods())} methods -> {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
