"""What the per-scan benchmarks share: scans of a simulated world, and per-scan timing."""

from __future__ import annotations

import math
import time

import numpy as np

from labkit.sim import Lidar, make_world, scan_at, scenario


def world_scans(world: str, n_beams: int, n_scans: int, *, seed: int = 0, noise_std_m: float = 0.005) -> list:
    """``n_scans`` scans of the bundled scenario ``world`` along its trajectory, by a lidar
    of ``n_beams`` beams over 180 degrees, with their points and masks already computed
    (as a reader would hand them over)."""
    sc = scenario(world)
    lidar = Lidar(f"bench{n_beams}", -math.pi / 2, math.pi / (n_beams - 1), n_beams, range_max=32.0,
                  noise_std_m=noise_std_m)
    geometry = make_world(world)
    rng = np.random.default_rng(seed)
    times = np.linspace(0.0, sc.duration_s * 0.95, n_scans)
    scans = [scan_at(geometry, lidar, sc.trajectory.pose_at(t), t, rng=rng)[0] for t in times]
    for s in scans:
        _ = s.points, s.valid
    return scans


def fresh_scan(scan):
    """The same beams as a new :class:`labkit.Scan`: its points, valid mask and noise estimate (all
    cached on a Scan) are computed again by whatever runs on it."""
    from labkit import Scan

    return Scan(ranges=scan.ranges, angles=scan.angles, range_min=scan.range_min, range_max=scan.range_max,
                stamp_ns=scan.stamp_ns)


def per_scan(fn, scans, repeat: int, *, fresh: bool = False) -> tuple[float, float]:
    """Median and largest seconds per scan, each scan timed at its best of ``repeat`` passes
    (so that a pause of the machine does not pass for a slow scan). ``fresh``: every call gets a
    new Scan of the same beams (:func:`fresh_scan`, built outside the timer)."""
    times = np.empty((repeat, len(scans)))
    for k in range(repeat):
        for i, s in enumerate(scans):
            if fresh:
                s = fresh_scan(s)
            t0 = time.perf_counter()
            fn(s)
            times[k, i] = time.perf_counter() - t0
    best = times.min(axis=0)
    return float(np.median(best)), float(best.max())
