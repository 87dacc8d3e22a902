"""The evaluation experiments: the simulated set, the comparison runner, the CLI."""

from __future__ import annotations

import json
import math
from functools import partial

import numpy as np
import pytest

from labkit import split_and_merge
from labkit.app import experiments as ex
from labkit.app.cli import main
from labkit.app.data import bundled_data
from labkit.geometry import angle_difference
from labkit.noise import AUTO_LINES


@pytest.fixture(scope="module")
def small_set():
    return ex.nguyen_set(6, noise_levels=(0.005, 0.02))


def test_nguyen_set_has_thirds_of_each_world_at_every_noise_level(small_set):
    assert len(small_set) == 12
    assert [s.world for s in small_set[:6]] == ["office"] * 2 + ["corridor"] * 2 + ["random_polygons"] * 2
    assert {s.noise_std_m for s in small_set} == {0.005, 0.02}
    assert all(s.scan.n_beams == 722 for s in small_set)
    assert small_set[0].scan.angles[-1] - small_set[0].scan.angles[0] == pytest.approx(math.pi)
    # the same poses and worlds at both noise levels: the same walls in the truth
    for a, b in zip(small_set[:6], small_set[6:], strict=False):
        assert [w.wall_id for w in a.truth.walls] == [w.wall_id for w in b.truth.walls]
        assert not np.array_equal(a.scan.ranges, b.scan.ranges)


def test_nguyen_set_is_deterministic_and_checks_its_size():
    a, b = ex.nguyen_set(3, noise_levels=(0.01,)), ex.nguyen_set(3, noise_levels=(0.01,))
    assert all(np.array_equal(x.scan.ranges, y.scan.ranges, equal_nan=True) for x, y in zip(a, b, strict=False))
    with pytest.raises(ValueError, match="n_scans"):
        ex.nguyen_set(2)


def test_an_extractor_that_returns_the_truth_scores_perfectly(small_set):
    """An oracle that hands back the visible walls hit by two beams or more (a line needs two
    points; a one-beam glimpse has no length): every wall in the truth is found, no line is
    false, and the errors are zero; an extractor that finds nothing finds nothing."""
    truth_of = {id(s.scan): s.truth for s in small_set}
    rows = ex.compare_lines(small_set, {"oracle": lambda scan: [w for w in truth_of[id(scan)].walls if w.n_beams > 1],
                                        "nothing": lambda scan: []})
    assert [(r["noise_std_m"], r["method"]) for r in rows] == [
        (0.005, "oracle"), (0.005, "nothing"), (0.02, "oracle"), (0.02, "nothing")]
    oracle, nothing = rows[0], rows[1]
    assert oracle["truth"] > 20 and oracle["tp_rate"] == 1.0 and oracle["fp_rate"] == 0.0
    assert oracle["sigma_dr_m"] == 0.0
    assert nothing["tp_rate"] == 0.0 and math.isnan(nothing["fp_rate"]) and nothing["lines_per_scan"] == 0


def test_truth_lines_are_the_walls_fitted_to_their_own_beams():
    """Nearly noise-free (0.1 um), each line lies on its wall (the simulator's closed-form
    geometry), is fitted to beams that all hit that wall, and one comes for every wall seen by
    two beams or more; the matching rule then finds every wall in the truth and no false line."""
    data = ex.nguyen_set(3, noise_levels=(1e-7,))
    for item in data:
        hits = item.truth.hits
        seen = [(w, np.flatnonzero(hits[w.first:w.last + 1] == w.wall_id) + w.first) for w in item.truth.walls]
        seen = [(w, beams) for w, beams in seen if len(beams) >= 2]  # (a wall's visible pieces come one by one)
        lines = ex.truth_lines(item)
        assert len(lines) == len(seen) > 3
        for line, (wall, beams) in zip(lines, seen, strict=True):
            assert abs(line.r - wall.r) < 1e-4 and abs(float(angle_difference(line.alpha, wall.alpha))) < 1e-4
            assert line.indices.tolist() == beams.tolist()
    (row,) = ex.compare_lines(data, {"own beams": lambda scan: ex.truth_lines(next(d for d in data if d.scan is scan))})
    assert row["tp_rate"] == 1.0 and row["fp_rate"] == 0.0


def test_truth_lines_keep_what_the_data_can_place(small_set):
    """With a confidence, the lines kept are those of every wall whose covariance places them
    within 5 cm and 3 deg with that probability (checked here with the placement integral's
    closed form for a diagonal covariance, on lines re-fitted to the same beams)."""
    from labkit.fitting import placement_probability

    item = next(s for s in small_set if s.noise_std_m == 0.02)
    every = ex.truth_lines(item)
    kept = ex.truth_lines(item, place_confidence=0.8)
    p = [placement_probability(line.covariance, 0.05, math.radians(3.0)) for line in every]
    assert [line.first for line in kept] == [line.first for line, q in zip(every, p, strict=True) if q >= 0.8]
    assert 0 < len(kept) < len(every)  # some walls of this scan are too short or too far to place at 2 cm
    # the integral on a diagonal covariance is a product of two normal probabilities
    cov = np.diag([0.03 ** 2, math.radians(2.0) ** 2])
    assert placement_probability(cov, 0.05, math.radians(3.0)) == pytest.approx(
        math.erf(0.05 / 0.03 / math.sqrt(2)) * math.erf(1.5 / math.sqrt(2)), rel=1e-6)


