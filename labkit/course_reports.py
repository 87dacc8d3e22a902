"""Bookkeeping of the course notebooks (10b): sums, checks and printed summaries.

A notebook's code cell keeps its experiment (what is run, on which data, with which settings); the
loops that only add up, compare with labkit or format a printout live here, so that the cell stays
short. Every function takes the notebook's rows or arrays as arguments; none computes a "your turn"
answer (the student's function is called in the notebook, and its results come in here).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from pathlib import Path

import numpy as np

from .evaluation import RayErrors, ray_errors
from .geometry import signed_distance_to_line

__all__ = ["FIXED_AND_AUTO_COLUMNS", "NOISE_ESTIMATE_COLUMNS", "pooled_ray_errors", "print_slant_ratios",
           "print_error_summary", "print_fixed_threshold_drift", "scaled_residuals", "on_one_wall",
           "print_noise_estimates", "print_best_fixed_against_auto", "print_one_threshold_for_all",
           "print_place_confidence_effect", "print_changes", "fixed_and_auto_on_log", "print_auto_on_logs",
           "print_more_circles"]

#: Columns of :func:`print_noise_estimates`'s table (for :func:`labkit.app.experiments.markdown_table`).
NOISE_ESTIMATE_COLUMNS = {
    "noise_std_m": "true sigma (mm)", "mean_m": "estimate, mean per scan (mm)", "sd_m": "scan-to-scan spread (mm)",
    "ratio": "mean / true:.3f", "pooled_m": "pooled over the scans (mm)", "plain_m": "plain std, median (mm)",
    "split_m": "auto split threshold, median (mm)"}
#: Columns of the rows of :func:`fixed_and_auto_on_log`.
FIXED_AND_AUTO_COLUMNS = {
    "log": "recording", "step": "beam step (deg)", "sigma_m": "estimate, pooled (mm)",
    "split_m": "auto threshold, median (mm)", "rmse_fixed": "RMSE FIXED_LINES (m):.4f",
    "cov_fixed": "coverage FIXED_LINES:.0%", "rmse_auto": "RMSE default (m):.4f", "cov_auto": "coverage default:.0%"}


def pooled_ray_errors(scans: Sequence, lines_per_scan: Sequence, label: str | None = None) -> RayErrors:
    """The ray-axis errors of every scan against its own lines, pooled into one :class:`labkit.evaluation.RayErrors`.

    Parameters
    ----------
    scans : sequence of labkit.Scan
        The scans.
    lines_per_scan : sequence of list of labkit.LineSegment
        The lines of each scan, in the same order.
    label : str, optional
        When given, print one line: the label, RMSE (mm), coverage and lines per scan.

    Returns
    -------
    labkit.evaluation.RayErrors
        The errors of all the scans' beams; ``rmse`` and ``coverage`` are over all of them.
    """
    if len(scans) != len(lines_per_scan):
        raise ValueError(f"{len(scans)} scans but {len(lines_per_scan)} lists of lines")
    total = sum((ray_errors(scan, lines) for scan, lines in zip(scans, lines_per_scan, strict=True)),
                start=RayErrors(np.empty(0), 0))
    if label is not None:
        print(f"{label:18}: RMSE {1000 * total.rmse:6.1f} mm, coverage {total.coverage:6.1%}, "
              f"{np.mean([len(lines) for lines in lines_per_scan]):.1f} lines per scan")
    return total


def print_slant_ratios(scan, segment, errors, meets) -> np.ndarray:
    """Print, beam by beam, ``|ray-axis error| / perpendicular distance`` beside ``1 / cos(incidence)``.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    segment : labkit.LineSegment
        The segment the errors were measured against.
    errors : ndarray
        The ray-axis error of every beam of ``scan``, metres (NaN where the ray misses the line).
    meets : ndarray of bool
        The beams whose ray meets the segment between its ends.

    Returns
    -------
    ndarray
        The ratios of the beams of ``meets``.
    """
    perpendicular = np.abs(signed_distance_to_line(scan.points[meets], segment.r, segment.alpha))
    ratios = np.abs(np.asarray(errors)[meets]) / perpendicular
    print(f"|ray error| / perpendicular distance, beam by beam: {np.round(ratios, 2).tolist()}")
    print(f"1 / cos(incidence angle):                          "
          f"{np.round(1 / np.abs(np.cos(scan.angles[meets] - segment.alpha)), 2).tolist()}")
    return ratios


def print_error_summary(per_beam: Mapping[str, np.ndarray]) -> None:
    """Print a table of ``|e|`` per method: median (mm), share beyond 10 cm, RMSE (mm).

    Parameters
    ----------
    per_beam : mapping of str to ndarray
        ``{method: |ray-axis errors|}`` in metres.
    """
    print(f"{'method':24} {'median |e| (mm)':>16} {'|e| > 10 cm':>12} {'RMSE (mm)':>10}")
    for name, e in per_beam.items():
        print(f"{name:24} {1000 * np.median(e):16.1f} {np.mean(e > 0.1):12.2%} {1000 * np.sqrt(np.mean(e ** 2)):10.1f}")


def print_fixed_threshold_drift(rows: Sequence[dict], fixed_m: float) -> str:
    """Print each level's rates with the fixed threshold in sigmas, then which rate moves more.

    Parameters
    ----------
    rows : sequence of dict
        One row per noise level, lowest first: ``noise_std_m``, ``tp_rate``, ``fp_rate``.
    fixed_m : float
        The fixed split threshold, metres.

    Returns
    -------
    str
        ``"TruePos"`` or ``"FalsePos"``: the rate that moves more from the first level to the last.
    """
    for row in rows:
        print(f"noise {1000 * row['noise_std_m']:2.0f} mm: the fixed threshold is "
              f"{fixed_m / row['noise_std_m']:4.1f} sigma; TruePos {row['tp_rate']:.3f}, FalsePos {row['fp_rate']:.3f}")
    first, last = rows[0], rows[-1]
    d_tp, d_fp = last["tp_rate"] - first["tp_rate"], last["fp_rate"] - first["fp_rate"]
    more = "FalsePos" if abs(d_fp) > abs(d_tp) else "TruePos"
    print(f"\nfrom {1000 * first['noise_std_m']:.0f} to {1000 * last['noise_std_m']:.0f} mm: TruePos moves by "
          f"{d_tp:+.3f}, FalsePos by {d_fp:+.3f}; {more} moves more")
    return more


def scaled_residuals(s, scan, mid) -> np.ndarray:
    """Divide three-beam residuals by their factors ``k_i``, check them against labkit's, print the check.

    ``k_i = sqrt(1 + (w (r_i / r_{i-1})^2)^2 + (w (r_i / r_{i+1})^2)^2)`` with ``w = 1 / (2 cos dtheta)``
    (derived in :mod:`labkit.noise`).

    Parameters
    ----------
    s : ndarray
        The residual ``s_i`` of each beam of ``mid``, metres.
    scan : labkit.Scan
        The scan.
    mid : ndarray of int
        The beams with two valid neighbours, in order.

    Returns
    -------
    ndarray
        ``labkit.range_noise_residuals(scan)``, which ``s / k_i`` must equal.

    Raises
    ------
    AssertionError
        When ``s / k_i`` differs from labkit's residuals.
    """
    from .noise import range_noise_residuals

    r, dtheta = scan.ranges, scan.angle_increment
    w = 1 / (2 * np.cos(dtheta))
    k_i = np.sqrt(1 + (w * (r[mid] / r[mid - 1]) ** 2) ** 2 + (w * (r[mid] / r[mid + 1]) ** 2) ** 2)
    z = range_noise_residuals(scan)
    assert np.shape(s) == np.shape(z) and np.allclose(np.asarray(s) / k_i, z), "s / k_i is not labkit's z"
    print(f"check: your residuals / k_i are labkit's, on {len(z)} of {scan.n_beams} beams "
          f"(k_i from {k_i.min():.3f} to {k_i.max():.3f}; sqrt(1.5) = {math.sqrt(1.5):.3f})")
    return z


def on_one_wall(truth, mid) -> np.ndarray:
    """Whether each beam of ``mid`` and its two neighbours hit the same wall, by the truth.

    Parameters
    ----------
    truth : labkit.sim.ScanTruth
        The scan's ground truth: ``hits`` (what each beam hit) and ``walls``.
    mid : ndarray of int
        The middle beams.

    Returns
    -------
    ndarray of bool
        True where beams ``i - 1``, ``i``, ``i + 1`` all hit one wall.
    """
    hits = np.asarray(truth.hits)
    wall_ids = [w.wall_id for w in truth.walls]
    return (hits[mid - 1] == hits[mid]) & (hits[mid] == hits[mid + 1]) & np.isin(hits[mid], wall_ids)


def print_noise_estimates(rows: Sequence[dict]) -> float:
    """Print how far the mean estimate strays from the true sigma, its spread, and the plain std's ratio.

    Parameters
    ----------
    rows : sequence of dict
        One row per level with ``noise_std_m``, ``mean_m``, ``sd_m``, ``ratio`` (mean / true) and ``plain_m``.

    Returns
    -------
    float
        The largest ``|ratio - 1|``.
    """
    furthest = max(rows, key=lambda row: abs(row["ratio"] - 1))
    print(f"the mean estimate is within {abs(furthest['ratio'] - 1):.1%} of the true sigma at every level (furthest "
          f"at {1000 * furthest['noise_std_m']:.0f} mm); one scan's estimate spreads by "
          f"{min(r['sd_m'] / r['mean_m'] for r in rows):.1%} to {max(r['sd_m'] / r['mean_m'] for r in rows):.1%}")
    print(f"the plain std is {min(r['plain_m'] / r['noise_std_m'] for r in rows):.1f} to "
          f"{max(r['plain_m'] / r['noise_std_m'] for r in rows):.1f} times the true sigma")
    return abs(furthest["ratio"] - 1)


def _better_on_both(curve: Sequence[dict], row: dict) -> list[dict]:
    return [r for r in curve if r["tp_rate"] >= row["tp_rate"] and r["fp_rate"] <= row["fp_rate"]
            and (r["tp_rate"], r["fp_rate"]) != (row["tp_rate"], row["fp_rate"])]


def print_best_fixed_against_auto(sweep: Sequence[dict], auto: Mapping[tuple, dict], score: Callable,
                                  methods: Sequence[str]) -> dict:
    """Print per noise level the best fixed threshold, and each auto method with those that beat it.

    The best fixed threshold is the one of largest ``score``; a fixed threshold beats an auto method
    when it is at least as good on both rates and not equal on both.

    Parameters
    ----------
    sweep : sequence of dict
        Rows of the fixed thresholds: ``noise_std_m``, ``split_threshold_m``, ``tp_rate``, ``fp_rate``.
    auto : mapping
        ``{(method, noise_std_m): row}`` of the auto methods.
    score : callable
        ``score(row)``: larger is better.
    methods : sequence of str
        The auto methods to compare.

    Returns
    -------
    dict
        ``{noise_std_m: {method: [thresholds better on both]}}``, metres.
    """
    beaten = {}
    for noise in sorted({r["noise_std_m"] for r in sweep}):
        curve = [r for r in sweep if r["noise_std_m"] == noise]
        top = max(curve, key=score)
        print(f"noise {1000 * noise:2.0f} mm: best fixed threshold {100 * top['split_threshold_m']:g} cm: "
              f"TruePos {top['tp_rate']:.3f}, FalsePos {top['fp_rate']:.3f}")
        beaten[noise] = {}
        for method in methods:
            row = auto[method, noise]
            beats = _better_on_both(curve, row)
            beaten[noise][method] = [r["split_threshold_m"] for r in beats]
            print(f"  {method + ':':28} TruePos {row['tp_rate']:.3f}, FalsePos {row['fp_rate']:.3f}; fixed "
                  "thresholds better on both: " + (", ".join(f"{100 * r['split_threshold_m']:g} cm" for r in beats)
                                                   or "none"))
    return beaten


def print_one_threshold_for_all(sweep: Sequence[dict], auto_rows: Sequence[dict], score: Callable,
                                methods: Sequence[str]) -> float:
    """The fixed threshold whose worst level scores best, against each auto method's worst level.

    Parameters
    ----------
    sweep : sequence of dict
        Rows of the fixed thresholds, as :func:`print_best_fixed_against_auto`'s.
    auto_rows : sequence of dict
        Rows of the auto methods: ``method``, ``noise_std_m``, ``tp_rate``, ``fp_rate``.
    score : callable
        ``score(row)``: larger is better.
    methods : sequence of str
        The auto methods.

    Returns
    -------
    float
        That fixed threshold, metres.
    """
    worst_of = {t: min((r for r in sweep if r["split_threshold_m"] == t), key=score)
                for t in sorted({r["split_threshold_m"] for r in sweep})}
    t_best = max(worst_of, key=lambda t: score(worst_of[t]))
    print(f"\none fixed threshold for all four levels: {100 * t_best:g} cm does best at its worst level "
          f"({1000 * worst_of[t_best]['noise_std_m']:.0f} mm: TruePos - FalsePos {score(worst_of[t_best]):.3f})")
    for method in methods:
        low = min((r for r in auto_rows if r["method"] == method), key=score)
        print(f"{method}: worst level {1000 * low['noise_std_m']:.0f} mm, TruePos - FalsePos {score(low):.3f}")
    return t_best


def print_place_confidence_effect(auto: Mapping[tuple, dict], before: str, after: str) -> None:
    """Per noise level: FalsePos, TruePos and lines per scan of method ``before`` -> method ``after``.

    Parameters
    ----------
    auto : mapping
        ``{(method, noise_std_m): row}``; rows have ``tp_rate``, ``fp_rate``, ``lines_per_scan``.
    before, after : str
        The two methods.
    """
    for noise in sorted({n for m, n in auto if m == before}):
        one, star = auto[before, noise], auto[after, noise]
        print(f"  noise {1000 * noise:2.0f} mm: FalsePos {one['fp_rate']:.3f} -> {star['fp_rate']:.3f}, "
              f"TruePos {one['tp_rate']:.3f} -> {star['tp_rate']:.3f}, "
              f"lines per scan {one['lines_per_scan']:.1f} -> {star['lines_per_scan']:.1f}")


def print_changes(rows: Sequence[dict], before: str, after: str, *, by: str = "setting", group: str = "kind",
                  values: Sequence[str] = ("recall", "precision")) -> None:
    """Print, per ``group``, each of ``values`` from the row of setting ``before`` to that of ``after``.

    Parameters
    ----------
    rows : sequence of dict
        The rows; exactly one per (``by``, ``group``) pair.
    before, after : str
        The two values of ``by`` to compare.
    by : str, default "setting"
        The key that tells the settings apart.
    group : str, default "kind"
        The key of the groups, printed one line each, in the rows' order.
    values : sequence of str, default ("recall", "precision")
        The keys to print, to three decimals.
    """
    for g in dict.fromkeys(row[group] for row in rows):
        old, new = (next(r for r in rows if r[by] == s and r[group] == g) for s in (before, after))
        print(f"{g}: " + ", ".join(f"{v} {old[v]:.3f} -> {new[v]:.3f}" for v in values))


def fixed_and_auto_on_log(path: str | Path, n_scans: int) -> dict:
    """One recording's row: split-and-merge with ``FIXED_LINES`` against the defaults, without truth.

    The row holds the beam step, the pooled noise estimate, the median auto threshold, and the ray-axis
    RMSE and coverage of both settings.

    Parameters
    ----------
    path : str or Path
        The recording (a bag or a Carmen log).
    n_scans : int
        How many scans from its start.

    Returns
    -------
    dict
        Keys of :data:`FIXED_AND_AUTO_COLUMNS`.
    """
    from .app.experiments import compare_on_logs
    from .io import read_scans
    from .lines.split_merge import split_and_merge
    from .noise import FIXED_LINES, auto_split_threshold, estimate_range_noise, scan_sigma

    scans = list(itertools.islice(read_scans(path), n_scans))
    fixed, auto = compare_on_logs([path], {"FIXED_LINES": partial(split_and_merge, **FIXED_LINES),
                                           "default": split_and_merge}, n_scans=n_scans)
    return {"log": Path(path).name, "step": f"{np.degrees(scans[0].angle_increment):.2f}",
            "sigma_m": estimate_range_noise(scans),
            "split_m": float(np.median([auto_split_threshold(scan_sigma(sc)) for sc in scans])),
            "rmse_fixed": fixed["rmse_m"], "cov_fixed": fixed["coverage"],
            "rmse_auto": auto["rmse_m"], "cov_auto": auto["coverage"]}


def print_auto_on_logs(rows: Sequence[dict], hall_sigma_m: float) -> list[dict]:
    """Print the hall's noise estimate against its truth, then where the default did worse.

    First the first recording's estimate against its simulated noise, then the recordings where the
    default raised the ray-axis RMSE, then how many lost coverage.

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`fixed_and_auto_on_log`, the simulated hall bag first.
    hall_sigma_m : float
        The hall bag's simulated range noise, metres.

    Returns
    -------
    list of dict
        The rows where the default's RMSE is above the fixed setting's.
    """
    first = rows[0]
    print(f"{first['log']}: simulated with {1000 * hall_sigma_m:.0f} mm, estimated {1000 * first['sigma_m']:.1f} mm "
          f"({first['sigma_m'] / hall_sigma_m - 1:+.0%})")
    worse = [r for r in rows if r["rmse_auto"] > r["rmse_fixed"]]
    print(f"the default (\"auto\") raised the ray-axis RMSE on {len(worse)} of {len(rows)} recordings"
          + (": " + ", ".join(f"{r['log']} ({1000 * r['rmse_fixed']:.0f} -> {1000 * r['rmse_auto']:.0f} mm, "
                              f"estimate {1000 * r['sigma_m']:.0f} mm, step {r['step']} deg)" for r in worse)
             if worse else ""))
    print(f"coverage fell on {sum(r['cov_auto'] < r['cov_fixed'] for r in rows)} of {len(rows)}: "
          "lines it cannot place are not reported, so fewer beams are explained")
    return worse


def print_more_circles(rows: Sequence[dict], before: str = "FIXED_CONFIG", after: str = "default") -> list[str]:
    """Print on how many recordings setting ``after`` found more circles per scan than ``before``.

    Parameters
    ----------
    rows : sequence of dict
        Rows of :func:`labkit.app.experiments.round_objects_on_logs`: ``log``, ``setting``, ``circles_per_scan``.
    before, after : str
        The two settings.

    Returns
    -------
    list of str
        The recordings where ``after`` found more.
    """
    per_log: dict[str, dict[str, float]] = {}
    for row in rows:
        per_log.setdefault(row["log"], {})[row["setting"]] = row["circles_per_scan"]
    more = [log for log, c in per_log.items() if c[after] > c[before]]
    print(f"the defaults found more circles per scan than {before} on {len(more)} of {len(per_log)} recordings"
          + (": " + ", ".join(f"{log} {per_log[log][before]:.2f} -> {per_log[log][after]:.2f}" for log in more)
             if more else ""))
    return more

