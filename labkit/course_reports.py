"""Bookkeeping of the course notebooks (01 to 10b): sums, checks, loops over trials, printouts.

A notebook's code cell keeps its experiment (what is run, on which data, with which settings); the
loops that only add up, compare with labkit or format a printout live here, so that the cell stays
short. Every function takes the notebook's rows or arrays as arguments; none computes a "your turn"
answer (the student's function is called in the notebook, and its results come in here).
"""

from __future__ import annotations

import itertools
import math
import os
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
           "print_more_circles", "print_beams_on", "print_iav_verdicts", "print_v_corners", "print_circles",
           "circle_fit_errors", "print_fit_error_summary", "wall_score", "print_merges", "check_extrapolation",
           "print_parameter_sweeps", "majority_label", "walls_found", "print_eps_answers", "extractor_row",
           "print_extractor_table", "lines_on", "score_legs", "print_data_set", "pick_example", "print_match",
           "round_object_notes", "print_level_summaries", "print_speed_and_noise", "print_ranking_against_paper",
           "weighting_row", "print_weighting_verdicts", "print_count_table", "print_recording_summary",
           "print_beam_reasons", "print_seam", "shared_datasets"]

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


# ---------------------------------------------------------------------------- every notebook
def shared_datasets() -> Path:
    """The folder of the course's real recordings, seen from the notebooks' folder.

    Returns
    -------
    Path
        ``$LABKIT_SHARED_DATASETS`` when that is set, else ``../../shared/datasets`` (the datasets beside the
        repository, from ``notebooks/``). It may not exist: the notebooks then skip their real-data cells.
    """
    return Path(os.environ.get("LABKIT_SHARED_DATASETS", "../../shared/datasets"))


# ---------------------------------------------------------------------------- notebook 01: scans
def print_beam_reasons(scan, reasons: Sequence[str]) -> None:
    """Print one line a beam: its number, angle (degrees), range, and "valid" or "invalid, " and its reason.

    Parameters
    ----------
    scan : labkit.Scan
        The scan (its ``angles`` and ``ranges``).
    reasons : sequence of str
        Per beam, why its reading is not a distance, or ``""`` when it is one.
    """
    for i, (theta, r, reason) in enumerate(zip(np.degrees(scan.angles), scan.ranges, reasons, strict=True)):
        print(f"beam {i}: {theta:5.0f} deg  r = {r:5}  {'invalid, ' + reason if reason else 'valid'}")


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
    beaten: dict[float, dict[str, list]] = {}
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


