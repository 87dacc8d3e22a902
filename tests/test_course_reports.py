"""The course notebooks' check cases (labkit.course_cases) and bookkeeping (labkit.course_reports): checked
against values worked out by hand."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

import labkit
from labkit import course_cases as cases
from labkit import course_fallbacks as fallbacks
from labkit import course_reports as reports
from labkit.course import YourTurnError, check


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
    from labkit.noise import FIXED_LINES

    bag = labkit.bundled_data("hall.bag")
    row = reports.fixed_and_auto_on_log(bag, 3)
    scans = list(labkit.read_scans(bag))[:3]
    fixed = reports.pooled_ray_errors(scans, [labkit.split_and_merge(s, **FIXED_LINES) for s in scans])
    auto = reports.pooled_ray_errors(scans, [labkit.split_and_merge(s) for s in scans])
    assert math.isclose(row["rmse_fixed"], fixed.rmse) and math.isclose(row["cov_fixed"], fixed.coverage)
    assert math.isclose(row["rmse_auto"], auto.rmse) and math.isclose(row["cov_auto"], auto.coverage)
    assert row["log"] == "hall.bag" and row["step"] == f"{math.degrees(scans[0].angle_increment):.2f}"
    assert set(row) == set(reports.FIXED_AND_AUTO_COLUMNS)

