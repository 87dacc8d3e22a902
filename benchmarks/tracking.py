"""Tracking people and moving circles over time, scored against the simulator's moving truth.

Part 1 -- the table. The ``crossing`` worlds (the hall with 1-6 walkers crossing and passing
close, the cylinder rolling round the columns; :func:`labkit.sim.worlds.crossing`) seen by the
static LMS200 of the ``crossing`` scenario (0.5 deg beams) at range noise 5 mm to 3 cm. Each row
runs :func:`labkit.pipeline.track_scans` (the pipeline and :class:`labkit.tracking.Tracker` with
the default :class:`labkit.Config`) over ``--scans`` scans and scores the confirmed tracks with
:func:`labkit.tracking_metrics.clear_mot` (0.5 m matching distance; a mover seen by fewer than 3
beams is an unseen object, see :func:`labkit.tracking_metrics.sim_frames`):

* people: MOTA, MOTP (cm), identity switches (in all, and per walker per 1000 scans),
  fragmentations, IDF1 -- walkers against person tracks;
* cylinder: MOTA and identity switches -- the rolling cylinder against circle tracks;
* static: scans in which a confirmed (moving) track stands within 0.3 m of a column or bench foot
  (must be 0), and how many of them were confirmed static;
* cost: tracking's median time per scan against the pipeline's (:func:`labkit.extract_features`),
  the same scans in the same run, each timed at its best of 3 (the tracker on a fresh copy of
  its state for every timed call), and their ratio; and the same for the tracker's reference
  code (:mod:`labkit.tracking` as ``trace=True`` runs it, here without the trace), which the
  default path replaces by compiled kernels (:mod:`labkit._tracking_engine`).

Part 2 -- the frame. The crossing world with 4 walkers seen from a robot driving to and fro and
turning: tracked in the sensor frame, the columns move with the robot and are confirmed as moving
targets; in the map frame (the scans' poses) they stay static.

Part 3 -- real recordings (``../shared/datasets``, skipped when absent): ``bags/Mapping1.bag`` and
the Intel Research Lab CARMEN log; what the tracker finds (tracks born, confirmed as moving,
static; how long and how far the moving ones went). ``--plot DIR`` draws each recording's map
with the robot's path, the moving tracks' paths, the static tracks and where the tracks that were
never confirmed were born (PNG, matplotlib).

Goal (issue 36), printed under the table: in the hall with 4 walkers at 2 cm noise, MOTA >= 0.9,
MOTP <= 5 cm, at most 1 identity switch per walker per 1000 scans, no static column confirmed as a
moving track, and tracking <= 10 % of the pipeline's time per scan.

The first line says how long the tracker's first scan took in this process (numba loading the
compiled kernels from its cache, or compiling them once).

Run: ``python benchmarks/tracking.py [--scans 1000] [--seed 10] [--real-scans 2000] [--plot out]
[--goal-row] [--skip 2,3]``
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import functools
import math
import sys
import time
from pathlib import Path

import numpy as np

from labkit import Config, extract_features, read_scans, sim, tracking
from labkit.pipeline import track_scans
from labkit.tracking import Tracker
from labkit.tracking_metrics import clear_mot, sim_frames

NOISES = (0.005, 0.01, 0.02, 0.03)
WALKERS = (1, 2, 4, 6)
DATASETS = Path(__file__).resolve().parents[1].parent / "shared" / "datasets"
#: Part 2's robot: (t, x, y, theta) keyframes, driving to and fro along the hall and turning
ROBOT = sim.Trajectory(((0.0, 4.0, 0.4, math.pi / 2), (20.0, 8.0, 0.4, math.pi / 2 + 0.4),
                        (40.0, 4.0, 0.6, math.pi / 2 - 0.4), (60.0, 6.0, 0.4, math.pi / 2),
                        (80.0, 8.0, 0.6, math.pi / 2 + 0.3), (100.0, 4.0, 0.4, math.pi / 2)))
REAL = (("Mapping1.bag", DATASETS / "bags" / "Mapping1.bag"),
        ("intel (Radish)", DATASETS / "carmen" / "intel-corrected.log.gz"))


def run(scenario: sim.Scenario, n_scans: int, seed: int, config: Config) -> dict:
    """Simulate, extract, track and score one scenario."""
    truths, tables = [], []
    scans = sim.simulate(scenario, seed=seed, n_scans=n_scans)
    truth_of = {}

    def stream():
        for scan, truth in scans:
            truth_of[scan.stamp_ns] = truth
            yield scan

    for features, table in track_scans(stream(), config):
        truths.append(truth_of.pop(features.stamp_ns))
        tables.append(table)
    world = scenario.world
    people = clear_mot(sim_frames(world, truths, tables, kind="person"))
    cylinder = clear_mot(sim_frames(world, truths, tables, kind="cylinder"))
    columns = np.array([c.center for c in world.circles])
    on_column, static_ids = 0, set()
    for truth, table in zip(truths, tables, strict=True):
        centers = columns if table.frame == "map" else _to_sensor(columns, truth.pose)
        d = np.hypot(table.states[:, None, 0] - centers[None, :, 0], table.states[:, None, 1] - centers[None, :, 1])
        near = (d < 0.3).any(axis=1)
        on_column += int((near & table.confirmed()).any())
        static_ids.update(table.ids[near & (table.status == "static")].tolist())
    return {"people": people, "cylinder": cylinder, "on_column": on_column, "static_columns": len(static_ids),
            "walkers": len(world.people), "scans": len(tables)}


def cost(scenario: sim.Scenario, n_scans: int, seed: int, config: Config, repeat: int = 3
         ) -> tuple[float, float, float]:
    """Median seconds per scan of the pipeline, of the tracker (its default, compiled path) and of
    the tracker's reference code (what ``trace=True`` runs, here without recording the steps),
    each scan timed at its best of ``repeat``: the pipeline on the scan, each tracker on a fresh
    copy of its state, so that every pass sees the same tracks; a pause of the machine does not
    pass for a slow scan."""
    tracker = Tracker(**config.tracking.kwargs())
    pipeline_s, tracking_s, reference_s = [], [], []
    for scan, _ in sim.simulate(scenario, seed=seed, n_scans=n_scans):
        best = math.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            features = extract_features(scan, config)
            best = min(best, time.perf_counter() - t0)
        pipeline_s.append(best)
        for times, compiled in ((tracking_s, True), (reference_s, False)):
            best = math.inf
            for _ in range(repeat):
                trial = copy.deepcopy(tracker)
                step = trial.step if compiled else functools.partial(_reference_step, trial)
                t0 = time.perf_counter()
                step(features, pose=scan.pose)
                best = min(best, time.perf_counter() - t0)
            times.append(best)
        tracker.step(features, pose=scan.pose)
    return float(np.median(pipeline_s)), float(np.median(tracking_s)), float(np.median(reference_s))


def _reference_step(tracker: Tracker, features, pose):
    """One step of the reference code, without a trace (the compiled kernels switched off)."""
    kept = tracking._ENGINE
    tracking._ENGINE = None
    try:
        return tracker.step(features, pose=pose)
    finally:
        tracking._ENGINE = kept


def first_step_seconds() -> float:
    """The first scan's time in this process: the tracker's compiled kernels loaded from numba's
    cache (or compiled, the first time after an install or a change)."""
    tracker = Tracker()
    t0 = time.perf_counter()
    tracker.step(tracking.Detections(0, ("person", "circle"), [[0.0, 0.0], [1.0, 1.0]]), pose=(0.0, 0.0, 0.1))
    return time.perf_counter() - t0


def _to_sensor(points: np.ndarray, pose) -> np.ndarray:
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    d = points - np.array([x, y])
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def _scenario(n_walkers: int, noise_m: float, trajectory: sim.Trajectory | None = None) -> sim.Scenario:
    sc = sim.scenario(f"crossing_{n_walkers}")
    sc = dataclasses.replace(sc, lidar=dataclasses.replace(sc.lidar, noise_std_m=noise_m))
    return sc if trajectory is None else dataclasses.replace(sc, trajectory=trajectory)


def table(n_scans: int, seed: int, config: Config, cost_scans: int, noises=NOISES, walkers=WALKERS) -> dict:
    print(f"Part 1: crossing worlds (hall, static LMS200), {n_scans} scans each, seed {seed}, default Config")
    print(f"{'noise':>6s} {'walk':>4s} | {'MOTA':>6s} {'MOTP':>6s} {'IDSW':>4s} {'/w/1k':>6s} {'FRAG':>4s} "
          f"{'IDF1':>5s} {'FN':>5s} {'FP':>4s} | {'cyl MOTA':>8s} {'IDSW':>4s} | {'col conf':>8s} {'static':>6s} | "
          f"{'pipe ms':>7s} {'+track':>7s} {'track ms':>8s} {'ratio':>6s} {'ref ms':>6s} {'ratio':>6s}")
    results = {}
    for noise in noises:
        for n in walkers:
            r = run(_scenario(n, noise), n_scans, seed, config)
            r["pipeline_s"], r["tracking_s"], r["reference_s"] = cost(_scenario(n, noise), cost_scans, seed, config)
            results[(noise, n)] = r
            p, c = r["people"], r["cylinder"]
            per = p.id_switches / n / (r["scans"] / 1000)
            pipe, track, ref = r["pipeline_s"] * 1e3, r["tracking_s"] * 1e3, r["reference_s"] * 1e3
            print(f"{noise * 100:5.1f}cm {n:4d} | {p.mota:6.3f} {p.motp * 100:5.2f}c {p.id_switches:4d} {per:6.2f} "
                  f"{p.fragmentations:4d} {p.idf1:5.3f} {p.misses:5d} {p.false_positives:4d} | {c.mota:8.3f} "
                  f"{c.id_switches:4d} | {r['on_column']:8d} {r['static_columns']:6d} | "
                  f"{pipe:7.3f} {pipe + track:7.3f} {track:8.3f} {track / pipe:6.3f} {ref:6.3f} {ref / pipe:6.3f}",
                  flush=True)
    print("(MOTP in cm; /w/1k: identity switches per walker per 1000 scans; col conf: scans with a confirmed track "
          "within 0.3 m of a column or bench foot; static: tracks confirmed static there; times: median per scan over "
          f"the first {cost_scans} scans, each the best of 3: pipe the pipeline alone, +track the pipeline with "
          "tracking, track the tracker (default, compiled), ref its reference code (what trace=True runs, without "
          "the trace); ratios to the pipeline's time)")
    return results


def goal(results: dict) -> bool:
    r = results[(0.02, 4)]
    p = r["people"]
    per = p.id_switches / 4 / (r["scans"] / 1000)
    ratio = r["tracking_s"] / r["pipeline_s"]
    checks = [("MOTA >= 0.9", p.mota >= 0.9, f"{p.mota:.3f}"),
              ("MOTP <= 5 cm", p.motp <= 0.05, f"{p.motp * 100:.2f} cm"),
              ("<= 1 ID switch per walker per 1000 scans", per <= 1.0, f"{per:.2f}"),
              ("no static column confirmed as moving", r["on_column"] == 0, f"{r['on_column']} scans"),
              ("tracking <= 10 % of the pipeline's time", ratio <= 0.10, f"{ratio:.1%}")]
    print("\nGoal (hall, 4 walkers, 2 cm):")
    for name, ok, value in checks:
        print(f"  {'met ' if ok else 'MISSED'} {name}: {value}")
    return all(ok for _, ok, _ in checks)


def frames(n_scans: int, seed: int) -> None:
    print(f"\nPart 2: the robot drives to and fro and turns (crossing, 4 walkers, 2 cm, {n_scans} scans)")
    print(f"{'frame':>7s} | {'MOTA':>6s} {'MOTP':>6s} {'IDSW':>4s} | {'cyl MOTA':>8s} | {'col conf':>8s} "
          f"{'static':>6s}")
    for frame in ("sensor", "map"):
        config = Config().updated({"tracking.frame": frame})
        r = run(_scenario(4, 0.02, ROBOT), n_scans, seed, config)
        p = r["people"]
        print(f"{frame:>7s} | {p.mota:6.3f} {p.motp * 100:5.2f}c {p.id_switches:4d} | {r['cylinder'].mota:8.3f} | "
              f"{r['on_column']:8d} {r['static_columns']:6d}", flush=True)
    print("(in the map frame, col conf must be 0: a column seen from the moving robot is never confirmed as moving)")


def real(n_scans: int, plot: Path | None) -> None:
    print(f"\nPart 3: real recordings (first {n_scans} scans, default Config; frame auto: the map with poses)")
    for name, path in REAL:
        if not path.exists():
            print(f"{name}: skipped, {path} is absent")
            continue
        stream = read_scans(path)
        scans = []
        for k, s in enumerate(stream):
            if k >= n_scans:
                break
            scans.append(s)
        tables = [t for _, t in track_scans(scans)]
        born = sum(e[0] == "birth" for t in tables for e in t.events)
        moving, static, births = {}, {}, {}
        for t in tables:
            for i in np.flatnonzero(t.confirmed()).tolist():
                moving.setdefault(int(t.ids[i]), []).append((t.stamp_ns, *t.states[i, :2].tolist(), str(t.kinds[i])))
            for i in np.flatnonzero(t.status == "static").tolist():
                static[int(t.ids[i])] = (*t.states[i, :2].tolist(), str(t.kinds[i]))
            new = {tid for kind, tid in t.events if kind == "birth"}
            for i in np.flatnonzero(np.isin(t.ids, list(new))).tolist():
                births[int(t.ids[i])] = (*t.states[i, :2].tolist(), str(t.kinds[i]))
        kinds = {}
        for rows in moving.values():
            kinds[rows[0][3]] = kinds.get(rows[0][3], 0) + 1
        lives = sorted(((rows[-1][0] - rows[0][0]) * 1e-9, float(np.hypot(*np.diff([r[1:3] for r in rows], axis=0).T)
                                                                       .sum()) if len(rows) > 1 else 0.0)
                       for rows in moving.values())
        late = sum(t.late for t in tables)
        static_kinds = {k: sum(v[2] == k for v in static.values()) for k in tracking.TRACK_KINDS}
        born_kinds = {k: sum(v[2] == k for v in births.values()) for k in tracking.TRACK_KINDS}
        print(f"{name}: {len(tables)} scans ({late} stamped before the scan before them, not tracked), frame "
              f"{tables[0].frame if tables else '-'}; {born} tracks born "
              f"({', '.join(f'{v} {k}' for k, v in born_kinds.items())}), "
              f"{len(moving)} confirmed as moving ({', '.join(f'{v} {k}' for k, v in kinds.items()) or 'none'}), "
              f"{len(static)} confirmed static ({', '.join(f'{v} {k}' for k, v in static_kinds.items())})")
        if lives:
            longest = sorted(lives, key=lambda x: -x[0])[:5]
            print("  longest moving tracks (seconds confirmed, metres travelled): "
                  + ", ".join(f"{s:.1f} s / {m:.1f} m" for s, m in longest))
        if plot is not None:
            _plot(plot, name, scans, tables, moving, static, births)


def _plot(folder: Path, name: str, scans, tables, moving, static, births) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from labkit.geometry import transform_points

    folder.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(8, 8))
    frame = tables[0].frame if tables else "sensor"
    for scan in scans[::10]:
        xy = scan.xy
        if frame == "map" and scan.pose is not None:
            xy = transform_points(xy, scan.pose)
        ax.plot(xy[:, 0], xy[:, 1], ",", color="0.6")
    path = np.array([scan.pose[:2] for scan in scans if scan.pose is not None]).reshape(-1, 2)
    if frame == "map" and len(path):
        ax.plot(path[:, 0], path[:, 1], "-", lw=0.6, color="tab:blue", alpha=0.5, label="robot path")
    for kind, colour in zip(tracking.TRACK_KINDS, ("tab:red", "tab:green"), strict=True):
        b = np.array([v[:2] for tid, v in births.items() if v[2] == kind and tid not in static and tid not in moving])
        if len(b):
            ax.plot(b[:, 0], b[:, 1], "x", ms=4, color=colour, alpha=0.6, label=f"{kind} track born, never confirmed")
        q = np.array([v[:2] for v in static.values() if v[2] == kind])
        if len(q):
            ax.plot(q[:, 0], q[:, 1], "s", ms=7, mfc="none", color=colour, label=f"{kind} track confirmed static")
    for tid, rows in moving.items():
        p = np.array([r[1:3] for r in rows])
        ax.plot(p[:, 0], p[:, 1], "-", lw=1.5, label=f"{rows[0][3]} {tid}")
    ax.set_aspect("equal")
    ax.set_title(f"{name}: {len(moving)} moving, {len(static)} static tracks, {len(births)} born\n"
                 f"({frame} frame; grey: every 10th scan)")
    if len(moving) <= 12:
        ax.legend(fontsize=7, loc="upper right")
    out = folder / (name.split()[0].replace(".", "_") + "_tracks.png")
    tmp = out.with_name(out.name + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(out)
    print(f"  picture: {out}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scans", type=int, default=1000, help="scans per simulated row (default 1000)")
    ap.add_argument("--seed", type=int, default=10)
    ap.add_argument("--cost-scans", type=int, default=200, help="scans timed per row (default 200)")
    ap.add_argument("--real-scans", type=int, default=2000)
    ap.add_argument("--plot", type=Path, default=None, help="folder for the pictures of part 3")
    ap.add_argument("--skip", default="", help="parts to skip, e.g. 2,3")
    ap.add_argument("--goal-row", action="store_true", help="part 1: only the goal's row (4 walkers, 2 cm)")
    args = ap.parse_args()
    skip = set(args.skip.split(","))
    ok = True
    print(f"The tracker's first scan in this process: {first_step_seconds():.2f} s (its compiled kernels loaded "
          "from numba's cache, or compiled when the cache is empty)")
    if "1" not in skip:
        rows = {"noises": (0.02,), "walkers": (4,)} if args.goal_row else {}
        ok = goal(table(args.scans, args.seed, Config(), args.cost_scans, **rows))
    if "2" not in skip:
        frames(args.scans, args.seed)
    if "3" not in skip:
        real(args.real_scans, args.plot)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
