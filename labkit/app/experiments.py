"""The evaluation experiments of ``labkit evaluate``, ``benchmarks/evaluation.py`` and notebook 10.

Each experiment is a function that builds its data, runs the extractors and scores them with
:mod:`labkit.evaluation`; the CLI, the benchmark script and the notebook all call these, so
their tables come from the same code.

* :func:`nguyen_set` -- simulated scans like Nguyen et al.'s (2007): 722 beams over 180 deg,
  office, corridor and random-polygon worlds, at two range noise levels;
* :func:`compare_lines` -- every line extractor in :data:`LINE_EXTRACTORS` on a set of
  simulated scans: TruePos, FalsePos, sigma dr, sigma dalpha, lines and scans per second;
* :func:`score_round_objects` -- circles and legs of the pipeline on the ``hall`` world;
* :func:`compare_on_logs` -- ray-axis RMSE (Schaefer et al. 2018) and lines per scan of
  every extractor on real scans (the Radish CARMEN logs);
* :func:`sweep_split_and_merge` -- the true-positive against false-positive curve of
  split-and-merge as its split threshold varies.

This module sits beside the CLI, above the algorithms: it imports the simulator, the readers
and every extractor.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from labkit.evaluation import (
    LineScores,
    RayErrors,
    match_circles,
    match_legs,
    match_lines,
    ray_errors,
    score_detections,
    score_lines,
)
from labkit.features import LineSegment, line_segment
from labkit.geometry import angle_difference
from labkit.lines import LINE_EXTRACTORS as REGISTRY
from labkit.lines.placing import placed as place_lines
from labkit.lines.split_merge import SplitMergeParams, split_and_merge
from labkit.noise import AUTO_LINES, FIXED_LINES
from labkit.pipeline import Config, extract_features
from labkit.scan import Scan
from labkit.sim import Lidar, ScanTruth, make_world, random_polygons, scan_at, scenario, simulate

__all__ = [
    "LINE_EXTRACTORS",
    "NOISE_LEVELS_M",
    "SENSOR_NOISE_LEVELS_M",
    "SimScan",
    "nguyen_set",
    "world_scans",
    "compare_lines",
    "score_round_objects",
    "compare_on_logs",
    "round_objects_on_logs",
    "sweep_split_and_merge",
    "false_positive_reasons",
    "truth_lines",
    "placement_frontier",
    "PLACE_CONFIDENCES",
    "markdown_table",
]

class _ByLabel(Mapping):
    """The registered line extractors (:data:`labkit.lines.LINE_EXTRACTORS`) by display label,
    read live so that an extractor registered later is compared too."""

    def __getitem__(self, label: str) -> Callable[[Scan], list]:
        for entry in REGISTRY.values():
            if entry.label == label:
                return entry.run
        raise KeyError(label)

    def __iter__(self):
        return iter([entry.label for entry in REGISTRY.values()])

    def __len__(self) -> int:
        return len(REGISTRY)


#: The line extractors compared: every registered one, by its label, each called with a scan
#: and its parameter record's defaults, and no line across a gap wider than 0.3 m
#: (``max_gap_m``; angular segmentation's ``split_gap_m``: without it its lines span collinear
#: walls across doorways). Most share ``min_points`` 5 and ``min_length_m`` 0.15 (angular
#: segmentation: ``min_pts`` 8, Meglicki's setting); the distance thresholds follow the scan's
#: range noise ("auto", each extractor's parameter record says how: split-and-merge 5 sigma,
#: incremental 4 sigma, RANSAC and Hough 2.5 sigma, none under 2 cm). Nguyen et al.'s six minus
#: EM, plus labkit's angular segmentation and IAV lines.
LINE_EXTRACTORS: Mapping[str, Callable[[Scan], list]] = _ByLabel()


#: Range noise of the two simulated sets of notebook 10: an LMS200's 5 mm and a cheap sensor's 2 cm.
NOISE_LEVELS_M = (0.005, 0.02)
#: The range noise levels of ``labkit evaluate`` and ``benchmarks/evaluation.py``, from a SICK
#: LMS200 (5 mm) to a cheap 360 deg scanner (3 cm): one default configuration must hold on all.
SENSOR_NOISE_LEVELS_M = (0.005, 0.01, 0.02, 0.03)


@dataclass(frozen=True)
class SimScan:
    """One simulated scan with its world's name, its noise level and its ground truth.

    Parameters
    ----------
    world : str
        The kind of world: ``"office"``, ``"corridor"``, ``"random_polygons"``, ...
    noise_std_m : float
        The simulated range noise, metres (standard deviation).
    scan : Scan
        The scan.
    truth : labkit.sim.ScanTruth
        Its ground truth.
    """

    world: str
    noise_std_m: float
    scan: Scan = field(repr=False)
    truth: ScanTruth = field(repr=False)


def nguyen_lidar(n_beams: int = 722, noise_std_m: float = 0.005) -> Lidar:
    """A 180 deg scanner with ``n_beams`` beams (722, as in Nguyen et al.) and 32 m range."""
    return Lidar(f"lidar{n_beams}", -math.pi / 2, math.pi / (n_beams - 1), n_beams, range_max=32.0,
                 noise_std_m=noise_std_m)


def nguyen_set(n_scans: int = 102, *, noise_levels: Sequence[float] = NOISE_LEVELS_M, n_beams: int = 722,
               seed: int = 0) -> list[SimScan]:
    """Simulated scans per noise level, a third from each kind of world.

    * ``office``: poses spread along the office scenario's tour (two rooms, a door, a column
      and a walking person);
    * ``corridor``: poses spread along the corridor scenario's drive (long walls, side
      branches, door recesses, a person);
    * ``random_polygons``: a new random room for every scan (``random_polygons(seed=k)``:
      six convex obstacles in a 12 x 9 m room), seen from its centre at a random heading.

    The same poses and worlds are used at every noise level; the noise itself is drawn from
    ``seed``.

    Parameters
    ----------
    n_scans : int
        Scans per noise level.
    noise_levels : sequence of float
        The range noise levels, metres.
    n_beams : int
        Beams of the 180 deg scanner (``nguyen_lidar``).
    seed : int
        The seed of the poses, the random rooms and the noise.

    Returns
    -------
    list of SimScan
        ``n_scans`` scans for each noise level, in the order of ``noise_levels``.
    """
    if n_scans < 3:
        raise ValueError(f"n_scans must be >= 3 (one per kind of world), got {n_scans}")
    per = [n_scans // 3 + (k < n_scans % 3) for k in range(3)]
    out: list[SimScan] = []
    for noise in noise_levels:
        if not noise >= 0:
            raise ValueError(f"noise_levels must be >= 0, got {noise}")
        rng = np.random.default_rng(seed)
        lidar = nguyen_lidar(n_beams, noise)
        headings = np.random.default_rng(seed + 1).uniform(-math.pi, math.pi, per[2])
        for name, count in zip(("office", "corridor", "random_polygons"), per, strict=True):
            for scan, truth in world_scans(name, lidar, count, rng, first_room=seed, headings=headings):
                out.append(SimScan(name, noise, scan, truth))
    return out


def world_scans(name: str, lidar: Lidar, n: int, rng: np.random.Generator, *, first_room: int = 0,
                headings: Sequence[float] | np.ndarray | None = None) -> list[tuple[Scan, ScanTruth]]:
    """Simulated ``(scan, truth)`` pairs of one kind of world.

    For a scenario's world (``office``, ``corridor``, ``hall``, ...) poses spread along its
    trajectory (moving objects placed at each time); for ``random_polygons`` a new random room
    per scan (``random_polygons(first_room + k)``) seen from its centre at ``headings[k]``.

    Parameters
    ----------
    name : str
        The kind of world: a scenario's name or ``"random_polygons"``.
    lidar : labkit.sim.Lidar
        The scanner that sees it.
    n : int
        How many pairs.
    rng : numpy.random.Generator
        Draws the range noise.
    first_room : int
        The seed of the first random room (``random_polygons`` only).
    headings : sequence of float or ndarray or None
        The scanner's heading in each random room, radians; None: ``n`` headings spread around
        the circle.

    Returns
    -------
    list of tuple of (Scan, labkit.sim.ScanTruth)
        ``n`` scans, each with its ground truth.
    """
    if name == "random_polygons":
        if headings is None:
            headings = np.linspace(-math.pi, math.pi, n, endpoint=False)
        return [scan_at(random_polygons(first_room + k), lidar, (6.0, 4.5, float(headings[k])), 0.0, rng=rng)
                for k in range(n)]
    sc, world = scenario(name), make_world(name)
    return [scan_at(world, lidar, sc.trajectory.pose_at(float(t)), float(t), rng=rng)
            for t in np.linspace(0.0, sc.duration_s * 0.98, n)]


def _timed(extract: Callable, scans: Sequence[Scan], progress=None, repeat: int = 1) -> tuple[list, float]:
    """Run ``extract`` on every scan; the results and the seconds spent in it, summed over
    the scans, each scan's time the best of ``repeat`` runs (other work on the machine only
    ever adds time)."""
    results, spent = [], 0.0
    items = scans if progress is None else progress(scans)
    for scan in items:
        best = math.inf
        for _ in range(max(1, repeat)):
            t = time.perf_counter()
            out = extract(scan)
            best = min(best, time.perf_counter() - t)
        results.append(out)
        spent += best
    return results, spent


def compare_lines(data: Sequence[SimScan], extractors: Mapping[str, Callable] | None = None, *,
                  by: Sequence[str] = ("noise_std_m",), progress: Callable | None = None, repeat: int = 1,
                  **rule) -> list[dict]:
    """Every extractor on a set of simulated scans, scored per group of scans.

    Parameters
    ----------
    data : sequence of SimScan
        The scans with their truth.
    extractors : mapping of str to callable, or None
        Name -> ``extract(scan)`` returning line segments; None: :data:`LINE_EXTRACTORS`.
    by : sequence of str
        The :class:`SimScan` fields that group the scans.
    progress : callable or None
        Called as ``progress(scans, desc=...)`` around the scans of each run (e.g. tqdm).
    repeat : int
        Each scan is timed at its best of ``repeat`` runs.
    **rule
        Keyword arguments of :func:`labkit.evaluation.match_lines`.

    Returns
    -------
    list of dict
        One row per (group, extractor): the group's keys, ``method``, the
        :meth:`labkit.evaluation.LineScores.as_dict` fields, ``lines_per_scan`` and ``scans_per_s``.
    """
    methods: Mapping[str, Callable] = LINE_EXTRACTORS if extractors is None else extractors
    groups: dict[tuple, list[SimScan]] = {}
    for item in data:
        groups.setdefault(tuple(getattr(item, k) for k in by), []).append(item)
    rows = []
    for key, items in groups.items():
        scans = [it.scan for it in items]
        for name, extract in methods.items():
            bar = None if progress is None else partial(progress, desc=f"{name} {key}")
            lines, spent = _timed(extract, scans, bar, repeat)
            s: LineScores = score_lines(zip(lines, (it.truth for it in items), strict=False), **rule)
            rows.append({**dict(zip(by, key, strict=False)), "method": name, **s.as_dict(),
                         "lines_per_scan": s.n_lines / max(s.n_scans, 1), "scans_per_s": len(scans) / spent})
    return rows


def score_round_objects(n_scans: int = 300, *, seed: int = 0, config: Config | None = None,
                        progress: Callable | None = None, noise_std_m: float | None = None) -> dict[str, dict]:
    """Circles and legs of :func:`labkit.extract_features` on the ``hall`` scenario, scored against its truth.

    The hall has columns, bench feet, a rolling cylinder and a walking student, seen by an LMS200;
    the detections are scored with :func:`labkit.evaluation.match_circles` and
    :func:`~labkit.evaluation.match_legs`.

    Parameters
    ----------
    n_scans : int
        Scans simulated.
    seed : int
        The simulation's seed.
    config : Config or None
        The pipeline's configuration; None: ``Config()``.
    progress : callable or None
        Called as ``progress(items, total=n_scans, desc="hall")`` around the simulated scans (e.g. tqdm).
    noise_std_m : float or None
        The range noise, metres; None: the scenario's 5 mm.

    Returns
    -------
    dict of str to dict
        ``"circles"`` and ``"legs"``: each ``kind``, the detection scores' fields
        (:func:`labkit.evaluation.score_detections`) and ``scans_per_s``.
    """
    circles, legs = [], []
    hall = scenario("hall")
    if noise_std_m is not None:
        hall = dataclasses.replace(hall, lidar=dataclasses.replace(hall.lidar, noise_std_m=noise_std_m))
    items = simulate(hall, seed, n_scans=n_scans)
    if progress is not None:
        items = progress(items, total=n_scans, desc="hall")
    spent = 0.0
    for scan, truth in items:
        t = time.perf_counter()
        f = extract_features(scan, config)
        spent += time.perf_counter() - t
        circles.append(match_circles(f.circles, scan, truth))
        legs.append(match_legs(f.legs, scan, truth))
    rate = n_scans / spent if spent else math.nan
    return {"circles": {"kind": "circles", **score_detections(circles).as_dict(), "scans_per_s": rate},
            "legs": {"kind": "legs", **score_detections(legs).as_dict(), "scans_per_s": rate}}


def compare_on_logs(paths: Iterable[str | Path], extractors: Mapping[str, Callable] | None = None, *,
                    n_scans: int = 100, progress: Callable | None = None, repeat: int = 1, topic: str | None = None,
                    strict: bool = False, on_damage: Callable[[Exception], None] | None = None,
                    scans: slice | None = None) -> list[dict]:
    """Line extractors on real recordings, scored without truth (ray-axis errors).

    For every extractor and recording: ray-axis RMSE, median error, share of errors over 10 cm,
    coverage and lines per scan (:func:`labkit.evaluation.ray_errors`). A damaged recording is
    scored on the scans that could be read.

    Parameters
    ----------
    paths : iterable of str or Path
        The recordings (any format :func:`labkit.read_scans` reads).
    extractors : mapping of str to callable, or None
        Name -> ``extract(scan)``; None: :data:`LINE_EXTRACTORS`.
    n_scans : int
        The first so many scans of each recording.
    progress : callable or None
        Called as ``progress(scans, desc=...)`` around the scans of each run (e.g. tqdm).
    repeat : int
        Each scan is timed at its best of ``repeat`` runs.
    topic : str or None
        The scan topic of a bag, as in :func:`labkit.read_scans`.
    strict : bool
        Stop at the first bad record, as in :func:`labkit.read_scans`.
    on_damage : callable or None
        Receives the :class:`labkit.CorruptFileError` of a damaged recording; None: the first
        is raised after every recording was scored.
    scans : slice or None
        Score this range of scans of each recording instead of the first ``n_scans``.

    Returns
    -------
    list of dict
        One row per (recording, extractor): ``log``, ``method``, ``scans``, ``beams``, ``rmse_m``,
        ``median_abs_m``, ``over_10cm``, ``coverage``, ``lines_per_scan``, ``scans_per_s``.
    """

    methods: Mapping[str, Callable] = LINE_EXTRACTORS if extractors is None else extractors
    rows = []
    damage: list[Exception] = []
    for path in paths:
        chosen = _first_scans(path, n_scans, topic, strict, damage, on_damage, scans)
        for name, extract in methods.items():
            bar = None if progress is None else partial(progress, desc=f"{Path(path).name} {name}")
            lines, spent = _timed(extract, chosen, bar, repeat)
            total = RayErrors(np.empty(0), 0)
            for scan, found in zip(chosen, lines, strict=False):
                total = total + ray_errors(scan, found)
            rows.append({"log": Path(path).name, "method": name, "scans": len(chosen),
                         "beams": int(np.median([s.n_beams for s in chosen])) if chosen else 0,
                         "rmse_m": total.rmse, "median_abs_m": total.median_abs,
                         "over_10cm": total.share_over(0.1), "coverage": total.coverage,
                         "lines_per_scan": sum(map(len, lines)) / max(len(chosen), 1),
                         "scans_per_s": len(chosen) / spent if spent else math.nan})
    if damage and on_damage is None:
        raise damage[0]
    return rows


def _first_scans(path, n_scans: int, topic, strict: bool, damage: list, on_damage,
                 scans: slice | None = None) -> list[Scan]:
    """The first ``n_scans`` scans of a recording (or the range ``scans``); a
    :class:`labkit.CorruptFileError` goes to ``damage`` and to ``on_damage`` (if given), and the
    scans read before it are kept. A record skipped among them is reported although reading
    stops after them (:func:`labkit.read_scans`' ``scans``)."""
    from labkit.io import CorruptFileError, read_scans  # I/O stays out of the algorithm imports above

    chosen: list[Scan] = []
    try:
        chosen.extend(read_scans(path, topic=topic, strict=strict, scans=scans or slice(0, n_scans)))
    except CorruptFileError as exc:
        damage.append(exc)
        if on_damage is not None:
            on_damage(exc)
    return chosen


def round_objects_on_logs(paths: Iterable[str | Path], configs: Mapping[str, Config | None], *, n_scans: int = 100,
                          topic: str | None = None, strict: bool = False,
                          on_damage: Callable[[Exception], None] | None = None) -> list[dict]:
    """Circles, legs and people per scan of :func:`labkit.extract_features` on real recordings.

    Real recordings have no truth: this counts, it does not score. The median range noise of the
    scans (:func:`labkit.noise.scan_sigma`) is given beside. Damaged recordings as
    :func:`compare_on_logs`.

    Parameters
    ----------
    paths : iterable of str or Path
        The recordings.
    configs : mapping of str to Config or None
        Name -> configuration (None for the defaults).
    n_scans : int
        The first so many scans of each recording.
    topic : str or None
        The scan topic of a bag, as in :func:`labkit.read_scans`.
    strict : bool
        Stop at the first bad record, as in :func:`labkit.read_scans`.
    on_damage : callable or None
        Receives the error of a damaged recording; None: the first is raised at the end.

    Returns
    -------
    list of dict
        One row per (recording, configuration): ``log``, ``setting``, ``scans``, ``sigma_m``,
        ``circles_per_scan``, ``legs_per_scan``, ``people_per_scan``.
    """
    from labkit.noise import scan_sigma

    rows = []
    damage: list[Exception] = []
    for path in paths:
        scans = _first_scans(path, n_scans, topic, strict, damage, on_damage)
        sigma = float(np.median([scan_sigma(s) for s in scans])) if scans else math.nan
        for name, config in configs.items():
            found = [extract_features(s, config) for s in scans]
            per = max(len(scans), 1)
            rows.append({"log": Path(path).name, "setting": name, "scans": len(scans), "sigma_m": sigma,
                         "circles_per_scan": sum(len(f.circles) for f in found) / per,
                         "legs_per_scan": sum(len(f.legs) for f in found) / per,
                         "people_per_scan": sum(len(f.people) for f in found) / per})
    if damage and on_damage is None:
        raise damage[0]
    return rows


#: Split thresholds of the sweep, metres.
SWEEP_THRESHOLDS_M = (0.01, 0.015, 0.02, 0.03, 0.05, 0.08, 0.12, 0.2, 0.3)


def sweep_split_and_merge(data: Sequence[SimScan], thresholds: Sequence[float] = SWEEP_THRESHOLDS_M, *,
                          by: Sequence[str] = ("noise_std_m",), progress: Callable | None = None, repeat: int = 1,
                          **fixed) -> list[dict]:
    """True- and false-positive rates of :func:`labkit.split_and_merge` for each split threshold.

    Each threshold runs with the papers' fixed setting (:data:`labkit.noise.FIXED_LINES`: 1 cm
    of assumed range noise, every line reported), other arguments ``fixed`` over it.

    Parameters
    ----------
    data : sequence of SimScan
        The scans with their truth.
    thresholds : sequence of float
        The values of ``split_threshold_m``, metres.
    by : sequence of str
        The :class:`SimScan` fields that group the scans.
    progress : callable or None
        As in :func:`compare_lines`.
    repeat : int
        Each scan is timed at its best of ``repeat`` runs.
    **fixed
        Further keyword arguments of :func:`labkit.split_and_merge`.

    Returns
    -------
    list of dict
        The rows of :func:`compare_lines`, with ``split_threshold_m`` in place of ``method``.
    """
    setting = {**FIXED_LINES, **fixed}
    extractors = {f"{t:g}": partial(split_and_merge, **{**setting, "split_threshold_m": t}) for t in thresholds}
    rows = compare_lines(data, extractors, by=by, progress=progress, repeat=repeat)
    for row in rows:
        row["split_threshold_m"] = float(row.pop("method"))
    return rows


def false_positive_reasons(data: Sequence[SimScan], noise_std_m: float, extract: Callable = split_and_merge,
                           max_dr_m: float = 0.05, max_dalpha: float = math.radians(3.0), **kwargs) -> list[dict]:
    """Why the false positives of an extractor failed to match their wall.

    Each false line is compared with the wall most of its beams hit: ``"dr"``, ``"dalpha"``,
    both, ``"overlap or a second line on the wall"``, or ``"not on a wall"``.

    Parameters
    ----------
    data : sequence of SimScan
        The scans with their truth.
    noise_std_m : float
        Only the scans of this noise level.
    extract : callable
        ``extract(scan, **kwargs)`` returning line segments.
    max_dr_m : float
        The matching tolerance in ``r``, metres.
    max_dalpha : float
        The matching tolerance in ``alpha``, radians.
    **kwargs
        Passed to ``extract``.

    Returns
    -------
    list of dict
        One row per reason, most frequent first: ``reason``, ``lines``, ``median_length_m``,
        ``median_points``.
    """
    found: dict[str, list[tuple[float, int]]] = {}
    for item in data:
        if item.noise_std_m != noise_std_m:
            continue
        lines = extract(item.scan, **kwargs)
        m = match_lines(lines, item.truth, max_dr_m=max_dr_m, max_dalpha=max_dalpha)
        walls = {w.wall_id: w for w in item.truth.walls}
        for i in m.false_positives:
            line = lines[i]
            owners, counts = np.unique(item.truth.hits[line.indices], return_counts=True)
            wall = walls.get(int(owners[np.argmax(counts)]))
            if wall is None:
                reason = "not on a wall"
            else:
                fails = [name for name, bad in (
                    ("dr", abs(line.r - wall.r) > max_dr_m),
                    ("dalpha", abs(float(angle_difference(line.alpha, wall.alpha))) > max_dalpha)) if bad]
                reason = " and ".join(fails) or "overlap or a second line on the wall"
            found.setdefault(reason, []).append((line.length, line.n_points))
    return [{"reason": k, "lines": len(v), "median_length_m": float(np.median([a for a, _ in v])),
             "median_points": float(np.median([b for _, b in v]))}
            for k, v in sorted(found.items(), key=lambda kv: -len(kv[1]))]


#: What a user trusts, as the extractors' placing defaults: within 5 cm and 3 degrees of the true line.
PLACE_DR_M, PLACE_DALPHA_DEG = SplitMergeParams.place_dr_m, SplitMergeParams.place_dalpha_deg


def truth_lines(item: SimScan, *, place_confidence: float = 0.0, place_dr_m: float = PLACE_DR_M,
                place_dalpha_deg: float = PLACE_DALPHA_DEG) -> list[LineSegment]:
    """The lines of an extractor that knew which beams hit which wall.

    For every visible wall of the scan's truth, one line fitted (weighted polar least squares, as
    the extractors fit) to exactly the valid beams that hit it, with the covariance of the true
    range noise; with ``place_confidence`` > 0, only those the data can place, as the ``"auto"``
    settings choose (:func:`labkit.fitting.placement_probability`).

    No extractor knows the truth, so on the same scans none should find more walls with as few
    false lines by that choice: its TruePos / FalsePos are a reference for what the data allows
    (:func:`placement_frontier`). A fit to a wall's own beams misses the matching tolerance only
    by noise, so its false positives are the lines the noise moved too far.

    Parameters
    ----------
    item : SimScan
        The scan with its truth.
    place_confidence : float
        The placing confidence; 0: every line kept.
    place_dr_m : float
        The placing tolerance in ``r``, metres.
    place_dalpha_deg : float
        The placing tolerance in ``alpha``, degrees.

    Returns
    -------
    list of LineSegment
        One line per visible wall kept.
    """
    scan, truth = item.scan, item.truth
    lines = []
    for wall in truth.walls:
        beams = np.arange(wall.first, wall.last + 1) if wall.first <= wall.last else np.concatenate(
            [np.arange(wall.first, scan.n_beams), np.arange(0, wall.last + 1)])  # (across the seam)
        beams = beams[(truth.hits[beams] == wall.wall_id) & scan.valid[beams]]
        if len(beams) < 2:
            continue
        lines.append(line_segment(scan.points[beams], beams, range_sigma=item.noise_std_m))
    return place_lines(lines, place_dr_m, place_dalpha_deg, place_confidence)  # (the extractors' own rule)


#: The confidences of :func:`placement_frontier`: every line, then tighter choices up to the
#: ``"auto"`` settings' 0.8 and beyond.
PLACE_CONFIDENCES = (0.0, 0.5, 0.6, 0.7, 0.8, 0.9)


def placement_frontier(data: Sequence[SimScan], confidences: Sequence[float] = PLACE_CONFIDENCES, *,
                       extract: Callable | None = None, progress: Callable | None = None) -> list[dict]:
    """TruePos against FalsePos as the placing confidence varies.

    Compares :func:`truth_lines` (method ``"walls' own beams"``) with ``extract`` (method
    ``"extractor"``). Placing is the last step of every extractor that has it, a filter on the
    lines' covariances (:func:`labkit.fitting.placement_probability`): each method runs once per
    scan with ``place_confidence=0`` and its lines are placed at each confidence in turn.

    Where the walls' own beams cannot reach a goal at any confidence, no extractor choosing its
    lines the same way can: the data is what limits it.

    Parameters
    ----------
    data : sequence of SimScan
        The scans with their truth.
    confidences : sequence of float
        The placing confidences.
    extract : callable or None
        ``extract(scan, place_confidence=0)``; None: split-and-merge with
        :data:`labkit.noise.AUTO_LINES`.
    progress : callable or None
        As in :func:`compare_lines`.

    Returns
    -------
    list of dict
        One row per noise level, confidence and method, with :func:`compare_lines`' fields (but
        ``scans_per_s``) and ``place_confidence``.
    """
    extract = partial(split_and_merge, **AUTO_LINES) if extract is None else extract
    every = {"walls' own beams": {id(item.scan): truth_lines(item) for item in data},
             "extractor": {id(item.scan): extract(item.scan, place_confidence=0.0) for item in data}}

    def placed(lines: dict, c: float) -> Callable:
        return lambda scan: place_lines(lines[id(scan)], PLACE_DR_M, PLACE_DALPHA_DEG, c)

    rows = []
    for c in confidences:
        extractors = {name: placed(lines, c) for name, lines in every.items()}
        for row in compare_lines(data, extractors, progress=progress):
            row.pop("scans_per_s")
            rows.append({**row, "place_confidence": c})
    return sorted(rows, key=lambda r: (r["noise_std_m"], r["method"], r["place_confidence"]))


#: Columns of the tables (row key -> ``header:format``), shared by the CLI, the benchmark and notebook 10.
LINE_COLUMNS = {"noise_std_m": "noise (m)", "method": "method", "tp_rate": "TruePos:.3f", "fp_rate": "FalsePos:.3f",
                "sigma_dr_m": "sigma dr (mm):", "sigma_dalpha_deg": "sigma dalpha (deg):.2f",
                "lines_per_scan": "lines/scan:.1f", "scans_per_s": "scans/s:,.0f"}
ROUND_COLUMNS = {"kind": "objects", "truth": "in truth", "detected": "detected", "scored": "scored",
                 "precision": "precision:.3f", "recall": "recall:.3f",
                 "center_err_median_m": "centre err median (m):.3f",
                 "center_err_p95_m": "centre err p95 (m):.3f", "radius_err_median": "radius err median:.1%",
                 "scans_per_s": "scans/s:,.0f"}
LOG_COLUMNS = {"log": "recording", "method": "method", "scans": "scans", "beams": "beams", "rmse_m": "RMSE (m):.4f",
               "median_abs_m": "median abs (m):.4f", "over_10cm": "beyond 10 cm:.1%", "coverage": "coverage:.1%",
               "lines_per_scan": "lines/scan:.1f", "scans_per_s": "scans/s:,.0f"}
ROUND_LOG_COLUMNS = {"log": "recording", "setting": "setting", "scans": "scans", "sigma_m": "median sigma (m):.4f",
                     "circles_per_scan": "circles/scan:.2f", "legs_per_scan": "legs/scan:.2f",
                     "people_per_scan": "people/scan:.2f"}
SWEEP_COLUMNS = {"noise_std_m": "noise (m)", "split_threshold_m": "split threshold (m)", "tp_rate": "TruePos:.3f",
                 "fp_rate": "FalsePos:.3f", "sigma_dr_m": "sigma dr (mm):", "lines_per_scan": "lines/scan:.1f"}


def markdown_table(rows: Sequence[dict], columns: dict[str, str]) -> str:
    """Rows as a Markdown table.

    Parameters
    ----------
    rows : sequence of dict
        The rows; a missing key gives an empty cell, a NaN a dash.
    columns : dict of str to str
        Row key -> ``header`` or ``header:format`` (a format spec such as ``.3f``); a header
        with ``(mm)`` shows a value stored in metres in millimetres.

    Returns
    -------
    str
        The table, one line per row under the header and its rule.
    """
    heads, keys, fmts = [], [], []
    for key, spec in columns.items():
        head, _, fmt = spec.partition(":")
        heads.append(head)
        keys.append(key)
        fmts.append(fmt)
    lines = ["| " + " | ".join(heads) + " |", "|" + "---|" * len(heads)]
    for row in rows:
        cells = []
        for key, head, fmt in zip(keys, heads, fmts, strict=False):
            v = row.get(key, "")
            if isinstance(v, float) and math.isnan(v):
                cells.append("—")
            elif "(mm)" in head and isinstance(v, float):
                cells.append(f"{v * 1000:.1f}")  # stored in metres
            else:
                cells.append(format(v, fmt) if fmt else str(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
