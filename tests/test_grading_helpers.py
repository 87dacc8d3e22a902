"""The hidden tests' helpers in ``labkit.grading``: random inputs (:mod:`labkit.grading.inputs`) and the
comparisons that say what is wrong (:mod:`labkit.grading.checks`)."""

from __future__ import annotations

import numpy as np
import pytest

import labkit
from labkit.grading import (
    Moved,
    assert_beams_result,
    assert_labels_result,
    assert_line_result,
    random_beams,
    random_wall_beams,
)


def test_random_beams_is_reproducible_and_accepted_by_scan():
    first = random_beams(np.random.default_rng(42))
    second = random_beams(np.random.default_rng(42))
    assert first["ranges"].tobytes() == second["ranges"].tobytes()
    assert first["angles"].tobytes() == second["angles"].tobytes()
    assert (first["range_min"], first["range_max"]) == (second["range_min"], second["range_max"])
    rng = np.random.default_rng(1)
    for n_beams in [0, 1, 2, 3, None, None, None, None]:
        beams = random_beams(rng, n_beams)
        scan = labkit.Scan(**beams)  # angles strictly increasing, span <= 2 pi, limits ordered
        if n_beams is None:
            assert 2 <= scan.n_beams <= 720
        else:
            assert scan.n_beams == n_beams


def test_random_beams_injects_every_kind_of_invalid_reading():
    rng = np.random.default_rng(3)
    seen = dict.fromkeys(["nan", "inf", "-inf", "zero", "negative", "at_max", "beyond_max", "below_min",
                          "at_min_valid"], 0)
    for _ in range(40):
        beams = random_beams(rng, 200, invalid_fraction=0.5)
        r, lo, hi = beams["ranges"], beams["range_min"], beams["range_max"]
        with np.errstate(invalid="ignore"):
            seen["nan"] += int(np.isnan(r).sum())
            seen["inf"] += int(np.isposinf(r).sum())
            seen["-inf"] += int(np.isneginf(r).sum())
            seen["zero"] += int((r == 0).sum())
            seen["negative"] += int((np.isfinite(r) & (r < 0)).sum())
            seen["at_max"] += int((r == hi).sum())
            seen["beyond_max"] += int((np.isfinite(r) & (r > hi)).sum())
            seen["below_min"] += int(((r > 0) & (r < lo)).sum())
            seen["at_min_valid"] += int(((r == lo) & (lo > 0)).sum())
    assert all(count > 0 for count in seen.values()), seen


def test_random_beams_invalid_fraction_extremes():
    rng = np.random.default_rng(5)
    for _ in range(10):
        assert labkit.Scan(**random_beams(rng, 50, invalid_fraction=0.0)).valid.all()
        assert not labkit.Scan(**random_beams(rng, 50, invalid_fraction=1.0)).valid.any()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_beams": -1}, "n_beams"),
        ({"n_beams": 2.5}, "n_beams"),
        ({"invalid_fraction": 1.5}, "invalid_fraction"),
        ({"max_beams": 1}, "max_beams"),
    ],
)
def test_random_beams_rejects_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        random_beams(np.random.default_rng(0), **kwargs)
    with pytest.raises(ValueError, match="rng"):
        random_beams(0)


@pytest.mark.parametrize(
    ("result", "match"),
    [
        ([np.zeros((1, 2)), np.array([0])], "tuple"),
        ((np.zeros((1, 2)),), "tuple"),
        (([[1.0, 0.0]], np.array([0])), "points must be a numpy array"),
        ((np.zeros((1, 3)), np.array([0])), r"shape \(1, 2\)"),
        ((np.array([[1, 0]]), np.array([0])), "float64"),
        ((np.array([[1.0, 0.0]]), np.array([0.0])), "integers"),
        ((np.array([[1.0, 0.0]]), np.array([1])), "position 0 should be beam 0"),
        ((np.array([[1.0, 1e-6]]), np.array([0])), "row 0"),
    ],
)
def test_assert_beams_result_says_what_is_wrong(result, match):
    assert_beams_result((np.array([[1.0, 0.0]]), np.array([0])), [[1.0, 0.0]], [0])
    with pytest.raises(AssertionError, match=match):
        assert_beams_result(result, [[1.0, 0.0]], [0])


def test_random_wall_beams_is_reproducible_partial_and_accepted_by_scan():
    first = random_wall_beams(np.random.default_rng(42))
    second = random_wall_beams(np.random.default_rng(42))
    assert first["ranges"].tobytes() == second["ranges"].tobytes()
    assert first["angles"].tobytes() == second["angles"].tobytes()
    rng = np.random.default_rng(1)
    for n_beams in [0, 1, 2, 3, 4, 5, *[None] * 200]:
        beams = random_wall_beams(rng, n_beams)
        scan = labkit.Scan(**beams)  # angles strictly increasing, span <= 2 pi
        assert not scan.is_full_circle  # first and last beams are never neighbours
        if n_beams is None:
            assert 2 <= scan.n_beams <= 720
        else:
            assert scan.n_beams == n_beams