def test_placement_frontier_has_both_methods_at_every_confidence(small_set):
    rows = ex.placement_frontier(small_set, (0.0, 0.8))
    assert {(r["noise_std_m"], r["method"], r["place_confidence"]) for r in rows} == {
        (n, m, c) for n in (0.005, 0.02) for m in ("walls' own beams", "extractor") for c in (0.0, 0.8)}
    own = {(r["noise_std_m"], r["place_confidence"]): r for r in rows if r["method"] == "walls' own beams"}
    for n in (0.005, 0.02):  # fewer lines, never more walls found (one line per wall: a subset)
        assert own[n, 0.8]["tp_rate"] <= own[n, 0.0]["tp_rate"]
        assert own[n, 0.8]["lines_per_scan"] < own[n, 0.0]["lines_per_scan"]
    # the extractor placed afterwards scores as split-and-merge run with that confidence itself
    direct = ex.compare_lines(small_set, {"AUTO_LINES": partial(split_and_merge, **AUTO_LINES),
                                          "AUTO_LINES, every line": partial(split_and_merge,
                                                                            **{**AUTO_LINES, "place_confidence": 0})})
    placed = {(r["noise_std_m"], r["place_confidence"]): r for r in rows if r["method"] == "extractor"}
    for r in direct:
        c = 0.0 if r["method"].endswith("every line") else AUTO_LINES["place_confidence"]
        got = placed[r["noise_std_m"], c]
        assert (got["tp_rate"], got["fp_rate"], got["lines_per_scan"]) == (r["tp_rate"], r["fp_rate"],
                                                                         r["lines_per_scan"])


def test_every_extractor_runs_and_the_sweep_has_a_row_per_threshold(small_set):
    rows = ex.compare_lines(small_set[:3])
    assert [r["method"] for r in rows] == list(ex.LINE_EXTRACTORS)
    assert all(0 <= r["tp_rate"] <= 1 and r["scans_per_s"] > 0 for r in rows)
    sweep = ex.sweep_split_and_merge(small_set[:3], thresholds=(0.02, 0.05))
    assert [r["split_threshold_m"] for r in sweep] == [0.02, 0.05]


def test_markdown_table_formats_and_marks_missing_values():
    rows = [{"a": "x", "b": 0.01234, "c": math.nan}]
    table = ex.markdown_table(rows, {"a": "name", "b": "dr (mm):", "c": "rate:.3f"})
    assert table.splitlines() == ["| name | dr (mm) | rate |", "|---|---|---|", "| x | 12.3 | — |"]


def test_cli_evaluate_simulated_with_json(tmp_path, capsys):
    out = tmp_path / "eval.json"
    assert main(["evaluate", "-q", "--scans", "3", "--noise", "0.01", "--method", "split-and-merge (IEPF)",
                 "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "| 0.01 | split-and-merge (IEPF) |" in text
    report = json.loads(out.read_text())
    assert report["lines"][0]["scans"] == 3 and "round_objects" not in report
    assert main(["evaluate", "-q", "--scans", "3", "--method", "Hough", "--json", str(out)]) == 2  # exists
    assert "pass -f" in capsys.readouterr().err


def test_cli_evaluate_recordings(capsys):
    assert main(["evaluate", "-q", str(bundled_data("hall.bag")), "--scans", "5", "--method", "incremental"]) == 0
    text = capsys.readouterr().out
    assert "Ray-axis RMSE" in text and "| incremental |" in text


def test_cli_evaluate_names_an_unknown_method(capsys):
    assert main(["evaluate", "-q", "--scans", "3", "--method", "magic"]) == 2
    assert "magic" in capsys.readouterr().err


def test_false_positive_reasons_account_for_every_false_positive(small_set):
    from labkit import split_and_merge
    from labkit.evaluation import match_lines

    noisy = [s for s in small_set if s.noise_std_m == 0.02]
    # the fixed defaults before "auto", which leave false lines to explain
    old = {"split_threshold_m": 0.05, "range_sigma_m": 0.01, "place_confidence": 0.0}
    n_fp = sum(len(match_lines(split_and_merge(s.scan, **old), s.truth).false_positives) for s in noisy)
    rows = ex.false_positive_reasons(small_set, 0.02, **old)
    assert n_fp > 0 and sum(r["lines"] for r in rows) == n_fp
    assert {r["reason"] for r in rows} <= {"dr", "dalpha", "dr and dalpha", "overlap or a second line on the wall",
                                          "not on a wall"}
