"""The Scan model: validation at the boundary, masking of invalid beams, constructors."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from labkit import Scan, polar_to_cartesian


# ---------------------------------------------------------------- masking
def test_valid_mask_rules():
    s = Scan(
        ranges=[1.0, np.nan, np.inf, -np.inf, 0.0, -1.0, 0.05, 0.1, 29.99, 30.0, 31.0],
        angles=np.linspace(-1, 1, 11),
        range_min=0.1,
        range_max=30.0,
    )
    # finite, > 0, >= range_min, < range_max (a reading equal to range_max is "no return")
    assert s.valid.tolist() == [True, False, False, False, False, False, False, True, True, False, False]
    assert s.valid_indices.tolist() == [0, 7, 8]


def test_xy_keeps_beam_indices():
    angles = np.radians([0.0, 45.0, 90.0, 180.0])
    s = Scan(ranges=[2.0, np.nan, 3.0, 1.0], angles=angles)
    np.testing.assert_allclose(s.xy, [[2.0, 0.0], [0.0, 3.0], [-1.0, 0.0]], atol=1e-12)
    assert s.valid_indices.tolist() == [0, 2, 3]
    assert np.isnan(s.points[1]).all()
    np.testing.assert_allclose(s.points[s.valid_indices], s.xy)


def test_defaults_and_repr():
    s = Scan(ranges=[1.0, 2.0], angles=[0.0, 0.1])
    assert (s.range_min, s.range_max, s.stamp_ns, s.frame_id, s.pose) == (0.0, math.inf, 0, "laser", None)
    assert "2 beams, 2 valid" in repr(s)


def test_arrays_are_read_only_copies():
    r = np.array([1.0, 2.0])
    s = Scan(ranges=r, angles=[0.0, 0.1])
    r[0] = 99.0
    assert s.ranges[0] == 1.0
    with pytest.raises(ValueError):
        s.ranges[0] = 5.0
    with pytest.raises(ValueError):
        s.xy[0, 0] = 5.0


# ---------------------------------------------------------------- validation
@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(ranges=[1.0, 2.0], angles=[0.0]), "same length"),
        (dict(ranges=[1.0, 2.0], angles=[0.1, 0.0]), "angles must be strictly increasing"),
        (dict(ranges=[1.0, 2.0], angles=[0.1, 0.1]), "angles must be strictly increasing"),
        (dict(ranges=[1.0, 2.0], angles=[0.0, np.nan]), "angles must be finite"),
        (dict(ranges=[1.0, 2.0], angles=[0.0, 7.0]), "span at most 2 pi"),
        (dict(ranges=[[1.0]], angles=[[0.0]]), "one-dimensional"),
        (dict(ranges=["a"], angles=[0.0]), "ranges must be a sequence of numbers"),
        (dict(ranges=[1.0], angles=[0.0], range_min=-1.0), "range_min must be >= 0"),
        (dict(ranges=[1.0], angles=[0.0], range_max=-1.0), "range_max must be >= 0"),
        (dict(ranges=[1.0], angles=[0.0], range_min=5.0, range_max=2.0), "range_max must be > range_min"),
        (dict(ranges=[1.0], angles=[0.0], range_max=float("nan")), "range_max"),
        (dict(ranges=[1.0], angles=[0.0], stamp_ns="soon"), "stamp_ns"),
        (dict(ranges=[1.0], angles=[0.0], frame_id=3), "frame_id"),
        (dict(ranges=[1.0], angles=[0.0], intensities=[1.0, 2.0]), "intensities"),
        (dict(ranges=[1.0], angles=[0.0], pose=(1.0, 2.0)), "pose"),
        (dict(ranges=[1.0], angles=[0.0], pose=(1.0, 2.0, np.inf)), "pose"),
    ],
)
def test_bad_input_names_the_argument(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Scan(**kwargs)


def test_full_circle_detection():
    n = 360
    full = Scan.from_angle_increment(np.ones(n), -np.pi, 2 * np.pi / n)
    assert full.is_full_circle
    half = Scan.from_angle_increment(np.ones(361), -np.pi / 2, np.pi / 360)
    assert not half.is_full_circle
    # some drivers publish both -pi and +pi: a span of exactly 2 pi is accepted
    both_ends = Scan(ranges=np.ones(5), angles=np.linspace(-np.pi, np.pi, 5))
    assert both_ends.is_full_circle


# ---------------------------------------------------------------- constructors
def test_from_angle_increment_matches_explicit_angles():
    s = Scan.from_angle_increment([1.0, 2.0, 3.0], -0.5, 0.25, range_max=10.0)
    np.testing.assert_allclose(s.angles, [-0.5, -0.25, 0.0])
    assert s.range_max == 10.0


def test_negative_increment_is_reversed():
    s = Scan.from_angle_increment([1.0, 2.0, 3.0], 0.5, -0.25, intensities=[10.0, 20.0, 30.0])
    np.testing.assert_allclose(s.angles, [0.0, 0.25, 0.5])
    np.testing.assert_allclose(s.ranges, [3.0, 2.0, 1.0])
    np.testing.assert_allclose(s.intensities, [30.0, 20.0, 10.0])


@pytest.mark.parametrize("inc", [0.0, np.nan, np.inf])
def test_from_angle_increment_rejects_bad_increment(inc):
    with pytest.raises(ValueError, match="angle_increment"):
        Scan.from_angle_increment([1.0, 2.0], 0.0, inc)


def _ros2_msg(**over):
    msg = SimpleNamespace(
        header=SimpleNamespace(stamp=SimpleNamespace(sec=12, nanosec=345), frame_id="base_laser"),
        angle_min=-1.0, angle_max=1.0, angle_increment=1.0, range_min=0.1, range_max=5.0,
        ranges=np.array([1.0, 5.0, np.nan], dtype=np.float32), intensities=np.array([], dtype=np.float32),
    )
    for k, v in over.items():
        setattr(msg, k, v)
    return msg


def test_from_ros2_message():
    s = Scan.from_ros(_ros2_msg())
    assert s.stamp_ns == 12_000_000_345
    assert s.frame_id == "base_laser"
    np.testing.assert_allclose(s.angles, [-1.0, 0.0, 1.0])
    assert s.valid.tolist() == [True, False, False]
    assert s.intensities is None


def test_from_ros1_message_stamp():
    msg = _ros2_msg(header=SimpleNamespace(stamp=SimpleNamespace(secs=3, nsecs=7), frame_id="l"))
    assert Scan.from_ros(msg).stamp_ns == 3_000_000_007


def test_from_ros_rejects_other_messages():
    with pytest.raises(ValueError, match="not a sensor_msgs/LaserScan"):
        Scan.from_ros(SimpleNamespace(header=None))


def test_replace_validates():
    s = Scan(ranges=[1.0, 2.0], angles=[0.0, 0.1])
    assert s.replace(stamp_ns=5).stamp_ns == 5
    with pytest.raises(ValueError, match="unknown Scan fields"):
        s.replace(color="red")
    with pytest.raises(ValueError, match="same length"):
        s.replace(ranges=[1.0])


def test_polar_to_cartesian_closed_form():
    r = np.array([1.0, 2.0, 3.0])
    a = np.array([0.0, np.pi / 2, np.pi])
    np.testing.assert_allclose(polar_to_cartesian(r, a), [[1, 0], [0, 2], [-3, 0]], atol=1e-12)
    with pytest.raises(ValueError, match="same shape"):
        polar_to_cartesian([1.0], [0.0, 1.0])


# ---------------------------------------------------------------- fuzzing
weird_floats = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, -1.0, 1e-300, 1e300, 30.0]),
)


def _check_invariants(s: Scan) -> None:
    assert s.valid.shape == (s.n_beams,)
    assert s.xy.shape == (int(s.valid.sum()), 2)
    assert np.all(np.isfinite(s.xy))
    assert s.valid_indices.shape == (s.xy.shape[0],)
    assert np.all(np.diff(s.valid_indices) > 0)
    assert np.all(s.ranges[s.valid] > 0)
    assert np.all(s.ranges[s.valid] < s.range_max)
    repr(s)


def _limits_ok(range_min, range_max) -> bool:
    return 0 <= range_min < range_max  # False for NaN


def _angles_ok(angle_min, increment, n) -> bool:
    if n <= 1:
        return bool(np.isfinite(angle_min)) and np.isfinite(increment) and increment != 0
    # The beam angles as float64 holds them: far from zero (|angle_min| ~ 1e16) rounding
    # alone can stretch a 5 rad span to 8 rad, and such input is rightly rejected.
    with np.errstate(over="ignore", invalid="ignore"):
        angles = angle_min + increment * np.arange(n)
        steps = np.diff(angles) * np.sign(increment)
    return bool(np.isfinite([angle_min, increment]).all() and np.isfinite(angles).all() and increment != 0
                and abs(angles[-1] - angles[0]) <= 2 * np.pi
                and np.all(steps > 0))


def build_or_reject(make, well_formed: bool):
    """Either a Scan whose invariants hold, or a ValueError -- and never a ValueError for
    well-formed input (invalid *readings* are masked, not raised)."""
    try:
        s = make()
    except ValueError as exc:
        assert not well_formed, f"well-formed input rejected: {exc}"
        return None
    _check_invariants(s)
    return s


@settings(max_examples=300)
@given(
    ranges=st.lists(weird_floats, max_size=40),
    start=st.floats(-10, 10),
    step=st.floats(1e-4, 0.2),
    range_min=weird_floats,
    range_max=weird_floats,
)
def test_fuzz_constructor(ranges, start, step, range_min, range_max):
    angles = start + step * np.arange(len(ranges))
    build_or_reject(lambda: Scan(ranges=ranges, angles=angles, range_min=range_min, range_max=range_max),
                    _limits_ok(range_min, range_max) and _angles_ok(start, step, len(ranges)))


@settings(max_examples=300)
@given(ranges=st.lists(weird_floats, max_size=40), angle_min=weird_floats, increment=weird_floats)
@example(ranges=[0.0, 0.0], angle_min=3.602879701896397e16, increment=5.0)  # rounding: 5 rad steps become 8
@example(ranges=[0.0, 0.0], angle_min=3.602879701896397e16, increment=-5.0)
def test_fuzz_from_angle_increment(ranges, angle_min, increment):
    build_or_reject(lambda: Scan.from_angle_increment(ranges, angle_min, increment, range_max=30.0),
                    _angles_ok(angle_min, increment, len(ranges)))


@settings(max_examples=200)
@given(
    ranges=st.lists(weird_floats, max_size=30),
    angle_min=st.floats(-4, 4),
    increment=st.one_of(weird_floats, st.floats(-0.05, 0.05)),
    range_min=st.one_of(weird_floats, st.floats(0, 1)),
    range_max=st.one_of(weird_floats, st.floats(1, 100)),
    sec=st.integers(0, 2**32 - 1),
    nsec=st.integers(0, 999_999_999),
)
def test_fuzz_from_ros(ranges, angle_min, increment, range_min, range_max, sec, nsec):
    msg = _ros2_msg(
        ranges=np.array(ranges, dtype=np.float64), angle_min=angle_min, angle_increment=increment,
        range_min=range_min, range_max=range_max,
        header=SimpleNamespace(stamp=SimpleNamespace(sec=sec, nanosec=nsec), frame_id="l"),
    )
    s = build_or_reject(lambda: Scan.from_ros(msg),
                        _limits_ok(range_min, range_max) and _angles_ok(angle_min, increment, len(ranges)))
    if s is not None:
        assert s.stamp_ns == sec * 1_000_000_000 + nsec