def test_random_wall_beams_has_walls_clutter_and_every_invalid_reading():
    rng = np.random.default_rng(3)
    seen = dict.fromkeys(["nan", "inf", "-inf", "zero", "negative"], 0)
    longest, n_segments = [], []
    for _ in range(100):
        beams = random_wall_beams(rng, 500)
        r = beams["ranges"]
        seen["nan"] += int(np.isnan(r).sum())
        seen["inf"] += int(np.isposinf(r).sum())
        seen["-inf"] += int(np.isneginf(r).sum())
        seen["zero"] += int((r == 0).sum())
        seen["negative"] += int((np.isfinite(r) & (r < 0)).sum())
        labels = labkit.segment_labels(labkit.Scan(**beams), threshold_m=0.1, min_points=1)
        sizes = np.bincount(labels[labels >= 0])
        longest.append(sizes.max(initial=0))
        n_segments.append(sizes.size)
    assert all(count > 0 for count in seen.values()), seen
    assert np.median(longest) >= 20, "walls should give long runs of neighbouring points"
    assert np.median(n_segments) >= 5, "jumps, clutter and invalid readings should cut the scan"
    for _ in range(10):
        assert not labkit.Scan(**random_wall_beams(rng, 50, invalid_fraction=1.0)).valid.any()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"n_beams": -1}, "n_beams"), ({"invalid_fraction": -0.1}, "invalid_fraction"), ({"max_beams": 1}, "max_beams")],
)
def test_random_wall_beams_rejects_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        random_wall_beams(np.random.default_rng(0), **kwargs)
    with pytest.raises(ValueError, match="rng"):
        random_wall_beams(np.random.default_rng)


@pytest.mark.parametrize(
    ("result", "match"),
    [
        ([0, 0, -1], "numpy array"),
        (np.array([0, 0]), r"shape \(3,\)"),
        (np.array([0.0, 0.0, -1.0]), "integers"),
        (np.array([0, 1, -1]), r"beam 1 should be 0, got 1"),
    ],
)
def test_assert_labels_result_says_what_is_wrong(result, match):
    assert_labels_result(np.array([0, 0, -1], dtype=np.int32), [0, 0, -1])
    with pytest.raises(AssertionError, match=match):
        assert_labels_result(result, [0, 0, -1])


def test_assert_labels_result_shows_the_neighbourhood_of_a_long_scan():
    expected = np.zeros(100, dtype=int)
    wrong = expected.copy()
    wrong[50] = 3
    with pytest.raises(AssertionError, match=r"beam 50 should be 0, got 3 \(expected around beams 47..53"):
        assert_labels_result(wrong, expected)


@pytest.mark.parametrize(
    ("result", "match"),
    [
        ([2.0, 0.0], "tuple"),
        ((2.0,), "tuple"),
        ((np.array([2.0]), 0.0), "r must be a number"),
        ((2.0, True), "alpha must be a number"),
        ((np.nan, 0.0), "finite"),
        ((-2.0, np.pi), "r must be >= 0"),
        ((2.0, -np.pi), r"alpha must be in \(-pi, pi\]"),
        ((2.0, 3 * np.pi / 2), r"alpha must be in \(-pi, pi\]"),
        ((2.1, 0.0), "r is wrong"),
        ((2.0, 0.01), "alpha is wrong"),
    ],
)
def test_assert_line_result_says_what_is_wrong(result, match):
    assert_line_result((2.0, np.float64(1e-9)), 2.0, 0.0)
    assert_line_result((1.0, np.pi), 1.0, -np.pi + 1e-9)  # close across the wrap
    with pytest.raises(AssertionError, match=match):
        assert_line_result(result, 2.0, 0.0)


@pytest.mark.parametrize("seed", range(20))
def test_moved_keeps_distances_in_scale_and_lines_through_their_points(seed):
    """Closed-form checks of the similarity: distances scale by ``scale``, the angle between two
    directions stays, and points of a line land on the moved line (r >= 0, alpha in (-pi, pi])."""
    rng = np.random.default_rng(seed)
    moved = Moved(rng)
    assert moved.scale in (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
    a, b = rng.uniform(-3, 3, (2, 2))
    (a2, b2) = moved.points([a, b])
    assert np.isclose(np.linalg.norm(a2 - b2), moved.scale * np.linalg.norm(a - b))
    r, alpha = float(rng.uniform(0, 4)), float(rng.uniform(-np.pi, np.pi))
    normal, along = np.array([np.cos(alpha), np.sin(alpha)]), np.array([-np.sin(alpha), np.cos(alpha)])
    on_line = r * normal + rng.uniform(-5, 5, (6, 1)) * along
    r2, alpha2 = moved.line(r, alpha)
    assert r2 >= 0 and -np.pi < alpha2 <= np.pi
    np.testing.assert_allclose(moved.points(on_line) @ [np.cos(alpha2), np.sin(alpha2)], r2, atol=1e-9)
    bearing = float(moved.bearing(alpha))
    assert -np.pi < bearing <= np.pi and np.isclose(np.cos(bearing - alpha), np.cos(moved.angle))
    assert not Moved(np.random.default_rng(seed), shift=False).shift.any()