def fixed_and_auto_on_log(path: str | Path, n_scans: int, compare: Callable) -> dict:
    """One recording's row: split-and-merge with ``FIXED_LINES`` against the defaults, without truth.

    The row holds the beam step, the pooled noise estimate, the median auto threshold, and the ray-axis
    RMSE and coverage of both settings.

    Parameters
    ----------
    path : str or Path
        The recording (a bag or a Carmen log).
    n_scans : int
        How many scans from its start.
    compare : callable
        ``labkit.app.experiments.compare_on_logs`` (the library does not import its applications).

    Returns
    -------
    dict
        Keys of :data:`FIXED_AND_AUTO_COLUMNS`.
    """
    from .io import read_scans
    from .lines.split_merge import split_and_merge
    from .noise import FIXED_LINES, auto_split_threshold, estimate_range_noise, scan_sigma

    scans = list(itertools.islice(read_scans(path), n_scans))
    fixed, auto = compare([path], {"FIXED_LINES": partial(split_and_merge, **FIXED_LINES),
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


# ---------------------------------------------------------------------------- notebook 08: IAV circles
def print_beams_on(shapes: Mapping[str, np.ndarray], beam_deg: float) -> dict[str, int]:
    """Print how many beams a scanner at the origin, ``beam_deg`` apart, would put on each shape.

    Parameters
    ----------
    shapes : mapping of str to ndarray
        ``{name: points (M, 2)}``, metres, all in front of the sensor (bearings within 90 degrees of straight ahead).
    beam_deg : float
        The scanner's angular step, degrees.

    Returns
    -------
    dict
        ``{name: beams}``: the bearings' range over the step, plus one.
    """
    beams = {}
    for name, p in shapes.items():
        bearings = np.degrees(np.arctan2(p[:, 1], p[:, 0]))
        beams[name] = int(np.ptp(bearings) / beam_deg) + 1
        print(f"a {beam_deg} deg scanner would put {beams[name]} beams on the {name}, we use {len(p)} points")
    print()
    return beams


def print_iav_verdicts(shapes: Mapping[str, np.ndarray], stats: Mapping) -> dict[str, tuple[bool, bool]]:
    """Print each shape's mean and spread of inscribed angles, the circle test and the V-corner test.

    The circle test is Xavier et al.'s: a mean between 90 and 135 degrees and a spread below
    :data:`labkit.iav.CIRCLE_STD_MAX`; the V-corner test is :func:`labkit.iav.is_v_corner` with a stride of
    an eighth of the angles.

    Parameters
    ----------
    shapes : mapping of str to ndarray
        ``{name: points (M, 2)}``.
    stats : mapping
        ``{name: labkit.iav.iav_stats(points)}``.

    Returns
    -------
    dict
        ``{name: (circle?, V-corner?)}``.
    """
    from . import iav

    verdicts = {}
    print(f"{'shape':9} {'mean (deg)':>10} {'std (deg)':>10}  circle?  v-corner test")
    for name, p in shapes.items():
        mean, std, _ = stats[name]
        is_circle = bool(np.radians(90) <= mean <= np.radians(135) and std < iav.CIRCLE_STD_MAX)
        v = iav.is_v_corner(iav.inscribed_angles(p), stride=max(1, (len(p) - 2) // 8))
        verdicts[name] = (is_circle, v)
        print(f"{name:9} {np.degrees(mean):10.1f} {np.degrees(std):10.1f}  {str(is_circle):7}  {v}")
    return verdicts


def print_v_corners(rows: Sequence[dict], arc_like_std: float) -> dict[str, list]:
    """Print the table of V-shaped corners against the circle tests, then which corners pass which.

    Parameters
    ----------
    rows : sequence of dict
        One per corner: ``opening`` (degrees), ``apex`` (the noise-free apex angle), ``mean`` and ``std`` of
        its noisy inscribed angles (radians), ``v`` (the V test's verdict).
    arc_like_std : float
        The "arc-like" spread limit, radians.

    Returns
    -------
    dict
        Lists of openings: ``circle_like`` (mean in 90-135 degrees), ``circles`` (that and a spread below
        the circle's), ``arc_like`` (a spread below ``arc_like_std``), ``caught`` (arc-like and a V).
    """
    from .iav import CIRCLE_STD_MAX

    def in_band(mean):
        return bool(np.radians(90) <= mean <= np.radians(135))

    print(f"{'opening':>7} {'apex angle':>10} {'mean':>6} {'std':>6}  mean in 90-135  std < 8.6  std < 23  your V test")
    for r in rows:
        print(f"{r['opening']:6d}° {np.degrees(r['apex']):9.1f}° {np.degrees(r['mean']):5.0f}° "
              f"{np.degrees(r['std']):5.1f}°  {str(in_band(r['mean'])):14} {str(r['std'] < CIRCLE_STD_MAX):9}  "
              f"{str(r['std'] < arc_like_std):8}  {r['v']}")
    out = {"circle_like": [r["opening"] for r in rows if in_band(r["mean"])],
           "circles": [r["opening"] for r in rows if in_band(r["mean"]) and r["std"] < CIRCLE_STD_MAX],
           "arc_like": [r["opening"] for r in rows if r["std"] < arc_like_std],
           "caught": [r["opening"] for r in rows if r["std"] < arc_like_std and r["v"]]}
    print(f"\nthe corners of {out['circle_like']} deg have a circle-like mean; {len(out['circles'])} of them pass the "
          f"circle's 8.6 deg spread; {out['arc_like'] or 'none'} would pass the arc-like 23 deg spread, and your V "
          f"test rejects {out['caught'] or 'none'} of those")
    return out


def print_circles(circles: Mapping[str, tuple]) -> None:
    """Print a table of circles: name, centre and radius, metres to four decimals.

    Parameters
    ----------
    circles : mapping
        ``{name: (centre, radius, ...)}``; anything after the radius is ignored.
    """
    print(f"{'':10} {'centre (m)':>18} {'radius (m)':>11}")
    for name, (center, radius, *_) in circles.items():
        print(f"{name:10} {str(np.round(np.asarray(center, dtype=float), 4)):>18} {radius:11.4f}")


def circle_fit_errors(fits: Mapping[str, Callable], arcs: Callable, spans, trials: int, truth: tuple,
                      rng: np.random.Generator) -> tuple[dict, dict]:
    """Median centre and radius errors of circle fits on noisy arcs, span by span.

    For every span, ``trials`` arcs ``arcs(span, rng)`` are drawn and every fit is tried on each; a fit
    that raises ``ValueError`` (collinear points) counts as a failure and adds no error. Prints the points
    per span and the failures.

    Parameters
    ----------
    fits : mapping of str to callable
        ``{name: fit(points)}`` returning ``(centre, radius)`` or an object with ``center`` and ``radius``.
    arcs : callable
        ``arcs(span, rng)``: the points of one noisy arc.
    spans : sequence of float
        The spans, degrees.
    trials : int
        Arcs per span.
    truth : (centre, radius)
        The true circle.
    rng : numpy.random.Generator
        Passed to ``arcs``.

    Returns
    -------
    center_err, radius_err : dict
        ``{name: ndarray (len(spans),)}``: the median distance of the centres from the true one, and the
        median ``|radius - true radius|``, metres.
    """
    true_center, true_radius = np.asarray(truth[0], dtype=float), float(truth[1])
    center_err = {m: np.zeros(len(spans)) for m in fits}
    radius_err = {m: np.zeros(len(spans)) for m in fits}
    failures = {m: 0 for m in fits}
    n_points = {}
    for k, span in enumerate(spans):
        errs: dict[str, tuple[list, list]] = {m: ([], []) for m in fits}
        for _ in range(trials):
            points = arcs(span, rng)
            n_points[int(span)] = len(points)
            for m, fit in fits.items():
                try:
                    out = fit(points)
                except ValueError:
                    failures[m] += 1
                    continue
                c, r = (out.center, out.radius) if hasattr(out, "center") else out
                errs[m][0].append(np.hypot(*(np.asarray(c) - true_center)))
                errs[m][1].append(r - true_radius)
        for m in fits:
            center_err[m][k] = np.median(errs[m][0])
            radius_err[m][k] = np.median(np.abs(errs[m][1]))
    print("points per span:", n_points)
    print("fits that failed (collinear points):", failures)
    return center_err, radius_err


def print_fit_error_summary(spans, center_err: Mapping[str, np.ndarray], *, short_deg: float = 30,
                            middle_deg: tuple[float, float] = (45, 120)) -> dict[str, float]:
    """Print each method's centre error per span, then three summaries of them.

    Parameters
    ----------
    spans : ndarray
        The spans, degrees, 180 among them.
    center_err : mapping of str to ndarray
        ``{method: median centre error per span}``, metres, with an ``"iav"`` and a ``"geometric"`` method.
    short_deg : float, default 30
        Spans up to this are short.
    middle_deg : (float, float), default (45, 120)
        The middle range of spans.

    Returns
    -------
    dict
        ``worst_short`` (the smallest error of any method on a short span, m), ``excess_min`` and
        ``excess_max`` (IAV's error over the geometric fit's, minus 1, in the middle range), ``spread_half``
        (the largest error at 180 degrees, m).
    """
    spans = np.asarray(spans)
    half = list(spans).index(180)
    middle = (spans >= middle_deg[0]) & (spans <= middle_deg[1])
    short = spans <= short_deg
    for m, errors in center_err.items():
        text = ", ".join(f"{s} deg {100 * e:.2f} cm" for s, e in zip(spans, errors, strict=True))
        print(f"{m:9} centre error: {text}")
    worst_short = min(errors[short].min() for errors in center_err.values())
    excess = center_err["iav"][middle] / center_err["geometric"][middle] - 1
    spread_half = max(errors[half] for errors in center_err.values())
    print(f"\nat {spans[short].min()} to {spans[short].max()} deg every method is off by at least "
          f"{100 * worst_short:.1f} cm")
    print(f"between {middle_deg[0]:g} and {middle_deg[1]:g} deg IAV's centre error is {excess.min():+.0%} to "
          f"{excess.max():+.0%} of the geometric fit's")
    print(f"with half of the column visible every method is within {1000 * spread_half:.1f} mm")
    return {"worst_short": float(worst_short), "excess_min": float(excess.min()), "excess_max": float(excess.max()),
            "spread_half": float(spread_half)}


# ---------------------------------------------------------------------------- notebook 05: merge and corners
def wall_score(lines, truth, dr_m: float = 0.05, dalpha: float = math.radians(3)) -> np.ndarray:
    """Notebook 04's score of one scan's lines against its true walls: found, eligible, wrong, lines.

    A wall piece of at least 10 beams and 0.3 m is eligible; it is found when a line lies mostly (over
    half of its beams) on it within ``dr_m`` in r and ``dalpha`` in alpha. A line is wrong when it lies
    mostly on a wall (its beams' most common hit) and matches none of that wall's pieces.

    Parameters
    ----------
    lines : list of labkit.LineSegment
        The scan's lines.
    truth : labkit.sim.ScanTruth
        Its ground truth: ``walls`` (pieces with ``wall_id``, ``r``, ``alpha``, ``n_beams``, ``length``)
        and ``hits`` (what each beam hit).
    dr_m : float, default 0.05
        The tolerance in r, metres.
    dalpha : float, default 3 degrees
        The tolerance in alpha, radians.

    Returns
    -------
    ndarray of int
        ``[found, eligible, wrong, lines]``: arrays of several scans add up.
    """
    from .geometry import angle_difference

    def matches(line, wall):
        return abs(line.r - wall.r) < dr_m and abs(angle_difference(line.alpha, wall.alpha)) < dalpha

    hits = np.asarray(truth.hits)
    eligible = [w for w in truth.walls if w.n_beams >= 10 and w.length >= 0.3]
    found = sum(any(np.mean(hits[line.indices] == w.wall_id) > 0.5 and matches(line, w) for line in lines)
                for w in eligible)
    wrong = 0
    for line in lines:
        ids, counts = np.unique(hits[line.indices], return_counts=True)
        owner = ids[np.argmax(counts)]
        pieces = [w for w in truth.walls if w.wall_id == owner]
        wrong += bool(pieces) and not any(matches(line, w) for w in pieces)
    return np.array([found, len(eligible), wrong, len(lines)])


def print_seam(scan, last, first) -> list[int]:
    """Print a full-circle scan's seam: its end beams, the two lines that meet there, the invalid beams between.

    First the scan itself and whether it is a full circle, then the angles of its first and last beams.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    last, first : labkit.LineSegment
        The scan's last line and its first one.

    Returns
    -------
    list of int
        The invalid beams after ``last``'s last beam, up to the end of the scan.
    """
    print(scan, "| full circle:", scan.is_full_circle)
    print(f"beam 0 is at {np.degrees(scan.angles[0]):.0f} deg, beam {scan.n_beams - 1} at "
          f"{np.degrees(scan.angles[-1]):.0f} deg: neighbours across the seam")
    print(f"last line:  {last}", f"first line: {first}", sep="\n")
    dropped = [i for i in range(last.last + 1, scan.n_beams) if not scan.valid[i]]
    print("invalid beams between them:", dropped, "at", [f"{np.degrees(scan.angles[i]):+.0f} deg" for i in dropped])
    return dropped


def print_merges(before, naive, wrapped) -> int:
    """Print the line counts of two merges, their first and last lines, and the naive merge's pieces.

    Parameters
    ----------
    before : list of labkit.LineSegment
        The lines before merging.
    naive, wrapped : list of labkit.LineSegment
        Merged with the naive angle difference and with the wrapped one; ``wrapped[0]`` is the wall
        across the seam.

    Returns
    -------
    int
        How many of the naive merge's lines lie within the beams of ``wrapped[0]``.
    """
    print(f"{len(before)} lines before merging; naive angles: {len(naive)} after, wrapped: {len(wrapped)} after")
    print("naive, first and last:", naive[0], naive[-1], sep="\n  ")
    print("wrapped, first:", wrapped[0], sep="\n  ")
    wall_behind = set(wrapped[0].indices.tolist())
    behind = [line for line in naive if set(line.indices.tolist()) <= wall_behind]
    print(f"with the naive difference the wall behind the robot stays in {len(behind)} pieces; wrapped, "
          f"it is one line across the seam: {wrapped[0].first > wrapped[0].last}")
    return len(behind)


def check_extrapolation(corners, lines, extrapolation: Callable, max_extension_m: float = 0.1) -> None:
    """Check a corner rule against labkit's ``extrapolated`` flags, then explain the farthest corner.

    Parameters
    ----------
    corners : list of labkit.Corner
        The corners :func:`labkit.find_corners` found in ``lines``.
    lines : list of labkit.LineSegment
        The lines.
    extrapolation : callable
        ``extrapolation(corner)`` returning ``(extension, allowance, neighbours, gap)``: metres, metres,
        whether the two lines end on neighbouring beams, metres.
    max_extension_m : float, default 0.1
        ``find_corners``' allowance away from neighbouring beams.

    Raises
    ------
    AssertionError
        When ``extension > allowance`` differs from a corner's ``extrapolated``.
    """
    from .geometry import angle_difference

    for corner in corners:
        extension, allowance, _, _ = extrapolation(corner)
        assert (extension > allowance) == corner.extrapolated, f"the rule disagrees with labkit at {corner}"
    print("check: your intersection gives labkit's corner points, and the rule gives labkit's `extrapolated`")
    far = max(corners, key=lambda c: np.hypot(*c.point))
    extension, allowance, neighbours, gap = extrapolation(far)
    graze = max(abs(np.degrees(angle_difference(math.atan2(far.point[1], far.point[0]), lines[i].alpha)))
                for i in far.lines)
    print(f"The farthest corner, {far.kind} at ({far.point[0]:.2f}, {far.point[1]:.2f}) m, is "
          f"{np.hypot(*far.point):.1f} m away; the beams there meet one of its walls {graze:.0f} degrees from its "
          f"normal. Its lines must be extended by {100 * extension:.1f} cm to meet, "
          f"{'more' if extension > max_extension_m else 'no more'} than max_extension_m = "
          f"{100 * max_extension_m:.0f} cm; they end on "
          f"{'neighbouring beams' if neighbours else 'beams that are not neighbours'}, "
          f"{100 * gap:.1f} cm apart, so the allowance is {100 * allowance:.1f} cm, and the corner is "
          f"{'' if far.extrapolated else 'not '}marked extrapolated.")


def print_parameter_sweeps(by_threshold: Mapping[float, tuple], by_min_points: Mapping[int, tuple]) -> float:
    """Print the split-threshold and min-points tables, and check and print what they show.

    Parameters
    ----------
    by_threshold : mapping
        ``{split threshold (m): (lines, share of walls found, share of wrong lines)}``, with 0.01, 0.05 and 0.5.
    by_min_points : mapping
        ``{min_points: (lines, found, wrong)}``, with 2, 5 and 20.

    Returns
    -------
    float
        How far the fixed setting (0.05 m, 5 points) is below the best share of walls found.

    Raises
    ------
    AssertionError
        When the tables no longer show that 1 cm gives more lines and 50 cm finds fewer walls than 5 cm,
        or that 2 points give more wrong lines and 20 find fewer walls than 5 (the notebook says so).
    """
    tables: list[tuple[str, Mapping, str]] = [("split threshold (m)", by_threshold, "{:20.2f}"),
                                              ("min points", by_min_points, "{:20d}")]
    for name, rows, fmt in tables:
        print(f"{name:>20} {'lines':>6} {'walls found':>12} {'wrong lines':>12}")
        for value, (n_lines, found, wrong) in rows.items():
            print(f"{fmt.format(value)} {n_lines:6d} {found:12.1%} {wrong:12.1%}")
        if name != "min points":
            print()
    t, m = by_threshold, by_min_points
    print(f"\nsplit threshold 0.01 m: {t[0.01][0]} lines, {t[0.01][0] - t[0.05][0]} more than at 0.05 m; "
          f"0.5 m: {t[0.5][1]:.1%} of the walls found against {t[0.05][1]:.1%} at 0.05 m")
    print(f"min_points 2: {m[2][2]:.1%} wrong lines against {m[5][2]:.1%} at 5; "
          f"min_points 20: {m[20][1]:.1%} of the walls found against {m[5][1]:.1%} at 5")
    assert t[0.01][0] > t[0.05][0] and t[0.5][1] < t[0.05][1], "the split threshold no longer does what the text says"
    assert m[2][2] > m[5][2] and m[20][1] < m[5][1], "min_points no longer does what the text says"
    best = max(found for _, found, _ in [*t.values(), *m.values()])
    print(f"the fixed setting (0.05 m, 5 points) finds {t[0.05][1]:.1%} of the walls, {best - t[0.05][1]:.1%} below "
          f"the best setting of the sweep")
    return float(best - t[0.05][1])


# ---------------------------------------------------------------------------- notebook 07: angular segmentation
def majority_label(labels) -> int:
    """The most common label of ``labels``, noise (negative labels) left out.

    Parameters
    ----------
    labels : ndarray of int
        Cluster labels, -1 for noise.

    Returns
    -------
    int
        The label; the smallest of the most common ones on a tie.

    Raises
    ------
    ValueError
        When every label is noise.
    """
    labels = np.asarray(labels)
    values, counts = np.unique(labels[labels >= 0], return_counts=True)
    if len(values) == 0:
        raise ValueError("every label is noise")
    return int(values[np.argmax(counts)])


def walls_found(lines, walls, dr: float = 0.10, dalpha: float = math.radians(5)) -> int:
    """How many walls some line matches: offset within ``dr`` and normal within ``dalpha`` (infinite lines).

    Parameters
    ----------
    lines : list
        Lines with ``r`` (m) and ``alpha`` (rad).
    walls : list
        True walls with ``r`` and ``alpha``.
    dr : float, default 0.10
        Metres.
    dalpha : float, default 5 degrees
        Radians; the difference is wrapped.

    Returns
    -------
    int
        The number of walls matched.
    """
    from .geometry import angle_difference

    return sum(any(abs(ln.r - w.r) < dr and abs(angle_difference(ln.alpha, w.alpha)) < dalpha for ln in lines)
               for w in walls)


def print_eps_answers(scan, base, wide_dist, narrow_theta) -> None:
    """Print the three slider settings' summaries, then what moving each radius changed.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    base, wide_dist, narrow_theta : tuple
        ``(lines, arrays, text)`` at (3 deg, 0.03 m), (3 deg, 0.35 m) and (1 deg, 0.03 m): the lines,
        the :func:`labkit.angular_arrays` record and its one-line summary.
    """
    for _, _, text in (base, wide_dist, narrow_theta):
        print(text)
    n_base, n_wide = len(base[0]), len(wide_dist[0])
    print(f"eps_dist 0.35 m instead of 0.03 m: {n_wide} segments instead of {n_base}"
          + (": parallel pieces less than 0.35 m apart, such as a recess and its wall, now share a segment"
             if n_wide < n_base else
             ": not fewer, so the recesses do not simply merge into their walls on this scan. Segment sizes "
             f"(points): {sorted(ln.n_points for ln in base[0])} at 0.03 m, "
             f"{sorted(ln.n_points for ln in wide_dist[0])} at 0.35 m: move the slider to see where the new, short "
             "segments lie"))
    share_base, share_narrow = (np.mean(r[1].labels[scan.valid] >= 0) for r in (base, narrow_theta))
    print(f"eps_theta 1 deg instead of 3 deg: {share_narrow:.0%} of the valid beams in a segment instead of "
          f"{share_base:.0%}" + (": noisy directions no longer chain" if share_narrow < share_base else ""))


def extractor_row(world: str, k: int, walls, *line_sets, min_beams: int = 10) -> tuple:
    """One row of the extractor table: world, scan, walls, then (lines, walls found) per set of lines.

    Parameters
    ----------
    world : str
        The world's name.
    k : int
        The scan's index.
    walls : list
        The scan's true walls (with ``n_beams``); those seen by at least ``min_beams`` beams count.
    *line_sets : list
        Each extractor's lines on the scan.
    min_beams : int, default 10
        The fewest beams a wall that counts is seen by.

    Returns
    -------
    tuple
        ``(world, k, walls that count, n_1, found_1, n_2, found_2, ...)`` with :func:`walls_found`.
    """
    seen = [w for w in walls if w.n_beams >= min_beams]
    return (world, k, len(seen), *[v for lines in line_sets for v in (len(lines), walls_found(lines, seen))])


def print_extractor_table(rows) -> np.ndarray:
    """Print the rows of :func:`extractor_row` of three extractors (angular, angular with gaps, split-and-merge).

    Parameters
    ----------
    rows : list of tuple
        ``(world, k, walls, n_ang, found_ang, n_gap, found_gap, n_sm, found_sm)``.

    Returns
    -------
    ndarray
        The column totals from ``walls`` on.
    """
    print(f"{'world':9} {'scan':>4} {'walls':>5} | {'angular, inf':>12} | {'gap 0.3 m':>12} | {'split&merge':>12}")
    print(f"{'':9} {'':>4} {'':>5} | {'lines found':>12} | {'lines found':>12} | {'lines found':>12}")
    for world, k, nw, na, fa, ng, fg, ns, fs in rows:
        print(f"{world:9} {k:4} {nw:5} | {na:5} {fa:6} | {ng:5} {fg:6} | {ns:5} {fs:6}")
    tot = np.array([r[2:] for r in rows]).sum(axis=0)
    print(f"{'total':9} {'':4} {tot[0]:5} | {tot[1]:5} {tot[2]:6} | {tot[3]:5} {tot[4]:6} | {tot[5]:5} {tot[6]:6}")
    print(f"\nsplit_gap_m = 0.3 m: {tot[3]} lines instead of {tot[1]}, {tot[4]} walls found instead of {tot[2]}; "
          f"it changes the lines of {sum(r[3] != r[5] for r in rows)} of the {len(rows)} scans")
    return tot


def lines_on(lines, mask) -> list:
    """The lines most of whose beams (over half) are in ``mask``.

    Parameters
    ----------
    lines : list
        Lines with ``indices`` (their beams).
    mask : ndarray of bool
        One entry per beam.

    Returns
    -------
    list
        Those lines, in order.
    """
    beams = set(np.flatnonzero(mask))
    return [ln for ln in lines if np.mean([b in beams for b in ln.indices]) > 0.5]


# ---------------------------------------------------------------------------- notebook 08b: legs
def score_legs(scans, detections, truth, match_m: float, is_occluded: Callable) -> dict:
    """Score a leg detector's detections against the truth: recall, precision and the misses.

    A true leg is detectable when at least 3 beams hit it and ``is_occluded(scan, first, last)`` is
    False; it is found when a detection of its scan lies within ``match_m`` of its centre. A detection
    is a true positive when it lies within ``match_m`` of some true leg of its scan (detectable or not).

    Parameters
    ----------
    scans : sequence of labkit.Scan
        The scans.
    detections : sequence of list of labkit.Leg
        Per scan, the legs found.
    truth : mapping
        ``truth[scan.stamp_ns].legs``: the true legs (``center``, ``n_beams``, ``first``, ``last``).
    match_m : float
        The largest distance of a match, metres.
    is_occluded : callable
        ``is_occluded(scan, first, last)``: whether a closer return beside the beams hides the leg.

    Returns
    -------
    dict
        ``recall``, ``precision``, ``n_detected``, ``n_true_positive``, ``rows`` (one
        ``(time since the first scan, true centre, found?)`` per detectable true leg) and ``missed``
        (``(scan number, true centre)`` of each detectable leg not found).
    """
    rows, missed = [], []
    n_true_positive = n_detected = 0
    t0 = scans[0].stamp_s
    for k, (scan, found) in enumerate(zip(scans, detections, strict=True)):
        centres = np.array([leg.center for leg in found]).reshape(-1, 2)
        n_detected += len(found)
        true_legs = truth[scan.stamp_ns].legs
        true_centres = np.array([g.center for g in true_legs]).reshape(-1, 2)
        if len(found) and len(true_legs):
            dist = np.linalg.norm(centres[:, None, :] - true_centres[None, :, :], axis=2)   # detections x truths
            n_true_positive += int(np.sum(dist.min(axis=1) <= match_m))
        for g in true_legs:
            if g.n_beams >= 3 and not is_occluded(scan, g.first, g.last):
                hit = len(found) > 0 and bool(np.min(np.hypot(*(centres - np.asarray(g.center)).T)) <= match_m)
                rows.append((scan.stamp_s - t0, g.center, hit))
                if not hit:
                    missed.append((k, g.center))
    return {"recall": float(np.mean([hit for *_, hit in rows])) if rows else math.nan,
            "precision": n_true_positive / n_detected if n_detected else math.nan,
            "n_detected": n_detected, "n_true_positive": n_true_positive, "rows": rows, "missed": missed}


# ---------------------------------------------------------------------------- notebook 10: evaluation
def print_data_set(data) -> None:
    """Print how many scans of each world a simulated set has at each noise level, and the scans' beams.

    Parameters
    ----------
    data : list
        Items of :func:`labkit.app.experiments.nguyen_set`: ``world``, ``noise_std_m``, ``scan``.
    """
    for noise in sorted({item.noise_std_m for item in data}):
        worlds = [item.world for item in data if item.noise_std_m == noise]
        print(f"range noise {1000 * noise:4.0f} mm: "
              + ", ".join(f"{worlds.count(w)} {w}" for w in dict.fromkeys(worlds)))
    scan0 = data[0].scan
    print(f"every scan: {scan0.n_beams} beams from {np.degrees(scan0.angle_min):.0f} to "
          f"{np.degrees(scan0.angle_max):.0f} deg, one every {np.degrees(scan0.angle_increment):.3f} deg")


def pick_example(data, noise: float, extract: Callable | None = None, skip_world: str = "corridor") -> int:
    """The index of a scan for the matching picture: all three kinds of line, and a missed wall if any.

    Among the scans at ``noise`` (not of ``skip_world``) where ``extract`` yields matched, false-positive
    and unscored lines, the first that also misses a wall, else the first; 0 when there is none.

    Parameters
    ----------
    data : list
        Items with ``scan``, ``truth``, ``world``, ``noise_std_m``.
    noise : float
        The noise level to pick from, metres.
    extract : callable, optional
        ``extract(scan)``: the lines; :func:`labkit.split_and_merge` by default.
    skip_world : str, default "corridor"
        A world left out (the corridor's scans are too long and thin for a readable picture).

    Returns
    -------
    int
        The index in ``data``.
    """
    from .evaluation import match_lines
    from .lines.split_merge import split_and_merge
    from .viz.evaluation_plots import line_status

    extract = extract or split_and_merge
    candidates = []
    for k, item in enumerate(data):
        if item.noise_std_m != noise or item.world == skip_world:
            continue
        lines = extract(item.scan)
        match = match_lines(lines, item.truth)
        if len(set(line_status(len(lines), match))) == 3:
            candidates.append((k, len(match.missed) > 0))
    return max(candidates, key=lambda c: c[1])[0] if candidates else 0


def print_match(lines, match) -> None:
    """Print each line's fate under the matching rule (and its wall's errors when matched), then the missed walls.

    Parameters
    ----------
    lines : list of labkit.LineSegment
        The lines.
    match : labkit.LineMatch
        ``labkit.match_lines(lines, truth)``.
    """
    from .viz.evaluation_plots import line_status

    errors = {i: (dr, da) for (i, _), dr, da in zip(match.pairs, match.dr, match.dalpha, strict=True)}
    wall_of = dict(match.pairs)
    for i, (line, status) in enumerate(zip(lines, line_status(len(lines), match), strict=True)):
        text = f"line {i:2d}  beams {line.first:3d}..{line.last:3d}  {line.length:5.2f} m  {status:14}"
        if i in errors:
            text += (f"  wall {wall_of[i]:2d}: dr {1000 * errors[i][0]:+6.1f} mm, "
                     f"dalpha {np.degrees(errors[i][1]):+5.2f} deg")
        print(text)
    print("walls in the truth but missed:", list(match.missed))


def _round_verdict(obj, j: int, m, min_beams: int) -> str:
    if j not in m.truth:
        return f"not in the truth ({'too few beams' if obj.n_beams < min_beams else 'partly hidden'})"
    found = [err for (_, jj), err in zip(m.pairs, m.center_errors, strict=True) if jj == j]
    return f"found, centre {1000 * found[0]:.0f} mm off" if found else "missed"


def round_object_notes(truth, circle_match, leg_match, min_beams=(4, 3)) -> list[tuple]:
    """Print why each true circle and leg of a scan is or is not found, and return the notes for a figure.

    Parameters
    ----------
    truth : labkit.sim.ScanTruth
        The scan's truth: ``circles`` (with ``name``) and ``legs`` (with ``person``), each with ``n_beams``.
    circle_match, leg_match : labkit.RoundMatch
        The matches of the scan's circles and legs (``truth``, ``pairs``, ``center_errors``).
    min_beams : (int, int), default (4, 3)
        The fewest beams a true circle and a true leg need to be in the truth.

    Returns
    -------
    list of (ndarray, str)
        ``(centre, "name: verdict")`` per true object: found (and how far off), missed, or not in the truth
        (too few beams, or partly hidden).
    """
    notes = []
    for kind, objects, m, least in [("circle", truth.circles, circle_match, min_beams[0]),
                                    ("leg", truth.legs, leg_match, min_beams[1])]:
        for j, obj in enumerate(objects):
            name = obj.name if kind == "circle" else f"{obj.person}'s leg"
            print(f"true {kind} {j} ({name}, {obj.n_beams} beams): {_round_verdict(obj, j, m, least)}")
            notes.append((obj.center, f"{name}: {_round_verdict(obj, j, m, least)}"))
    return notes


def print_level_summaries(rows, sweep, best: Mapping, fixed_m: float, round_scores: Mapping) -> None:
    """Print the conclusions of the line and round-object scores, level by level.

    Per noise level, the methods that find most walls, make fewest wrong lines and run fastest; then
    split-and-merge's best threshold against the fixed one; then the round objects' scores.

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`labkit.app.experiments.compare_lines` (``truth`` is the level's count of true walls).
    sweep : list of dict
        Rows of :func:`labkit.app.experiments.sweep_split_and_merge`.
    best : mapping
        ``{noise: the sweep's best row}``.
    fixed_m : float
        The papers' fixed split threshold, metres (one of the sweep's).
    round_scores : mapping
        ``{kind: row}`` with ``precision``, ``recall``, ``center_err_median_m``.
    """
    levels = sorted({r["noise_std_m"] for r in rows})
    for noise in levels:
        level = [r for r in rows if r["noise_std_m"] == noise]
        top_tp = max(level, key=lambda r: r["tp_rate"])
        low_fp = min(level, key=lambda r: r["fp_rate"])
        fastest = max(level, key=lambda r: r["scans_per_s"])
        print(f"range noise {1000 * noise:.0f} mm ({level[0]['truth']} true walls, so one wall is "
              f"{1 / level[0]['truth']:.3f} of TruePos):")
        print(f"  most walls found:   {top_tp['method']} "
              f"(TruePos {top_tp['tp_rate']:.3f}, FalsePos {top_tp['fp_rate']:.3f})")
        print(f"  fewest wrong lines: {low_fp['method']} "
              f"(FalsePos {low_fp['fp_rate']:.3f}, TruePos {low_fp['tp_rate']:.3f})")
        good = [r for r in level if r["tp_rate"] >= 0.9]
        if good and min(good, key=lambda r: r["fp_rate"]) is not low_fp:
            pick = min(good, key=lambda r: r["fp_rate"])
            print(f"  fewest wrong lines among those that find 90 % of the walls: {pick['method']} "
                  f"(FalsePos {pick['fp_rate']:.3f}, TruePos {pick['tp_rate']:.3f})")
        print(f"  fastest:            {fastest['method']} ({fastest['scans_per_s']:,.0f} scans/s)")
    for noise in levels:
        t = best[noise]["split_threshold_m"]
        fixed = next(r for r in sweep if r["noise_std_m"] == noise and math.isclose(r["split_threshold_m"], fixed_m))
        print(f"split-and-merge at {1000 * noise:.0f} mm: best threshold {100 * t:g} cm ({t / noise:.1f} sigma), "
              f"TruePos - FalsePos {best[noise]['tp_rate'] - best[noise]['fp_rate']:.3f} against "
              f"{fixed['tp_rate'] - fixed['fp_rate']:.3f} at the papers' fixed {100 * fixed_m:g} cm")
    for kind, row in round_scores.items():
        print(f"{kind} in the hall: precision {row['precision']:.3f}, recall {row['recall']:.3f}, "
              f"median centre error {1000 * row['center_err_median_m']:.0f} mm")


def _row_of(rows, method: str, noise: float) -> dict:
    return next(r for r in rows if r["method"] == method and r["noise_std_m"] == noise)


def print_speed_and_noise(rows, method: str = "split-and-merge (IEPF)", against: str = "RANSAC") -> tuple[str, str]:
    """Print ``method``'s speed against ``against``'s, and which TruePos noise hurt most and least.

    How many times as many scans per second ``method`` ran as ``against``, level by level, then which
    method's TruePos fell most and which least from the lowest noise level to the highest.

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`labkit.app.experiments.compare_lines`.
    method, against : str
        The two methods whose speeds are compared.

    Returns
    -------
    (str, str)
        The method whose TruePos fell most, and the one that kept it best.
    """
    levels = sorted({r["noise_std_m"] for r in rows})
    methods = list(dict.fromkeys(r["method"] for r in rows))
    for noise in levels:
        ratio = _row_of(rows, method, noise)["scans_per_s"] / _row_of(rows, against, noise)["scans_per_s"]
        print(f"noise {1000 * noise:.0f} mm: {method} ran {ratio:.1f} times as many scans per second as {against}")
    low, high = levels[0], levels[-1]
    change = {m: _row_of(rows, m, high)["tp_rate"] - _row_of(rows, m, low)["tp_rate"] for m in methods}
    worst_hit, best_kept = min(change, key=lambda m: change[m]), max(change, key=lambda m: change[m])
    print(f"\nTruePos from {1000 * low:.0f} to {1000 * high:.0f} mm of noise: largest fall {worst_hit} "
          f"({change[worst_hit]:+.3f}), best kept {best_kept} ({change[best_kept]:+.3f})")
    return worst_hit, best_kept


def print_ranking_against_paper(rows, published: Mapping[str, float], method: str = "split-and-merge (IEPF)") -> dict:
    """Compare our FalsePos ranking of the methods with the published one, level by level.

    For every pair of methods the paper ranks apart, count how many we rank the same way (a random order
    would get half on average); name our lowest FalsePos and the paper's, ``method``'s rank, and the pairs
    we rank the other way.

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`labkit.app.experiments.compare_lines`.
    published : mapping
        ``{method: published FalsePos}``; only the methods also in ``rows`` count.
    method : str, default "split-and-merge (IEPF)"
        The method whose rank is printed.

    Returns
    -------
    dict
        ``{noise: number of pairs ranked the same way}``.
    """
    levels = sorted({r["noise_std_m"] for r in rows})
    shared = [m for m in dict.fromkeys(r["method"] for r in rows) if m in published]
    strict_pairs = [(a, b) for a in shared for b in shared if published[a] < published[b]]
    print("\nFalsePos, published (Nguyen et al.): "
          + ", ".join(f"{m} {published[m]:.2f}" for m in sorted(shared, key=lambda m: published[m])))
    agreed = {}
    for noise in levels:
        ours = {m: _row_of(rows, m, noise)["fp_rate"] for m in shared}
        agree = agreed[noise] = sum(ours[a] < ours[b] for a, b in strict_pairs)
        print(f"FalsePos, ours at {1000 * noise:.0f} mm:            "
              + ", ".join(f"{m} {ours[m]:.2f}" for m in sorted(shared, key=lambda m: ours[m])))
        verdict = "more than" if agree > len(strict_pairs) / 2 else "no more than"
        print(f"  of the {len(strict_pairs)} pairs of methods the paper ranks apart, we rank {agree} the same way: "
              f"{verdict} a random order would on average ({len(strict_pairs) / 2:g})")
        ours_best = min(ours, key=lambda m: ours[m])
        paper_best = min(shared, key=lambda m: published[m])
        rank = sorted(shared, key=lambda m: ours[m]).index(method) + 1
        same = "as in the paper" if ours_best == paper_best else f"the paper's lowest is {paper_best}"
        print(f"  lowest FalsePos here: {ours_best} ({ours[ours_best]:.2f}; {same}); "
              f"{method} is {rank} of {len(shared)}")
        disagree = [(a, b) for a, b in strict_pairs if not ours[a] < ours[b]]
        print("  pairs we rank the other way (paper: first < second): "
              + "; ".join(f"{a} < {b}" for a, b in disagree))
    return agreed


# ---------------------------------------------------------------------------- notebook 03: weights
def weighting_row(name: str, label: str, rho, theta, weights, sigma, alpha: float, samples) -> tuple:
    """One row of the weighting table: propagated sigma_r and sigma_alpha beside their Monte Carlo spread.

    Parameters
    ----------
    name, label : str
        The noise model's and the weighting's names, printed first.
    rho, theta : ndarray
        The noise-free wall's ranges (m) and bearings (rad).
    weights : str, ndarray or None
        The weights, as :func:`labkit.fit_line_polar` takes them.
    sigma : ndarray
        The range noise of each beam, metres.
    alpha : float
        The wall's true normal angle, radians.
    samples : ndarray, shape (N, len(rho))
        Noisy copies of ``rho``.

    Returns
    -------
    (ndarray, ndarray)
        The propagated ``(sigma_r, sigma_alpha)`` of the noise-free fit, and the standard deviations of r
        and of alpha (wrapped, against ``alpha``) over the samples' fits.
    """
    from .fitting import fit_line_polar
    from .geometry import angle_difference

    C = fit_line_polar(rho, theta, weights, range_sigma=sigma).covariance
    fits = [fit_line_polar(s, theta, weights, range_sigma=sigma) for s in samples]
    r_k, a_k = np.array([f.r for f in fits]), np.array([f.alpha for f in fits])
    sd = np.sqrt(np.diag(C))
    mc = np.array([r_k.std(), angle_difference(a_k, alpha).std()])
    print(f"{name:27} {label:17} {1000 * sd[0]:12.2f} {1000 * mc[0]:9.2f} {np.degrees(sd[1]):18.4f} "
          f"{np.degrees(mc[1]):7.4f}")
    return sd, mc


def print_weighting_verdicts(propagated: Mapping, spread: Mapping, models, labels, ideal: str = "ideal") -> list:
    """Print what the weighting table shows, checking that no weighting beats the ideal one.

    Per noise model the weights of smallest sigma_r and what the others lose; checks that the ideal
    weights are never beaten and that the Monte Carlo spread agrees; then where ``inverse_variance``
    loses, where weights tie with the ideal ones, and where 1/rho helps.

    Parameters
    ----------
    propagated, spread : mapping
        ``{(model, weighting): (sigma_r, sigma_alpha)}``: propagated, and measured by Monte Carlo.
    models : iterable of str
        The noise models.
    labels : sequence of str
        The weightings, the ideal one last; ``"uniform"``, ``"1/rho"`` and ``"inverse_variance"`` among them.
    ideal : str, default "ideal"
        The ideal weighting's label.

    Returns
    -------
    list of str
        The models under which ``inverse_variance`` loses more than 5 % in sigma_r.

    Raises
    ------
    AssertionError
        When another weighting beats the ideal one (Gauss-Markov says none can), or the Monte Carlo spread
        is more than 12 % off the propagated sigma.
    """
    models = list(models)
    for name in models:
        ranking = sorted(labels, key=lambda k: propagated[name, k][0])
        best = ranking[0]
        losses = ", ".join(f"{k} +{100 * (propagated[name, k][0] / propagated[name, best][0] - 1):.0f}%"
                           for k in ranking[1:])
        print(f"{name}: smallest sigma_r with {best} weights ({1000 * propagated[name, best][0]:.2f} mm); {losses}")
        # Gauss-Markov: inverse-variance weights of the distances are the best linear choice, for r and alpha
        assert all(propagated[name, ideal][j] <= propagated[name, k][j] * (1 + 1e-9) for k in labels for j in (0, 1)), \
            f"a weighting beats the ideal one under {name}"
        assert all(np.allclose(spread[name, k], propagated[name, k], rtol=0.12) for k in labels), \
            f"the Monte Carlo spread disagrees with the propagated sigmas under {name}"
    worse = [name for name in models if propagated[name, "inverse_variance"][0] > 1.05 * propagated[name, ideal][0]]
    print("\nThe ideal weights 1/(sigma^2 cos^2(theta - alpha)) are never beaten, under any noise model (asserted "
          "above). 'inverse_variance' (1/sigma^2 alone) loses more than 5% in sigma_r under: "
          f"{', '.join(worse) or 'none'}.")
    for name in models:
        tied = [k for k in labels if k != ideal and np.isclose(propagated[name, k][0], propagated[name, ideal][0],
                                                                 rtol=1e-6)]
        if tied:
            print(f"under {name} noise, {' and '.join(tied)} give exactly the ideal sigma_r: there those weights are "
                  "the ideal ones times a constant, and a constant factor does not change a weighted fit")
    for name in models:
        side = "helps" if propagated[name, "1/rho"][0] < propagated[name, "uniform"][0] else "hurts"
        print(f"against uniform weights, 1/rho {side} under {name} noise")
    return worse


# ---------------------------------------------------------------------------- notebook 09b: configurations
def print_count_table(runs: Mapping, kinds=("segments", "lines", "corners", "circles", "legs"),
                      stages=("lines", "corners", "total")) -> None:
    """Print a table with one column per run: mean counts per scan, mean milliseconds per stage.

    Parameters
    ----------
    runs : mapping of str to list of labkit.Features
        ``{name: one Features per scan}``.
    kinds : sequence of str
        Keys of ``Features.counts()``.
    stages : sequence of str
        Keys of ``Features.timings`` (seconds, printed as milliseconds).
    """
    print(f"{'per scan (mean)':22}" + "".join(f"{name:>10}" for name in runs))
    for kind in kinds:
        print(f"{kind:22}" + "".join(f"{np.mean([f.counts()[kind] for f in fs]):10.2f}" for fs in runs.values()))
    for stage in stages:
        print(f"{'ms ' + stage:22}" + "".join(f"{1e3 * np.mean([f.timings[stage] for f in fs]):10.3f}"
                                             for fs in runs.values()))


# ---------------------------------------------------------------------------- notebook 09: playback
def print_recording_summary(scans, features, kinds) -> dict:
    """Print a recording's beams, rate, share of invalid beams and features per scan.

    Parameters
    ----------
    scans : list of labkit.Scan
        The scans, in order (at least two).
    features : list of labkit.Features
        One per scan.
    kinds : sequence of str
        Keys of ``Features.counts()`` to average.

    Returns
    -------
    dict
        ``{kind: mean count per scan}``.
    """
    first = scans[0]
    span_s = (scans[-1].stamp_ns - first.stamp_ns) / 1e9
    print(f"{first.n_beams} beams, one every {np.degrees(first.angle_increment):.2f} deg, "
          f"range_max {first.range_max:.2f} m")
    print(f"{len(scans)} scans over {span_s:.0f} s ({len(scans) / span_s:.2f} scans per second)")
    print(f"invalid beams: {np.mean([1 - s.valid.mean() for s in scans]):.1%} on average")
    mean_counts = {k: float(np.mean([f.counts()[k] for f in features])) for k in kinds}
    print("features per scan:", ", ".join(f"{k} {v:.2f}" for k, v in mean_counts.items()))
    return mean_counts
