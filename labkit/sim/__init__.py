"""A 2D laser scan simulator with exact ground truth.

The simulator ray-casts a planar lidar into a *world* of wall segments, arcs (rounded
corners) and circles (columns, bench legs), plus moving objects: a rolling cylinder and
walking people whose two legs alternate like a real gait. For every scan it also returns
what the scan *should* contain: which object each beam hit, the visible portion of every
wall as a segment with its normal-form line ``(r, alpha)`` in the sensor frame, the
visible circles and arcs, the people's legs and the sensor pose. That ground truth is
what labkit's tests and evaluation compare extractors against.

Everything is deterministic for a given seed: noise and dropouts come from one
``numpy.random.Generator`` per run, drawn in a fixed order.

Quick start
-----------
>>> from labkit import sim
>>> scenario = sim.scenario("hall")
>>> scan, truth = next(iter(sim.simulate(scenario, seed=0)))
>>> scan.n_beams, len(truth.walls) > 0
(361, True)

Modules: :mod:`~labkit.sim.worlds` (walls, arcs, columns, the bundled rooms, the ``crossing``
worlds for tracking), :mod:`~labkit.sim.people` (paths, rolling cylinders, walkers, movers),
:mod:`~labkit.sim.lidar` (lidars, trajectories, scenarios, ray casting, :func:`scan_at`, :func:`simulate`) and
:mod:`~labkit.sim.truth` (ground-truth records and ``.truth.jsonl`` files).
"""

from .lidar import EPOCH_NS, LIDARS, Lidar, Scenario, Trajectory, scan_at, scenario, simulate
from .people import Mover, PathSpec, RollingCylinder, Walker
from .truth import (
    TRUTH_FILE,
    GroundTruth,
    ScanTruth,
    VisibleArc,
    VisibleCircle,
    VisibleLeg,
    VisibleWall,
    read_truth,
    truth_path_for,
    write_truth,
)
from .worlds import CROSSING_WALKERS, WORLDS, Arc, Column, Wall, World, crossing, make_world, random_polygons

__all__ = [
    "Wall",
    "Arc",
    "Column",
    "PathSpec",
    "RollingCylinder",
    "Walker",
    "Mover",
    "World",
    "Lidar",
    "LIDARS",
    "Trajectory",
    "Scenario",
    "VisibleWall",
    "VisibleCircle",
    "VisibleArc",
    "VisibleLeg",
    "ScanTruth",
    "GroundTruth",
    "WORLDS",
    "make_world",
    "random_polygons",
    "crossing",
    "CROSSING_WALKERS",
    "scenario",
    "simulate",
    "scan_at",
    "write_truth",
    "read_truth",
    "truth_path_for",
    "EPOCH_NS",
    "TRUTH_FILE",
]
