"""Leg detection and pairing against the simulator's walking people."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit import Scan, sim
from labkit.circles.legs import detect_legs, is_occluded, pair_legs
from labkit.features import Leg, Person
from labkit.iav import inscribed_angles, middle_point_offset
from labkit.segmentation import RangeSegment, range_segments

LMS200 = sim.LIDARS["lms200"]


def _truly_occluded(scan, truth, leg) -> bool:
    """The occlusion rule applied to the ground truth: a beam next to the leg's run hits
    something in front of the leg's end beside it."""
    for nb, end in ((leg.first - 1, leg.first), (leg.last + 1, leg.last)):
        if 0 <= nb < scan.n_beams and truth.hits[nb] >= 0 and scan.ranges[nb] < scan.ranges[end]:
            return True
    return False


@pytest.fixture(scope="module")
def hall():
    """30 s of the hall scenario (seed 0): the static LMS200 and the walking student."""
    return list(sim.simulate("hall", 0, n_scans=300))


def _score(data, **kwargs):
    """Precision and recall of detect_legs on the hall's walking student.

    A detection is true when its centre is within 0.1 m of a true leg's. Recall counts
    the legs seen by at least 3 beams and not occluded (by the rule above).
    """
    tp = fp = seen = found = 0
    center_errors = []
    for scan, truth in data:
        legs = detect_legs(scan, **kwargs)
        centers = np.array([g.center for g in truth.legs]).reshape(-1, 2)
        matched = set()
        for leg in legs:
            d = np.hypot(*(centers - leg.center).T)
            if d.size and d.min() < 0.1:
                tp += 1
                matched.add(int(d.argmin()))
                center_errors.append(float(d.min()))
            else:
                fp += 1
        for k, g in enumerate(truth.legs):
            if g.n_beams >= 3 and not _truly_occluded(scan, truth, g):
                seen += 1
                found += k in matched
    return tp / (tp + fp), found / seen, np.array(center_errors), seen


def test_walking_student_in_the_hall(hall):
    """300 scans (30 s) of the hall: LMS200 at 0.5 deg with 5 mm noise, the student walking
    2-6 m away. Measured (seed 0, default adaptive segmentation): precision 1.0, recall 0.943
    (0.994 and 0.930 with the fixed 0.08 m segmentation); with the fixed one seeds 1-3 gave
    0.978-0.986 and 0.904-0.924. Centre error: median 1.4 cm, largest 4.1 cm. Asserted:
    precision >= 0.95, recall >= 0.85, median < 2.5 cm, largest < 6 cm."""
    precision, recall, errors, seen = _score(hall)
    assert seen > 400
    assert precision >= 0.95
    assert recall >= 0.85
    assert np.median(errors) < 0.025 and errors.max() < 0.06


def test_the_papers_literal_chord_test_misses_far_legs(hall):
    """Without chord padding (the paper's literal test) the chord of a leg seen by 3-4
    beams falls below 0.1 m. Measured (seed 0, the default adaptive segmentation): precision
    1.0, recall 0.654 against 1.0 and 0.943 (with the paper's fixed 0.08 m segmentation:
    precision 0.825, recall 0.641 against 0.994 and 0.930). Asserted: recall at least 0.15
    lower, precision not higher."""
    precision, recall, _, _ = _score(hall, chord_padding_beams=0.0)
    padded_precision, padded_recall, _, _ = _score(hall)
    assert recall <= padded_recall - 0.15
    assert precision <= padded_precision


def test_people_are_paired_legs_of_one_person(hall):
    """Every person reported in the hall is the student (midpoint within 0.15 m of the
    midpoint of the true legs), and whenever both legs are detected they are paired.
    Measured: 209 people in 300 scans, all true; 209 of 209 scans with both legs found."""
    people_total = people_true = both = paired = 0
    for scan, truth in hall:
        legs = detect_legs(scan)
        people = pair_legs(legs)
        if len(truth.legs) == 2:
            true_mid = np.mean([g.center for g in truth.legs], axis=0)
            people_true += sum(np.hypot(*(p.center - true_mid)) < 0.15 for p in people)
            centers = np.array([g.center for g in truth.legs])
            hit = {int(np.argmin(np.hypot(*(centers - g.center).T))) for g in legs
                   if np.min(np.hypot(*(centers - g.center).T)) < 0.1}
            if hit == {0, 1}:
                both += 1
                paired += len(people) >= 1
        people_total += len(people)
    assert people_total > 150
    assert people_true >= 0.95 * people_total
    assert paired >= 0.98 * both


