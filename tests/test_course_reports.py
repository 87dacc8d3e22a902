"""The course notebooks' check cases (labkit.course_cases) and bookkeeping (labkit.course_reports): checked
against values worked out by hand."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import labkit
from labkit import course_cases as cases
from labkit import course_fallbacks as fallbacks
from labkit import course_reports as reports
from labkit import course_shapes as shapes
from labkit import iav
from labkit.course import YourTurnError, check


def _no_stride(angles, n_neighbours=4, stride=1):       # neighbours next to each other, whatever the stride
    i = int(np.argmin(angles))
    k = n_neighbours // 2
    if i < k or i + k >= len(angles):
        return False
    return bool(np.all(np.diff(angles[i - k:i + 1]) < 0) and np.all(np.diff(angles[i:i + k + 1]) > 0))


@pytest.mark.parametrize("name, wrong", [
    # the perpendicular distance, not the one along the ray
    ("ray_axis_error", lambda range_m, angle, line_r, line_alpha: range_m - line_r),
    # the inverse-range residual without the factor r_mid ** 2 that turns it back into metres
    ("three_beam_residual", lambda a, b, c, d: 1 / b - (1 / a + 1 / c) / (2 * math.cos(d))),
])
def test_the_cases_pass_labkits_answer_and_fail_a_wrong_one(name, wrong, capsys):
    assert check(getattr(fallbacks, name), getattr(cases, name)(), fallback=None) is getattr(fallbacks, name)
    assert "well done" in capsys.readouterr().out
    with pytest.raises(YourTurnError, match="Hint"):
        check(wrong, getattr(cases, name)(), fallback=None, name=name)


def test_the_notebook_08_cases_pass_labkits_answers_and_fail_wrong_ones(capsys):
    corner = iav.inscribed_angles(shapes.v_corner_points(90.0))
    v_cases = cases.is_v_shaped(corner, stride=2)
    assert check(iav.is_v_corner, v_cases, fallback=None) is iav.is_v_corner
    assert check(iav.middle_point_offset, cases.middle_ratio(), fallback=None) is iav.middle_point_offset
    assert check(fallbacks.radius_and_height, cases.radius_and_height(), fallback=None) is fallbacks.radius_and_height
    assert capsys.readouterr().out.count("well done") == 3
    with pytest.raises(YourTurnError, match="stride angles apart"):
        check(_no_stride, v_cases, fallback=None, name="is_v_shaped")
    with pytest.raises(YourTurnError, match="the sign"):               # the offset's size without its sign
        check(lambda p, v: abs(iav.middle_point_offset(p, v)), cases.middle_ratio(), fallback=None)
    with pytest.raises(YourTurnError, match="half the chord"):         # the printed slip: the whole chord
        check(lambda d, a: (d / 2 / math.cos(a - math.pi / 2), d * math.tan(a - math.pi / 2)),
              cases.radius_and_height(), fallback=None)


def test_ray_axis_cases_by_hand():
    # 60 deg off the normal of x = 2 the ray meets the wall 2 / cos(60 deg) = 4 m away: 4.1 m measured is 0.1 m
    by_args = {c.args: c.expected for c in cases.ray_axis_error()}
    assert by_args[(4.1, math.radians(60), 2.0, 0.0)] == 0.1
    assert math.isnan(by_args[(3.0, math.radians(100), 2.0, 0.0)])


def _wall_segment(y0, y1):
    pts = np.array([[2.0, y0], [2.0, 0.0], [2.0, y1]])      # on the wall x = 2
    return labkit.line_segment(pts, np.arange(3))


def test_pooled_ray_errors_adds_up_scans_by_hand(capsys):
    a = math.atan(0.5)                                        # the ray meets x = 2 at (2, 1), sqrt(5) m away
    scans = [labkit.Scan(np.array([2.1, math.sqrt(5.0)]), np.array([0.0, a])),    # errors 0.1 and 0
             labkit.Scan(np.array([1.9, 3.0]), np.array([0.0, a]))]              # -0.1; (2, 1) is past the end
    lines = [[_wall_segment(-1.0, 1.5)], [_wall_segment(-1.0, 0.2)]]
    total = reports.pooled_ray_errors(scans, lines, label="all lines")
    np.testing.assert_allclose(sorted(total.errors), [-0.1, 0.0, 0.1], atol=1e-9)
    assert total.n_valid == 4 and total.coverage == 0.75
    assert math.isclose(total.rmse, math.sqrt(0.02 / 3))
    assert capsys.readouterr().out == "all lines         : RMSE   81.6 mm, coverage  75.0%, 1.0 lines per scan\n"
    with pytest.raises(ValueError, match="2 scans but 1"):
        reports.pooled_ray_errors(scans, lines[:1])


def test_slant_ratios_are_one_over_cos_by_hand(capsys):
    # the wall x = 2: the beam at 0 deg measures 2.1 m, the one at 60 deg 4.2 m (its point at x = 2.1)
    scan = labkit.Scan(np.array([2.1, 4.2]), np.array([0.0, math.radians(60)]))
    segment = SimpleNamespace(r=2.0, alpha=0.0)
    ratios = reports.print_slant_ratios(scan, segment, np.array([0.1, 0.2]), np.array([True, True]))
    np.testing.assert_allclose(ratios, [1.0, 2.0])
    assert capsys.readouterr().out.splitlines()[1].endswith("[1.0, 2.0]")


def test_error_summary_by_hand(capsys):
    reports.print_error_summary({"iepf": np.array([0.003, 0.004, 0.2])})
    row = capsys.readouterr().out.splitlines()[1].split()
    # median 4 mm, one of three beyond 10 cm, RMSE sqrt((9e-6 + 16e-6 + 0.04) / 3) = 115.5 mm
    assert row == ["iepf", "4.0", "33.33%", "115.5"]


def test_fixed_threshold_drift_names_the_rate_that_moves_more(capsys):
    rows = [{"noise_std_m": 0.005, "tp_rate": 0.9, "fp_rate": 0.1},
            {"noise_std_m": 0.03, "tp_rate": 0.85, "fp_rate": 0.4}]
    assert reports.print_fixed_threshold_drift(rows, 0.05) == "FalsePos"
    out = capsys.readouterr().out
    assert "the fixed threshold is 10.0 sigma" in out and "TruePos moves by -0.050, FalsePos by +0.300" in out
    rows[1]["fp_rate"] = 0.12
    assert reports.print_fixed_threshold_drift(rows, 0.05) == "TruePos"


def test_scaled_residuals_on_a_circle_by_hand(capsys):
    # equal ranges: s = r (1 - 1 / cos(dtheta)) and k = sqrt(1 + 2 w^2), w = 1 / (2 cos(dtheta))
    dtheta = math.radians(1.0)
    scan = labkit.Scan(np.full(7, 3.0), np.arange(7) * dtheta)
    mid = np.arange(1, 6)
    s = np.full(5, 3.0 * (1 - 1 / math.cos(dtheta)))
    z = reports.scaled_residuals(s, scan, mid)
    w = 1 / (2 * math.cos(dtheta))
    np.testing.assert_allclose(z, s / math.sqrt(1 + 2 * w ** 2))
    assert "on 5 of 7 beams" in capsys.readouterr().out
    with pytest.raises(AssertionError, match="not labkit's"):
        reports.scaled_residuals(s * 1.5, scan, mid)


def test_on_one_wall_by_hand():
    truth = SimpleNamespace(hits=np.array([0, 0, 0, 1, 1, 1, 7]), walls=[SimpleNamespace(wall_id=0),
                                                                        SimpleNamespace(wall_id=1)])
    # beam 6 hit object 7, not a wall
    assert reports.on_one_wall(truth, np.arange(1, 6)).tolist() == [True, False, False, True, False]


def test_noise_estimates_report_the_furthest_level(capsys):
    rows = [{"noise_std_m": 0.01, "mean_m": 0.0102, "sd_m": 0.001, "ratio": 1.02, "plain_m": 0.03},
            {"noise_std_m": 0.02, "mean_m": 0.0194, "sd_m": 0.004, "ratio": 0.97, "plain_m": 0.05}]
    assert math.isclose(reports.print_noise_estimates(rows), 0.03)
    out = capsys.readouterr().out
    assert "within 3.0% of the true sigma at every level (furthest at 20 mm)" in out
    assert "spreads by 9.8% to 20.6%" in out and "the plain std is 2.5 to 3.0 times" in out


def _row(**kw):
    return {"noise_std_m": 0.01, **kw}


def score(row):
    return row["tp_rate"] - row["fp_rate"]


def test_best_fixed_and_the_thresholds_better_on_both(capsys):
    sweep = [_row(split_threshold_m=0.02, tp_rate=0.9, fp_rate=0.3),    # score 0.60
             _row(split_threshold_m=0.05, tp_rate=0.85, fp_rate=0.1),   # 0.75: the best
             _row(split_threshold_m=0.1, tp_rate=0.6, fp_rate=0.05)]    # 0.55
    auto = {("A", 0.01): _row(tp_rate=0.8, fp_rate=0.12), ("B", 0.01): _row(tp_rate=0.95, fp_rate=0.01)}
    assert reports.print_best_fixed_against_auto(sweep, auto, score, ("A", "B")) == {0.01: {"A": [0.05], "B": []}}
    out = capsys.readouterr().out
    assert "best fixed threshold 5 cm" in out and out.rstrip().endswith("better on both: none")


def test_one_threshold_for_all_levels_by_its_worst_level(capsys):
    sweep = [{"noise_std_m": n, "split_threshold_m": t, "tp_rate": tp, "fp_rate": 0.0}
             for n, t, tp in [(0.01, 0.02, 0.6), (0.03, 0.02, 0.2), (0.01, 0.05, 0.5), (0.03, 0.05, 0.3)]]
    auto_rows = [{"method": "A", "noise_std_m": n, "tp_rate": tp, "fp_rate": 0.0}
                 for n, tp in [(0.01, 0.7), (0.03, 0.4)]]
    assert reports.print_one_threshold_for_all(sweep, auto_rows, score, ("A",)) == 0.05   # worst 0.3 beats 0.2
    out = capsys.readouterr().out
    assert "5 cm does best at its worst level (30 mm: TruePos - FalsePos 0.300)" in out
    assert "A: worst level 30 mm, TruePos - FalsePos 0.400" in out


def test_place_confidence_effect_and_changes(capsys):
    auto = {("A", 0.01): {"tp_rate": 0.9, "fp_rate": 0.2, "lines_per_scan": 9.0},
            ("B", 0.01): {"tp_rate": 0.85, "fp_rate": 0.05, "lines_per_scan": 7.5}}
    reports.print_place_confidence_effect(auto, "A", "B")
    rows = [{"setting": s, "kind": k, "recall": r, "precision": p}
            for s, k, r, p in [("old", "circles", 0.5, 1.0), ("new", "circles", 0.75, 0.9), ("old", "legs", 0.2, 1.0),
                               ("new", "legs", 0.4, 0.8)]]
    reports.print_changes(rows, "old", "new")
    assert capsys.readouterr().out.splitlines() == [
        "  noise 10 mm: FalsePos 0.200 -> 0.050, TruePos 0.900 -> 0.850, lines per scan 9.0 -> 7.5",
        "circles: recall 0.500 -> 0.750, precision 1.000 -> 0.900",
        "legs: recall 0.200 -> 0.400, precision 1.000 -> 0.800"]


def test_auto_on_logs_and_more_circles(capsys):
    rows = [{"log": "hall.bag", "sigma_m": 0.012, "step": "0.50", "rmse_fixed": 0.02, "rmse_auto": 0.018,
             "cov_fixed": 0.9, "cov_auto": 0.85},
            {"log": "intel.log.gz", "sigma_m": 0.03, "step": "1.00", "rmse_fixed": 0.05, "rmse_auto": 0.08,
             "cov_fixed": 0.8, "cov_auto": 0.8}]
    assert reports.print_auto_on_logs(rows, hall_sigma_m=0.01) == [rows[1]]
    circles = [{"log": log, "setting": s, "circles_per_scan": c}
               for log, s, c in [("a", "FIXED_CONFIG", 1.0), ("a", "default", 1.5), ("b", "FIXED_CONFIG", 2.0),
                                 ("b", "default", 2.0)]]
    assert reports.print_more_circles(circles) == ["a"]
    assert capsys.readouterr().out.splitlines() == [
        "hall.bag: simulated with 10 mm, estimated 12.0 mm (+20%)",
        "the default (\"auto\") raised the ray-axis RMSE on 1 of 2 recordings: intel.log.gz (50 -> 80 mm, "
        "estimate 30 mm, step 1.00 deg)",
        "coverage fell on 1 of 2: lines it cannot place are not reported, so fewer beams are explained",
        "the defaults found more circles per scan than FIXED_CONFIG on 1 of 2 recordings: a 1.00 -> 1.50"]


def test_fixed_and_auto_on_a_bag_are_its_pooled_ray_errors():
    from labkit.app.experiments import compare_on_logs
    from labkit.noise import FIXED_LINES

    bag = labkit.bundled_data("hall.bag")
    row = reports.fixed_and_auto_on_log(bag, 3, compare_on_logs)
    scans = list(labkit.read_scans(bag))[:3]
    fixed = reports.pooled_ray_errors(scans, [labkit.split_and_merge(s, **FIXED_LINES) for s in scans])
    auto = reports.pooled_ray_errors(scans, [labkit.split_and_merge(s) for s in scans])
    assert math.isclose(row["rmse_fixed"], fixed.rmse) and math.isclose(row["cov_fixed"], fixed.coverage)
    assert math.isclose(row["rmse_auto"], auto.rmse) and math.isclose(row["cov_auto"], auto.coverage)
    assert row["log"] == "hall.bag" and row["step"] == f"{math.degrees(scans[0].angle_increment):.2f}"
    assert set(row) == set(reports.FIXED_AND_AUTO_COLUMNS)


# ---------------------------------------------------------------------------- notebook 08
def test_add_range_noise_moves_points_along_their_beams():
    rng, again = np.random.default_rng(3), np.random.default_rng(3)
    points = np.array([[3.0, 4.0], [0.0, 2.0]])
    moved = shapes.add_range_noise(points, 0.1, rng)
    e = again.normal(0, 0.1, 2)
    np.testing.assert_allclose(moved, [[3.0 * (5 + e[0]) / 5, 4.0 * (5 + e[0]) / 5], [0.0, 2.0 + e[1]]])


def test_the_shapes_by_hand():
    s = shapes.iav_test_shapes(5)
    np.testing.assert_allclose(np.hypot(*(s["arc"] - (3.0, 0.0)).T), 0.25)          # on the column
    np.testing.assert_allclose(s["arc"][[0, 2, 4]], [[2.875, 0.25 * math.sin(math.radians(120))], [2.75, 0.0],
                                                      [2.875, -0.25 * math.sin(math.radians(120))]], atol=1e-12)
    np.testing.assert_allclose(s["line"], np.c_[np.full(5, 3.0), [-0.4, -0.2, 0.0, 0.2, 0.4]])
    arm = 0.4 / math.sqrt(2)                                      # the corner: apex at (3 - arm, 0), arms at 45 deg
    np.testing.assert_allclose(s["V-corner"][[0, 2, 4]], [[3.0, -arm], [3.0 - arm, 0.0], [3.0, arm]])
    v = shapes.v_corner_points(60.0, arm_m=1.0, n=3, apex=(2.0, 0.0))
    np.testing.assert_allclose(v, [[2.0 + math.cos(math.radians(30)), -0.5], [2.0, 0.0],
                                   [2.0 + math.cos(math.radians(30)), 0.5]])


def test_noisy_arc_has_a_point_per_beam_and_faces_the_sensor():
    # 100 deg of R = 0.25 m is 0.4363 m of arc; beams 3 m * 0.5 deg = 0.02618 m apart: int(16.67) + 1 = 17 points
    step = 3.0 * math.radians(0.5)
    pts = shapes.noisy_arc((3.0, 0.0), 0.25, 100.0, np.random.default_rng(0), beam_step_m=step, sigma_m=0.0,
                           turn_deg=0.0)
    assert len(pts) == 17
    np.testing.assert_allclose(np.hypot(*(pts - (3.0, 0.0)).T), 0.25)
    c, s = 0.25 * math.cos(math.radians(50)), 0.25 * math.sin(math.radians(50))   # from 130 deg to 230 deg
    np.testing.assert_allclose(pts[[0, -1]], [[3.0 - c, s], [3.0 - c, -s]])
    assert len(shapes.noisy_arc((3.0, 0.0), 0.25, 5.0, np.random.default_rng(0), beam_step_m=step, sigma_m=0.0)) == 4


def test_beams_on_and_iav_verdicts_by_hand(capsys):
    # a wall from (3, -3) to (3, 3) spans bearings -45..45 deg: 90 / 0.5 + 1 = 181 beams
    wall = np.c_[np.full(7, 3.0), np.linspace(-3, 3, 7)]
    assert reports.print_beams_on({"wall": wall}, beam_deg=0.5) == {"wall": 181}
    half = np.c_[3.0 - np.sin(np.linspace(0, np.pi, 9)), np.cos(np.linspace(0, np.pi, 9))]  # half circle: 90 deg
    pts = {"half circle": half, "wall": wall}
    verdicts = reports.print_iav_verdicts(pts, {k: iav.iav_stats(p) for k, p in pts.items()})
    assert verdicts == {"half circle": (True, False), "wall": (False, False)}
    out = capsys.readouterr().out
    assert "a 0.5 deg scanner would put 181 beams on the wall, we use 7 points" in out
    assert "half circle       90.0        0.0  True     False" in out


def test_v_corners_sorts_openings_into_the_tests(capsys):
    deg = math.radians
    rows = [{"opening": 60, "apex": deg(60), "mean": deg(120), "std": deg(20), "v": True},    # circle-like, arc-like
            {"opening": 90, "apex": deg(90), "mean": deg(130), "std": deg(5), "v": False},    # passes as a circle
            {"opening": 150, "apex": deg(150), "mean": deg(165), "std": deg(10), "v": False}]  # arc-like only
    out = reports.print_v_corners(rows, deg(23))
    assert out == {"circle_like": [60, 90], "circles": [90], "arc_like": [60, 90, 150], "caught": [60]}
    text = capsys.readouterr().out
    assert "    60°      60.0°   120°  20.0°  True           False      True      True" in text
    assert "the corners of [60, 90] deg have a circle-like mean; 1 of them pass" in text


def test_circles_table(capsys):
    reports.print_circles({"truth": (np.array([3.0, 0.0]), 0.25, "0.6"), "fit": ((3.00004, -0.1), 0.3)})
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].split() == ["truth", "[3.", "0.]", "0.2500"] and lines[2].split()[-1] == "0.3000"


def test_circle_fit_errors_are_medians_by_hand(capsys):
    # three "trials" per span; a fit that is off by the trial number in x, another that fails on the second
    draws = iter(range(100))

    def arcs(span, rng):
        return np.array([[next(draws), 0.0]] * 3)

    def off_by(points):
        return (points[0, 0] % 3, 0.0), 1.0 + points[0, 0] % 3      # trial k: centre off by k m, radius by k m

    def fails_on_1(points):
        if points[0, 0] % 3 == 1:
            raise ValueError("collinear")
        return np.zeros(2), 1.0

    center, radius = reports.circle_fit_errors({"a": off_by, "b": fails_on_1}, arcs, [30, 180], 3,
                                               (np.zeros(2), 1.0), np.random.default_rng(0))
    np.testing.assert_allclose(center["a"], [1.0, 1.0])          # the median of 0, 1, 2
    np.testing.assert_allclose(radius["a"], [1.0, 1.0])
    np.testing.assert_allclose(center["b"], [0.0, 0.0])
    out = capsys.readouterr().out
    assert "points per span: {30: 3, 180: 3}" in out and "{'a': 0, 'b': 2}" in out


def test_fit_error_summary_by_hand(capsys):
    spans = np.array([20, 30, 45, 90, 180])
    err = {"iav": np.array([0.2, 0.1, 0.03, 0.02, 0.004]), "geometric": np.array([0.3, 0.05, 0.02, 0.01, 0.002])}
    out = reports.print_fit_error_summary(spans, err, short_deg=30, middle_deg=(45, 120))
    assert out == pytest.approx({"worst_short": 0.05, "excess_min": 0.5, "excess_max": 1.0, "spread_half": 0.004})
    text = capsys.readouterr().out
    assert "at 20 to 30 deg every method is off by at least 5.0 cm" in text
    assert "between 45 and 120 deg IAV's centre error is +50% to +100% of the geometric fit's" in text
    assert "within 4.0 mm" in text


# ---------------------------------------------------------------------------- notebook 05
def _wall(wall_id, r, alpha, n_beams, length):
    return SimpleNamespace(wall_id=wall_id, r=r, alpha=alpha, n_beams=n_beams, length=length)


def test_wall_score_by_hand():
    walls = [_wall(1, 2.0, 0.0, 20, 1.0), _wall(2, 3.0, math.pi / 2, 5, 1.0),   # wall 2: too few beams to count
             _wall(3, 4.0, math.pi, 12, 0.5)]
    truth = SimpleNamespace(walls=walls, hits=np.r_[np.full(20, 1), np.full(5, 2), np.full(12, 3)])

    def line(r, alpha, beams):
        return SimpleNamespace(r=r, alpha=alpha, indices=np.arange(*beams))

    lines = [line(2.01, 0.01, (0, 20)),                  # finds wall 1
             line(3.2, math.pi / 2, (20, 25)),          # on wall 2, 20 cm off: wrong
             line(4.0, -math.pi + 0.01, (25, 37))]      # finds wall 3: its alpha wraps to 0.57 deg off
    assert reports.wall_score(lines, truth).tolist() == [2, 2, 1, 3]
    lines[2].alpha = -math.pi + 0.1                    # 5.7 deg off: wall 3 missed, the line wrong
    assert reports.wall_score(lines, truth).tolist() == [1, 2, 2, 3]


def test_the_notebook_05_cases_pass_labkits_answers_and_fail_wrong_ones(capsys):
    a, b = cases._line(3.0, 179.0), cases._line(3.01, -179.5)      # 1.5 deg apart across +-180
    assert check(fallbacks.similar_lines, cases.similar_lines(a, b), fallback=None) is fallbacks.similar_lines
    first, second = SimpleNamespace(r=2.0, alpha=0.0), SimpleNamespace(r=1.0, alpha=math.pi / 2)   # x = 2, y = 1
    meet = labkit.geometry.intersect_lines
    assert check(meet, cases.intersection(first, second, (2.0, 1.0)), fallback=None) is meet
    assert capsys.readouterr().out.count("well done") == 2

    def naive(a, b, dr_max_m=0.2, dalpha_max=0.17):             # no wrap
        return bool(abs(a.r - b.r) < dr_max_m and abs(a.alpha - b.alpha) < dalpha_max)

    with pytest.raises(YourTurnError, match="angles wrap"):
        check(naive, cases.similar_lines(a, b), fallback=None, name="similar_lines")

    def no_parallel_test(r1, a1, r2, a2):
        det = math.cos(a1) * math.sin(a2) - math.sin(a1) * math.cos(a2)
        return np.array([r1 * math.sin(a2) - r2 * math.sin(a1), r2 * math.cos(a1) - r1 * math.cos(a2)]) / det

    with pytest.raises(YourTurnError, match="parallel"):
        check(no_parallel_test, cases.intersection(first, second, (2.0, 1.0)), fallback=None, name="intersection")


def _seg(indices, first, last):
    return SimpleNamespace(indices=np.array(indices), first=first, last=last)


def test_print_merges_counts_the_pieces_left_behind(capsys):
    naive = [_seg([0, 1], 0, 1), _seg([5, 6], 5, 6), _seg([358, 359], 358, 359)]
    wrapped = [_seg([358, 359, 0, 1], 358, 1), _seg([5, 6], 5, 6)]
    assert reports.print_merges([None] * 5, naive, wrapped) == 2          # [0, 1] and [358, 359] lie in the wall
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "5 lines before merging; naive angles: 3 after, wrapped: 2 after"
    assert out[-1] == ("with the naive difference the wall behind the robot stays in 2 pieces; wrapped, "
                       "it is one line across the seam: True")


def test_check_extrapolation_by_hand(capsys):
    lines = [SimpleNamespace(alpha=0.0), SimpleNamespace(alpha=math.pi / 2)]
    far = SimpleNamespace(point=np.array([3.0, 4.0]), lines=(0, 1), kind="concave", extrapolated=True)
    near = SimpleNamespace(point=np.array([1.0, 0.0]), lines=(0, 1), kind="convex", extrapolated=False)
    rule = {id(far): (0.15, 0.12, True, 0.12), id(near): (0.05, 0.1, False, 0.3)}
    reports.check_extrapolation([near, far], lines, lambda c: rule[id(c)])
    out = capsys.readouterr().out
    # the beam to (3, 4) is at 53.13 deg: 53 deg from the normal alpha = 0, 37 deg from alpha = 90 deg
    assert ("The farthest corner, concave at (3.00, 4.00) m, is 5.0 m away; the beams there meet one of its walls "
            "53 degrees from its normal. Its lines must be extended by 15.0 cm to meet, more than max_extension_m = "
            "10 cm; they end on neighbouring beams, 12.0 cm apart, so the allowance is 12.0 cm, and the corner is "
            "marked extrapolated.") in out
    near.extrapolated = True
    with pytest.raises(AssertionError, match="disagrees"):
        reports.check_extrapolation([near, far], lines, lambda c: rule[id(c)])


def test_parameter_sweeps_print_and_check_the_sentences(capsys):
    t = {0.01: (50, 0.8, 0.2), 0.05: (30, 0.9, 0.1), 0.5: (10, 0.5, 0.05)}
    m = {2: (60, 0.85, 0.3), 5: (30, 0.9, 0.1), 20: (20, 0.6, 0.05)}
    assert reports.print_parameter_sweeps(t, m) == 0.0                    # the fixed setting is the best
    out = capsys.readouterr().out
    assert "                0.01     50        80.0%        20.0%" in out
    assert "split threshold 0.01 m: 50 lines, 20 more than at 0.05 m; 0.5 m: 50.0% of the walls found" in out
    assert "min_points 2: 30.0% wrong lines against 10.0% at 5" in out
    t[0.5] = (10, 0.95, 0.05)
    with pytest.raises(AssertionError, match="split threshold"):
        reports.print_parameter_sweeps(t, m)


# ---------------------------------------------------------------------------- notebook 07
def _half_atan2(p0, p1, p2):
    q = np.array([p0, p1, p2]) - np.mean([p0, p1, p2], axis=0)
    return 0.5 * math.atan2(2 * np.sum(q[:, 0] * q[:, 1]), np.sum(q[:, 0] ** 2) - np.sum(q[:, 1] ** 2))


def test_the_notebook_07_cases_pass_labkits_answers_and_fail_wrong_ones(capsys):
    angles = np.radians(np.arange(-30.0, 30.5, 1.0))
    scan = labkit.Scan(ranges=2.0 / np.cos(angles), angles=angles)      # the wall x = 2: direction 90 deg
    phi = labkit.local_directions(scan)

    def by_tls(p0, p1, p2):      # an oracle: labkit's TLS line fit, its normal turned by 90 degrees
        return float(np.mod(labkit.fit_line_tls(np.array([p0, p1, p2])).alpha + np.pi / 2, np.pi))

    assert check(by_tls, cases.triplet_direction(scan, phi, 10), fallback=None) is by_tls
    points = np.c_[np.linspace(0, 4, 5), np.full(5, 1.5)]                # y = 1.5 at direction 0: offsets 1.5
    assert check(fallbacks.wall_offsets, cases.wall_offsets(points, 0.0, np.full(5, 1.5)), fallback=None)
    assert capsys.readouterr().out.count("well done") == 2
    with pytest.raises(YourTurnError, match="modulo pi"):               # atan2 halved, left in (-pi/2, pi/2]
        check(_half_atan2, cases.triplet_direction(scan, phi, 10), fallback=None)
    with pytest.raises(YourTurnError, match="across the line"):         # along the line, not across it
        check(lambda pts, d: pts @ np.array([math.cos(d), math.sin(d)]), cases.wall_offsets(points, 0.0, 1.5),
              fallback=None)


def test_majority_label_and_lines_on_by_hand():
    assert reports.majority_label(np.array([-1, -1, -1, 2, 2, 0])) == 2      # noise left out
    assert reports.majority_label(np.array([3, 1, 3, 1])) == 1               # a tie: the smaller
    with pytest.raises(ValueError, match="noise"):
        reports.majority_label(np.array([-1, -1]))
    mask = np.zeros(10, bool)
    mask[2:6] = True
    lines = [SimpleNamespace(indices=np.arange(0, 4)), SimpleNamespace(indices=np.arange(2, 9)),
             SimpleNamespace(indices=np.arange(1, 6))]       # 2 of 4 (a half is not over half), 4 of 7, 4 of 5
    assert reports.lines_on(lines, mask) == [lines[1], lines[2]]


def test_walls_found_and_the_extractor_table_by_hand(capsys):
    walls = [SimpleNamespace(r=2.0, alpha=0.0, n_beams=40), SimpleNamespace(r=1.0, alpha=math.pi, n_beams=30),
             SimpleNamespace(r=5.0, alpha=1.0, n_beams=5)]                       # seen by 5 beams: does not count
    lines = [SimpleNamespace(r=2.05, alpha=0.05), SimpleNamespace(r=1.0, alpha=-math.pi + 0.02),   # both found
             SimpleNamespace(r=5.0, alpha=1.0)]
    assert reports.walls_found(lines, walls) == 3 and reports.walls_found(lines[:1], walls) == 1
    assert reports.walls_found([SimpleNamespace(r=2.15, alpha=0.0)], walls) == 0      # 15 cm off
    rows = [reports.extractor_row("hall", 0, walls, lines, lines[:1], lines[1:]),
            reports.extractor_row("hall", 30, walls, lines, lines, [])]
    assert rows[0] == ("hall", 0, 2, 3, 2, 1, 1, 2, 1)
    assert reports.print_extractor_table(rows).tolist() == [4, 6, 4, 4, 3, 2, 1]
    assert capsys.readouterr().out.endswith("split_gap_m = 0.3 m: 4 lines instead of 6, 3 walls found instead of 4; "
                                            "it changes the lines of 1 of the 2 scans\n")


def test_eps_answers_read_the_three_settings(capsys):
    scan = SimpleNamespace(valid=np.array([True, True, True, True, False]))
    st = SimpleNamespace                                                    # only .labels is read
    base = ([SimpleNamespace(n_points=5)] * 3, st(labels=np.array([0, 0, 1, -1, -1])), "base")
    wide = ([SimpleNamespace(n_points=9)] * 2, st(labels=np.array([0, 0, 0, 0, -1])), "wide")
    narrow = ([], st(labels=np.array([-1, 0, -1, -1, -1])), "narrow")
    reports.print_eps_answers(scan, base, wide, narrow)
    out = capsys.readouterr().out.splitlines()
    assert out[:3] == ["base", "wide", "narrow"]
    assert out[3] == ("eps_dist 0.35 m instead of 0.03 m: 2 segments instead of 3: parallel pieces less than 0.35 m "
                      "apart, such as a recess and its wall, now share a segment")
    assert out[4] == ("eps_theta 1 deg instead of 3 deg: 25% of the valid beams in a segment instead of 75%: noisy "
                      "directions no longer chain")


# ---------------------------------------------------------------------------- notebook 08b
def _leg(x, y, n_beams=5, first=0, last=4):
    return SimpleNamespace(center=np.array([x, y]), n_beams=n_beams, first=first, last=last)


def test_score_legs_by_hand():
    scans = [SimpleNamespace(stamp_s=10.0, stamp_ns=1), SimpleNamespace(stamp_s=10.1, stamp_ns=2)]
    truth = {1: SimpleNamespace(legs=[_leg(1.0, 0.0), _leg(2.0, 0.0), _leg(3.0, 0.0, n_beams=2)]),   # 3rd: 2 beams
             2: SimpleNamespace(legs=[_leg(1.0, 1.0, first=7)])}                                      # 2nd: occluded
    detections = [[_leg(1.05, 0.0), _leg(3.0, 0.05), _leg(5.0, 5.0)],   # finds leg 1, and the 2-beam one; one wrong
                  [_leg(1.0, 1.0)]]                                     # finds the occluded leg
    score = reports.score_legs(scans, detections, truth, 0.10, is_occluded=lambda scan, first, last: first == 7)
    # detectable: the first two legs of scan 0 (scan 1's is occluded); found: the first
    assert score["recall"] == 0.5 and [hit for *_, hit in score["rows"]] == [True, False]
    assert score["rows"][0][0] == 0.0 and score["missed"][0][0] == 0 and list(score["missed"][0][1]) == [2.0, 0.0]
    # true positives: 3 of the 4 detections lie within 10 cm of some true leg, detectable or not
    assert (score["n_detected"], score["n_true_positive"], score["precision"]) == (4, 3, 0.75)


def test_the_notebook_08b_cases_pass_labkits_answer_and_fail_a_wrong_one(capsys):
    from labkit.circles.legs import pair_legs
    from labkit.features import Leg

    def leg(y):
        return Leg(center=np.array([1.0, y]), diameter=0.12, middle=np.array([0.95, y]), first=0, last=3, n_points=4,
                   iav_mean=2.0, iav_std=0.1)

    legs = [leg(0.0), leg(0.4)]
    assert len(pair_legs(legs)) == 1                                     # 0.4 m apart: one person
    two_legs = [legs, [leg(0.0), leg(1.0)]]                              # 1 m apart: none
    assert check(fallbacks.pair_two_legs, cases.pair_two_legs(two_legs), fallback=None) is fallbacks.pair_two_legs
    assert "passes all 7 checks" in capsys.readouterr().out
    with pytest.raises(YourTurnError, match="the limit is included"):   # strictly closer than the limit
        check(lambda a, b, max_distance_m=0.6: (np.add(a, b) / 2 if math.dist(a, b) < max_distance_m else None),
              cases.pair_two_legs(two_legs), fallback=None, name="pair_two_legs")


# ---------------------------------------------------------------------------- notebook 10
def test_the_notebook_10_cases_pass_labkits_answer_and_fail_a_wrong_one(capsys):
    assert check(fallbacks.normal_form_match, cases.normal_form_match(), fallback=None) is fallbacks.normal_form_match
    assert "passes all 6 checks" in capsys.readouterr().out
    with pytest.raises(YourTurnError, match="wrap the angle difference"):
        check(lambda lr, la, wr, wa, max_dr_m=0.05, max_dalpha=0.0524:
              abs(lr - wr) <= max_dr_m and abs(la - wa) <= max_dalpha, cases.normal_form_match(), fallback=None)


def test_print_data_set_by_hand(capsys):
    scan = SimpleNamespace(n_beams=361, angle_min=-math.pi / 2, angle_max=math.pi / 2, angle_increment=math.pi / 360)
    data = [SimpleNamespace(world=w, noise_std_m=n, scan=scan)
            for n, w in [(0.005, "office"), (0.005, "office"), (0.005, "corridor"), (0.02, "office")]]
    reports.print_data_set(data)
    assert capsys.readouterr().out.splitlines() == [
        "range noise    5 mm: 2 office, 1 corridor", "range noise   20 mm: 1 office",
        "every scan: 361 beams from -90 to 90 deg, one every 0.500 deg"]


def _match(pairs, scored, missed=(), dr=(), dalpha=()):
    return SimpleNamespace(pairs=list(pairs), scored=list(scored), missed=list(missed), dr=list(dr),
                           dalpha=list(dalpha))


def test_pick_example_prefers_all_kinds_and_a_miss(monkeypatch):
    import labkit.evaluation

    items = [SimpleNamespace(world=w, noise_std_m=n, scan=k, truth=None)
             for k, (w, n) in enumerate([("office", 0.005), ("corridor", 0.005), ("office", 0.005), ("office", 0.02),
                                         ("office", 0.005)])]
    # scan 0: every kind, no miss; 1: the corridor; 2: no unscored line; 3: another level; 4: every kind and a miss
    kinds = {0: _match([(0, 0)], [0, 1]), 1: _match([(0, 0)], [0, 1], [1]), 2: _match([(0, 0)], [0, 1, 2], [1]),
             3: _match([(0, 0)], [0, 1], [1]), 4: _match([(0, 0)], [0, 1], [1])}
    monkeypatch.setattr(labkit.evaluation, "match_lines", lambda lines, truth: kinds[lines[0]])
    assert reports.pick_example(items, 0.005, extract=lambda scan: [scan, scan, scan]) == 4
    kinds[4] = _match([(0, 0)], [0, 1])                                      # no miss anywhere: the first
    assert reports.pick_example(items, 0.005, extract=lambda scan: [scan, scan, scan]) == 0
    assert reports.pick_example(items, 0.05, extract=lambda scan: [scan, scan, scan]) == 0   # none at all


def test_print_match_by_hand(capsys):
    lines = [SimpleNamespace(first=0, last=20, length=1.5), SimpleNamespace(first=21, last=30, length=0.4)]
    reports.print_match(lines, _match([(0, 3)], [0, 1], missed=[5], dr=[0.0042], dalpha=[math.radians(-0.5)]))
    assert capsys.readouterr().out.splitlines() == [
        "line  0  beams   0.. 20   1.50 m  matched         wall  3: dr   +4.2 mm, dalpha -0.50 deg",
        "line  1  beams  21.. 30   0.40 m  false positive",
        "walls in the truth but missed: [5]"]


def test_round_object_notes_by_hand(capsys):
    truth = SimpleNamespace(circles=[SimpleNamespace(name="column", n_beams=9, center=(1.0, 2.0)),
                                     SimpleNamespace(name="bin", n_beams=3, center=(3.0, 0.0))],
                            legs=[SimpleNamespace(person="ann", n_beams=5, center=(2.0, -1.0))])
    circles = SimpleNamespace(truth=[0], pairs=[(0, 0)], center_errors=[0.012])
    legs = SimpleNamespace(truth=[0], pairs=[], center_errors=[])
    notes = reports.round_object_notes(truth, circles, legs)
    assert notes == [((1.0, 2.0), "column: found, centre 12 mm off"), ((3.0, 0.0), "bin: not in the truth (too few "
                     "beams)"), ((2.0, -1.0), "ann's leg: missed")]
    assert capsys.readouterr().out.splitlines()[0] == "true circle 0 (column, 9 beams): found, centre 12 mm off"


def _rows():
    return [{"noise_std_m": n, "method": m, "tp_rate": tp, "fp_rate": fp, "scans_per_s": sp, "truth": 50}
            for n, m, tp, fp, sp in [(0.005, "split-and-merge (IEPF)", 0.95, 0.10, 3000.0),
                                     (0.005, "RANSAC", 0.92, 0.05, 300.0), (0.005, "Hough", 0.80, 0.30, 100.0),
                                     (0.02, "split-and-merge (IEPF)", 0.85, 0.40, 2000.0),
                                     (0.02, "RANSAC", 0.80, 0.20, 250.0), (0.02, "Hough", 0.78, 0.25, 90.0)]]


def test_level_summaries_by_hand(capsys):
    sweep = [{"noise_std_m": n, "split_threshold_m": t, "tp_rate": tp, "fp_rate": fp}
             for n, t, tp, fp in [(0.005, 0.05, 0.9, 0.1), (0.005, 0.02, 0.95, 0.05), (0.02, 0.05, 0.8, 0.3),
                                  (0.02, 0.1, 0.85, 0.2)]]
    best = {0.005: sweep[1], 0.02: sweep[3]}
    reports.print_level_summaries(_rows(), sweep, best, 0.05, {"legs": {"precision": 0.9, "recall": 0.8,
                                                                        "center_err_median_m": 0.021}})
    out = capsys.readouterr().out.splitlines()
    assert out[:4] == ["range noise 5 mm (50 true walls, so one wall is 0.020 of TruePos):",
                       "  most walls found:   split-and-merge (IEPF) (TruePos 0.950, FalsePos 0.100)",
                       "  fewest wrong lines: RANSAC (FalsePos 0.050, TruePos 0.920)",
                       "  fastest:            split-and-merge (IEPF) (3,000 scans/s)"]
    # at 20 mm no method finds 90 % of the walls: no extra line
    assert out[7] == "  fastest:            split-and-merge (IEPF) (2,000 scans/s)"
    assert out[8] == ("split-and-merge at 5 mm: best threshold 2 cm (4.0 sigma), TruePos - FalsePos 0.900 against "
                      "0.800 at the papers' fixed 5 cm")
    assert out[-1] == "legs in the hall: precision 0.900, recall 0.800, median centre error 21 mm"


def test_speed_noise_and_ranking_by_hand(capsys):
    assert reports.print_speed_and_noise(_rows()) == ("RANSAC", "Hough")   # TruePos -0.12 and -0.02 (IEPF -0.10)
    published = {"split-and-merge (IEPF)": 0.10, "RANSAC": 0.30, "Hough": 0.30, "EM": 0.5}
    # the paper ranks IEPF < RANSAC and IEPF < Hough (RANSAC = Hough: no order); ours at 5 mm: 0.10, 0.05, 0.30
    # (IEPF < Hough only), at 20 mm: 0.40, 0.20, 0.25 (neither)
    assert reports.print_ranking_against_paper(_rows(), published) == {0.005: 1, 0.02: 0}
    out = capsys.readouterr().out
    assert "noise 5 mm: split-and-merge (IEPF) ran 10.0 times as many scans per second as RANSAC" in out
    assert "largest fall RANSAC (-0.120), best kept Hough (-0.020)" in out
    assert "we rank 1 the same way: no more than a random order would on average (1)" in out
    assert "pairs we rank the other way (paper: first < second): split-and-merge (IEPF) < RANSAC\n" in out
    assert "lowest FalsePos here: RANSAC (0.05; the paper's lowest is split-and-merge (IEPF)); " \
           "split-and-merge (IEPF) is 2 of 3" in out


# ---------------------------------------------------------------------------- notebook 03
def test_the_notebook_03_cases_pass_labkits_answers_and_fail_wrong_ones(capsys):
    theta = np.radians(np.arange(-45, 0.1, 3.0))
    rho = 1.5 / np.cos(theta - np.radians(-60))                       # the wall r = 1.5 m, alpha = -60 deg
    assert check(fallbacks.jacobian, cases.jacobian(rho, theta, 0.01), fallback=None) is fallbacks.jacobian
    assert check(fallbacks.ideal_weights, cases.ideal_weights(), fallback=None) is fallbacks.ideal_weights
    assert capsys.readouterr().out.count("well done") == 2

    def refit_with_default_weights(rho, theta, w, h=1e-6):           # ignores the weights it is given
        return fallbacks.jacobian(rho, theta, None, h)

    with pytest.raises(YourTurnError, match="use the weights w you are given"):
        check(refit_with_default_weights, cases.jacobian(rho, theta, 0.01), fallback=None, name="jacobian")
    with pytest.raises(YourTurnError, match="cos"):                   # 1 / sigma^2 alone
        check(lambda sigma, theta, alpha: 1 / np.broadcast_to(sigma, np.shape(theta)) ** 2, cases.ideal_weights(),
              fallback=None, name="ideal_weights")


def test_simulated_weights_match_the_closed_form():
    theta = np.radians([0.0, 60.0])                                   # cos 0 = 1, cos 60 = 1/2
    np.testing.assert_allclose(cases.simulated_weights(0.02, theta, 0.0), [1 / 0.02**2, 4 / 0.02**2], rtol=0.02)


def test_weighting_row_and_verdicts_by_hand(capsys):
    theta = np.radians(np.arange(10, 80.1, 5.0))
    rho = 1.0 / np.cos(theta - np.radians(30))
    sigma = np.full(rho.size, 0.02)
    samples = rho + sigma * np.random.default_rng(0).standard_normal((400, rho.size))
    sd, mc = reports.weighting_row("constant", "uniform", rho, theta, "uniform", sigma, np.radians(30), samples)
    C = labkit.fit_line_polar(rho, theta, "uniform", range_sigma=sigma).covariance
    np.testing.assert_allclose(sd, np.sqrt(np.diag(C)))
    np.testing.assert_allclose(mc, sd, rtol=0.12)                     # 400 draws: the spread within 12 %
    assert capsys.readouterr().out.startswith("constant                    uniform")
    labels = ["uniform", "1/rho", "inverse_variance", "ideal"]
    prop = {("m", "uniform"): (2.0, 1.0), ("m", "1/rho"): (3.0, 1.0), ("m", "inverse_variance"): (2.0, 1.0),
            ("m", "ideal"): (1.0, 0.5)}
    assert reports.print_weighting_verdicts(prop, prop, ["m"], labels) == ["m"]
    out = capsys.readouterr().out
    assert ("m: smallest sigma_r with ideal weights (1000.00 mm); uniform +100%, inverse_variance +100%, "
            "1/rho +200%") in out
    assert "against uniform weights, 1/rho hurts under m noise" in out
    prop["m", "uniform"] = (0.9, 1.0)                                 # beats the ideal weights: impossible
    with pytest.raises(AssertionError, match="beats the ideal"):
        reports.print_weighting_verdicts(prop, prop, ["m"], labels)


# ---------------------------------------------------------------------------- notebook 09b
def _features(lines, **timings):
    counts = {"segments": 3, "lines": lines, "corners": 1, "circles": 0, "legs": 2}
    return SimpleNamespace(counts=lambda: counts, lines=[None] * lines,
                           timings={"lines": 0.002, "corners": 0.001, "total": 0.004, **timings})


def test_the_notebook_09b_cases_by_hand(capsys):
    a = [_features(n) for n in (3, 2, 5, 4)]
    b = [_features(n) for n in (1, 2, 6, 4)]     # fewer than a in scan 0 only; more in scan 2
    got = cases.fewer_lines_share(a, b)
    assert [c.expected for c in got] == [0.25, 0.25, 0.0]
    assert check(fallbacks.fewer_lines_share, got, fallback=None) is fallbacks.fewer_lines_share
    assert "well done" in capsys.readouterr().out
    with pytest.raises(YourTurnError, match="strictly fewer"):                # "fewer or as many"
        check(lambda a, b: float(np.mean([len(y.lines) <= len(x.lines) for x, y in zip(a, b, strict=True)])), got,
              fallback=None, name="fewer_lines_share")
    with pytest.raises(ValueError, match="as many lines"):
        cases.fewer_lines_share(a[:1], b[:1])


def test_count_table_by_hand(capsys):
    reports.print_count_table({"iepf": [_features(4), _features(6)], "angular": [_features(3), _features(3)]},
                              kinds=("lines",), stages=("total",))
    assert capsys.readouterr().out.splitlines() == [
        "per scan (mean)             iepf   angular", "lines                       5.00      3.00",
        "ms total                   4.000     4.000"]


# ---------------------------------------------------------------------------- notebook 11
def test_the_notebook_11_cases_pass_labkits_answers_and_fail_wrong_ones(capsys):
    assert check(labkit.poses.compose, cases.compose_poses(), fallback=None) is labkit.poses.compose
    assert check(fallbacks.pose_at, cases.pose_at(), fallback=None) is fallbacks.pose_at
    assert capsys.readouterr().out.count("well done") == 2

    def added(a, b):                                                  # b's translation not rotated
        return (a[0] + b[0], a[1] + b[1], labkit.geometry.wrap_angle(a[2] + b[2]))

    with pytest.raises(YourTurnError, match="rotate b's translation"):
        check(added, cases.compose_poses(), fallback=None, name="compose_poses")

    def the_long_way(t0, p0, t1, p1, t):                              # theta interpolated without wrapping
        u = (t - t0) / (t1 - t0)
        return tuple(a + u * (b - a) for a, b in zip(p0, p1, strict=True))

    with pytest.raises(YourTurnError, match="short way round"):
        check(the_long_way, cases.pose_at(), fallback=None, name="pose_at")


# ---------------------------------------------------------------------------- notebook 09
def test_the_notebook_09_cases_pass_labkits_answer_and_fail_wrong_ones(capsys):
    config = labkit.Config()
    got = cases.config_for(config)
    assert got[0].expected.lines.split_threshold_m == 0.03 and got[0].expected.lines.method == "split_and_merge"
    assert check(fallbacks.config_for, got, fallback=None) is fallbacks.config_for
    assert "well done" in capsys.readouterr().out
    with pytest.raises(YourTurnError, match="wants metres"):             # centimetres left as they are
        check(lambda method, cm: labkit.Config().updated({"lines.method": method, "lines.split_threshold_m": cm}),
              got, fallback=None, name="config_for")


def test_recording_summary_by_hand(capsys):
    def scan(k, valid):
        return SimpleNamespace(stamp_ns=k * 200_000_000, n_beams=4, angle_increment=math.radians(1.0), range_max=8.0,
                               valid=np.array(valid))

    scans = [scan(0, [1, 1, 1, 1]), scan(1, [1, 1, 0, 1]), scan(5, [0, 0, 1, 1])]   # 1 s, 3 scans
    feats = [SimpleNamespace(counts=lambda n=n: {"lines": n}) for n in (1, 2, 6)]
    assert reports.print_recording_summary(scans, feats, kinds=["lines"]) == {"lines": 3.0}
    assert capsys.readouterr().out.splitlines() == [
        "4 beams, one every 1.00 deg, range_max 8.00 m", "3 scans over 1 s (3.00 scans per second)",
        "invalid beams: 25.0% on average", "features per scan: lines 3.00"]


# ---------------------------------------------------------------------------- notebook 02
def test_the_notebook_02_cases_pass_labkits_answer_and_fail_a_wrong_one(capsys):
    theta = np.radians(np.arange(-45, 0.1, 1.0))
    rho = 1.5 / np.cos(theta - np.radians(-60)) + np.random.default_rng(0).normal(0, 0.01, theta.size)
    got = cases.closed_form_alpha(rho, theta, 1.5, np.radians(-60))
    assert check(fallbacks.closed_form_alpha, got, fallback=None) is fallbacks.closed_form_alpha
    assert "well done" in capsys.readouterr().out

    def with_atan(rho, theta, w):                                        # atan of the ratio: loses the quadrant
        x, y = rho * np.cos(theta), rho * np.sin(theta)
        xm, ym = np.average(x, weights=w), np.average(y, weights=w)
        suu, svv = np.sum(w * (x - xm) ** 2), np.sum(w * (y - ym) ** 2)
        return float(np.arctan(2 * np.sum(w * (x - xm) * (y - ym)) / (suu - svv)) / 2 + np.pi / 2)

    with pytest.raises(YourTurnError, match="atan loses the quadrant"):
        check(with_atan, got, fallback=None, name="closed_form_alpha")


# ---------------------------------------------------------------------------- notebook 04
def test_the_notebook_04_cases_pass_labkits_answers_and_fail_wrong_ones(capsys):
    assert check(fallbacks.chord_distances, cases.chord_distances(), fallback=None) is fallbacks.chord_distances
    scan, _ = next(iter(labkit.sim.simulate("random_polygons_4", seed=0, n_scans=1)))
    segment = labkit.range_segments(scan, threshold_m=0.08, min_points=5, adaptive=True, range_sigma_m=0.01)[0].points
    assert check(labkit.lines.iepf, cases.iepf(segment), fallback=None) is labkit.lines.iepf
    assert capsys.readouterr().out.count("well done") == 2

    def unsigned_cross(points):                                       # the cross product, not divided by |b - a|
        a, b = points[0], points[-1]
        return np.abs((b[0] - a[0]) * (points[:, 1] - a[1]) - (b[1] - a[1]) * (points[:, 0] - a[0]))

    with pytest.raises(YourTurnError, match="chord's length"):
        check(unsigned_cross, cases.chord_distances(), fallback=None, name="chord_distances")
    with pytest.raises(YourTurnError, match="fewer than min_points"):  # every run is one line
        check(lambda points, threshold_m=0.05, min_points=5: [(0, len(points))], cases.iepf(segment),
              fallback=None, name="iepf")


# ---------------------------------------------------------------------------- notebooks 06 and 01
def test_the_notebook_06_cases_pass_labkits_answers_and_fail_wrong_ones(capsys):
    x = np.array([0.0, 0.4, 0.7, 0.9, 1.2, 1.6, 2.5, 3.9, 4.2, 4.4, 4.5, 4.8, 5.3, 6.9])
    near = np.abs(x[:, None] - x[None, :]) <= 0.5
    L, U = fallbacks.bounds_from_table(near)
    core = near.sum(axis=1) >= 4                                       # brute force, as the notebook does
    border = ~core & (near & core[None, :]).any(axis=1)
    assert check(fallbacks.is_core, cases.is_core(L, U, 4, core), fallback=None) is fallbacks.is_core
    assert check(fallbacks.is_border, cases.is_border(L, U, core, border), fallback=None) is fallbacks.is_border
    assert capsys.readouterr().out.count("well done") == 2
    with pytest.raises(YourTurnError, match="the point itself included"):   # U - L, one short
        check(lambda L, U, min_pts: (np.asarray(U) - np.asarray(L)) >= min_pts, cases.is_core(L, U, 4, core),
              fallback=None, name="is_core")


def test_the_notebook_01_cases_pass_labkits_answers_and_fail_wrong_ones(capsys):
    scan, _ = next(iter(labkit.sim.simulate("corridor", seed=0, n_scans=1)))
    assert check(fallbacks.cut_points, cases.cut_points(scan), fallback=None) is fallbacks.cut_points
    thresholds = labkit.breakpoint_thresholds
    assert check(thresholds, cases.adaptive_threshold(), fallback=None) is thresholds
    assert capsys.readouterr().out.count("well done") == 2
    # the triangle by hand at 10 m, 0.5 deg beams, 10 deg incidence: the law of sines gives
    # 10 sin(0.5 deg) / sin(9.5 deg) = 0.5288 m, + 3 cm
    assert cases.adaptive_threshold()[0].expected[2] == pytest.approx(10 * math.sin(math.radians(0.5))
                                                                      / math.sin(math.radians(9.5)) + 0.03)

    def gaps_only(scan, threshold_m=0.08):                              # NaN gaps never cut
        gaps = np.hypot(*np.diff(scan.points, axis=0).T)
        return np.nan_to_num(gaps, nan=0.0) >= threshold_m

    with pytest.raises(YourTurnError, match="next to every invalid beam"):
        check(gaps_only, cases.cut_points(scan), fallback=None, name="cut_points")


def test_beam_reasons_by_hand(capsys):
    scan = SimpleNamespace(angles=np.radians([-10.0, 0.0, 10.0]), ranges=np.array([1.0, np.nan, 0.02]))
    reports.print_beam_reasons(scan, ["", "NaN: no measurement", "below range_min"])
    assert capsys.readouterr().out.splitlines() == [
        "beam 0:   -10 deg  r =   1.0  valid",
        "beam 1:     0 deg  r =   nan  invalid, NaN: no measurement",
        "beam 2:    10 deg  r =  0.02  invalid, below range_min"]


def test_print_seam_finds_the_invalid_beams_before_the_seam(capsys):
    ranges = np.array([1.0, 1.0, 1.0, 1.0, np.nan, 1.0, np.inf, 1.0])  # beams 4 and 6 dropped out
    scan = labkit.Scan(ranges=ranges, angles=np.radians(np.arange(-180, 180, 45)), range_min=0.05, range_max=8.0)
    assert reports.print_seam(scan, SimpleNamespace(last=3), SimpleNamespace(last=1)) == [4, 6]
    out = capsys.readouterr().out.splitlines()
    assert out[1] == "beam 0 is at -180 deg, beam 7 at 135 deg: neighbours across the seam"
    assert out[-1] == "invalid beams between them: [4, 6] at ['+0 deg', '+90 deg']"
    assert out[0].endswith("| full circle: True")                 # 8 beams, 45 degrees apart
    assert out[2:4] == ["last line:  namespace(last=3)", "first line: namespace(last=1)"]


def test_shared_datasets_reads_the_environment_first(monkeypatch):
    monkeypatch.setenv("LABKIT_SHARED_DATASETS", "/data/recordings")
    assert reports.shared_datasets() == Path("/data/recordings")
    monkeypatch.delenv("LABKIT_SHARED_DATASETS")
    assert reports.shared_datasets() == Path("../../shared/datasets")   # notebooks/ -> the repository's sibling