def _reference_legs(scan, pad=1.0):
    """detect_legs as a plain loop over range_segments and the public functions."""
    out = []
    for seg in range_segments(scan, threshold_m=0.08, range_sigma_m=0.01):  # (the fixed settings' segmentation)
        p = seg.points
        if len(p) < 3:
            continue
        middle = p[len(p) // 2]
        chord = np.hypot(*(p[-1] - p[0])) + pad * np.hypot(*middle) * scan.angle_increment
        if not 0.1 <= chord <= 0.25:
            continue
        try:
            ratio = middle_point_offset(p)
            angles = inscribed_angles(p, signed=True)
        except ValueError:
            continue
        if not 0.1 < ratio < 0.7 or is_occluded(scan, seg.first, seg.last):
            continue
        center = middle + 0.5 * chord * middle / np.hypot(*middle)
        out.append((seg.first, seg.last, len(p), angles.mean(), angles.std(), center, chord))
    return out


@pytest.mark.parametrize("pad", [0.0, 1.0])
def test_batch_detector_matches_the_plain_loop(pad):
    n_legs = 0
    for scan, _ in sim.simulate("hall", 1, n_scans=60):
        got = detect_legs(scan, chord_padding_beams=pad, range_sigma_m=0)  # the paper's test, as the loop
        want = _reference_legs(scan, pad)
        n_legs += len(got)
        assert [(g.first, g.last, g.n_points) for g in got] == [w[:3] for w in want]
        for g, (*_, mean, std, center, chord) in zip(got, want, strict=True):
            assert g.iav_mean == pytest.approx(mean, abs=1e-9) and g.iav_std == pytest.approx(std, abs=1e-9)
            np.testing.assert_allclose(g.center, center, atol=1e-9)
            assert g.diameter == pytest.approx(chord, rel=1e-9)
    assert n_legs > 30


def _two_legs_world(rear_offset_m):
    """A front leg 2 m ahead and a rear leg 0.5 m behind it, ``rear_offset_m`` to the side."""
    return sim.World("legs", circles=(sim.Column((2.0, 0.0), 0.07, "leg"),
                                      sim.Column((2.5, rear_offset_m), 0.07, "leg")))


def test_a_partly_hidden_leg_is_rejected_as_occluded():
    scan, truth = sim.scan_at(_two_legs_world(0.15), LMS200, (0.0, 0.0, 0.0))
    front, rear = truth.circles
    assert rear.first == front.last + 1  # the front leg hides the rear one's right edge
    legs, trace = detect_legs(scan, trace=True)
    assert [(g.first, g.last) for g in legs] == [(front.first, front.last)]
    (rear_check,) = [t for t in trace if t.first == rear.first]
    assert rear_check.test == "occluded"
    assert is_occluded(scan, rear.first, rear.last) and not is_occluded(scan, front.first, front.last)
    # without the rule the partial leg passes, and its centre is off
    unguarded = detect_legs(scan, reject_occluded=False)
    assert len(unguarded) == 2


def test_side_by_side_legs_are_both_found():
    scan, truth = sim.scan_at(_two_legs_world(0.3), LMS200, (0.0, 0.0, 0.0))
    legs = detect_legs(scan)
    assert len(legs) == 2
    for leg, true in zip(legs, truth.circles, strict=True):
        assert np.hypot(*(leg.center - true.center)) < 0.02
        assert leg.diameter == pytest.approx(0.14, abs=0.03)
    (person,) = pair_legs(legs)
    np.testing.assert_allclose(person.center, (2.25, 0.15), atol=0.02)


@pytest.mark.parametrize("ranges, first, last, expected", [
    ([3.0, 2.0, 2.0, 2.0, 3.0], 1, 3, False),  # background on both sides
    ([1.5, 2.0, 2.0, 2.0, 3.0], 1, 3, True),  # something in front on the left
    ([3.0, 2.0, 2.0, 2.0, 1.9], 1, 3, True),  # ... on the right
    ([np.nan, 2.0, 2.0, 2.0, 30.0], 1, 3, False),  # a dropout and a no-return do not occlude
    ([2.0, 2.0, 2.0, 3.0, 3.0], 0, 2, True),  # cut by the edge of the field of view
    ([3.0, 3.0, 2.0, 2.0, 2.0], 2, 4, True),
], ids=["free", "left", "right", "invalid-neighbours", "fov-start", "fov-end"])
def test_occlusion_rule(ranges, first, last, expected):
    scan = Scan(ranges=ranges, angles=np.radians(np.arange(5.0)), range_max=30.0)
    assert is_occluded(scan, first, last) is expected


def test_occlusion_wraps_on_a_full_circle_scan():
    n = 360
    ranges = np.full(n, 5.0)
    ranges[[0, 1, 2]] = 2.0
    ring = Scan.from_angle_increment(ranges, -np.pi, 2 * np.pi / n)
    assert not is_occluded(ring, 0, 2)  # beam 359 (5 m) is behind, not the edge of a field of view
    ranges[n - 1] = 1.0
    assert is_occluded(Scan.from_angle_increment(ranges, -np.pi, 2 * np.pi / n), 0, 2)


@pytest.mark.parametrize("beam", [-1, 5, 1.5, True])
def test_is_occluded_checks_beam_indices(beam):
    scan = Scan(ranges=[1.0] * 5, angles=np.arange(5.0) * 0.01)
    with pytest.raises(ValueError, match="first"):
        is_occluded(scan, beam, 3)


def test_columns_and_walls_are_not_legs():
    world = sim.World("hall-like", walls=(sim.Wall((4.0, -3.0), (4.0, 3.0)),),
                      circles=(sim.Column((2.0, 1.0), 0.25), sim.Column((2.5, -1.0), 0.15)))
    rng = np.random.default_rng(0)
    for _ in range(10):
        scan, _ = sim.scan_at(world, LMS200, (0.0, 0.0, 0.0), rng=rng)
        legs, trace = detect_legs(scan, trace=True)
        assert legs == []
        assert "chord too long" in {t.test for t in trace}


def test_optional_iav_thresholds_tighten_the_test(hall):
    """With the circles' thresholds added, fewer legs pass (the paper has none for legs).
    Measured on 300 scans (seed 0): precision 1.0 but recall 0.56 against 0.93."""
    precision, recall, _, _ = _score(hall, iav_mean_range_deg=(90.0, 135.0), iav_std_max_deg=math.degrees(0.15))
    _, padded_recall, _, _ = _score(hall)
    assert precision >= 0.95 and 0.3 < recall < padded_recall - 0.2


@pytest.mark.parametrize("method", ["ray", "iav", "algebraic", "geometric"])
def test_centre_methods_on_a_clean_leg(method):
    world = sim.World("leg", circles=(sim.Column((1.5, 0.4), 0.08),))
    scan, _ = sim.scan_at(world, LMS200, (0.0, 0.0, 0.0))
    (leg,) = detect_legs(scan, center_method=method)
    np.testing.assert_allclose(leg.center, (1.5, 0.4), atol=0.012)
    assert leg.diameter == pytest.approx(0.16, abs=0.02)
    assert isinstance(leg, Leg) and leg.n_points == leg.last - leg.first + 1
    np.testing.assert_allclose(leg.middle, scan.points[(leg.first + leg.last + 1) // 2])


def _segment(points, first=1):
    p = np.asarray(points, dtype=float)
    return RangeSegment(np.arange(first, first + len(p)), p)


@pytest.mark.parametrize("points, verdict", [
    ([[1.0, 0.0]], "too few points"),
    ([[1.0, 0.0], [1.0, 0.15]], "too few points"),
    ([[1.0, 0.0]] * 4, "chord too short"),
    ([[1.0, 0.0], [1.0, 0.0], [0.95, 0.07], [1.0, 0.14]], "degenerate"),
], ids=["one", "two", "identical", "repeated-end"])
def test_degenerate_segments_are_skipped_with_a_reason(points, verdict):
    scan = Scan(ranges=np.ones(10), angles=np.arange(10) * 0.1)
    legs, trace = detect_legs(scan, segments=[_segment(points)], chord_padding_beams=0.0, trace=True)
    assert legs == [] and [t.test for t in trace] == [verdict]


def test_invalid_beams_are_masked_not_raised():
    assert detect_legs(Scan(ranges=[np.nan] * 10, angles=np.arange(10) * 0.01)) == []
    assert detect_legs(Scan(ranges=[], angles=[])) == []
    assert detect_legs(Scan(ranges=[2.0], angles=[0.0])) == []


@pytest.mark.parametrize("kwargs, match", [
    (dict(min_points=2), "min_points"),
    (dict(chord_range_m=(0.25, 0.1)), "chord_range_m"),
    (dict(chord_padding_beams=-1.0), "chord_padding_beams"),
    (dict(middle_range=(0.7, 0.1)), "middle_range"),
    (dict(iav_mean_range_deg=(60.0, 230.0)), "iav_mean_range_deg"),
    (dict(iav_std_max_deg=0.0), "iav_std_max_deg"),
    (dict(center_method="middle"), "center_method"),
    (dict(seg_threshold_m=-0.08), "seg_threshold_m"),
    (dict(segments=["a"]), "segments"),
])
def test_detect_legs_validates_its_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        detect_legs(Scan(ranges=np.ones(10), angles=np.arange(10) * 0.1), **kwargs)
    with pytest.raises(ValueError, match="scan"):
        detect_legs([1.0, 2.0])


# ============================================================================ pairing
def _leg(x, y, first=0):
    c = np.array([x, y], dtype=float)
    return Leg(c, 0.14, c, first, first + 4, 5, 2.0, 0.05)


def test_pairing_is_greedy_closest_first():
    a, b, c = _leg(0.0, 0.0, 0), _leg(0.3, 0.0, 10), _leg(0.75, 0.0, 20)
    (person,) = pair_legs([c, a, b])
    assert person.legs == (a, b)  # 0.3 m beats 0.45 m; c stays alone
    np.testing.assert_allclose(person.center, (0.15, 0.0))
    assert isinstance(person, Person)


def test_pairing_respects_the_distance_limit():
    assert pair_legs([_leg(0.0, 0.0), _leg(0.7, 0.0)]) == []
    assert len(pair_legs([_leg(0.0, 0.0), _leg(0.7, 0.0)], max_distance_m=0.8)) == 1
    assert pair_legs([]) == [] and pair_legs([_leg(0.0, 0.0)]) == []


@settings(max_examples=100)
@given(xy=st.lists(st.tuples(st.floats(-5, 5), st.floats(-5, 5)), max_size=12), limit=st.floats(0.05, 2.0))
def test_pairing_invariants(xy, limit):
    """Each leg is used at most once, every pair is within the limit, and no two
    leftover legs are within it (greedy pairing is maximal)."""
    legs = [_leg(x, y, 10 * i) for i, (x, y) in enumerate(xy)]
    people = pair_legs(legs, max_distance_m=limit)
    used = [id(g) for p in people for g in p.legs]
    assert len(used) == len(set(used))
    for p in people:
        assert np.hypot(*(p.legs[0].center - p.legs[1].center)) <= limit
        assert p.legs[0].first <= p.legs[1].first
    left = [g for g in legs if id(g) not in set(used)]
    for i in range(len(left)):
        for j in range(i + 1, len(left)):
            assert np.hypot(*(left[i].center - left[j].center)) > limit


@pytest.mark.parametrize("args, match", [
    (([_leg(0, 0)], 0.0), "max_distance_m"),
    (([_leg(0, 0)], np.inf), "max_distance_m"),
    ((["leg", "leg"], 0.6), "legs"),
])
def test_pair_legs_validates_its_arguments(args, match):
    with pytest.raises(ValueError, match=match):
        pair_legs(*args)
