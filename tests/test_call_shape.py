"""The one call shape of labkit's detectors (``labkit._params.takes_params``): keywords are
checked like a record, and the record a keyword builds is remembered for the next call --
these tests try to make that memory answer for a call it was not made for."""

from __future__ import annotations

import numpy as np
import pytest

from labkit import detect_circles, segment_labels
from labkit.circles.iav import CircleParams
from labkit.scan import Scan
from labkit.segmentation import SegmentationParams

# Three walls 2 m away, each 0.3 m from the next: one segment at a 0.5 m threshold, three at 0.1 m
_ANGLES = np.radians(np.arange(30) * 0.5)
_SCAN = Scan(ranges=2.0 + 0.3 * (np.arange(30) // 10), angles=_ANGLES)


def test_a_keyword_is_the_record_with_that_value():
    for threshold in (0.5, 0.1, 0.5):  # back and forth: each call its own answer, not the last call's
        by_keyword = segment_labels(_SCAN, threshold_m=threshold, adaptive=False)
        by_record = segment_labels(_SCAN, SegmentationParams(threshold_m=threshold, adaptive=False))
        np.testing.assert_array_equal(by_keyword, by_record)
        assert by_keyword.max() + 1 == (1 if threshold == 0.5 else 3)


def test_the_same_keywords_on_another_record_use_that_record():
    loose, tight = SegmentationParams(threshold_m=0.5), SegmentationParams(threshold_m=0.1)
    assert segment_labels(_SCAN, loose, adaptive=False).max() == 0
    assert segment_labels(_SCAN, tight, adaptive=False).max() == 2


def test_a_value_of_the_wrong_type_is_refused_after_the_right_one_was_remembered():
    segment_labels(_SCAN, adaptive=True)  # remembered; 1 == True and hash(1) == hash(True)
    with pytest.raises(ValueError, match="adaptive must be true or false"):
        segment_labels(_SCAN, adaptive=1)
    segment_labels(_SCAN, min_points=2)
    with pytest.raises(ValueError, match="min_points must be a whole number"):
        segment_labels(_SCAN, min_points=2.0)


def test_a_bad_value_is_refused_every_time():
    for _ in range(2):  # a refusal is not remembered as a record
        with pytest.raises(ValueError, match="threshold_m must be > 0"):
            segment_labels(_SCAN, threshold_m=-1.0)


def test_a_pair_given_as_a_list_is_checked_and_used():
    s = Scan(ranges=np.full(40, 2.0), angles=np.radians(np.arange(40) * 0.5))
    assert detect_circles(s, mean_range_deg=[90.0, 155.0]) == detect_circles(s, CircleParams())
    with pytest.raises(ValueError, match="low < high"):
        detect_circles(s, mean_range_deg=[155.0, 90.0])


def test_the_old_positional_threshold_and_its_errors():
    np.testing.assert_array_equal(segment_labels(_SCAN, 0.5, adaptive=False),
                                  segment_labels(_SCAN, threshold_m=0.5, adaptive=False))
    with pytest.raises(TypeError, match="got 'threshold_m' twice"):
        segment_labels(_SCAN, 0.5, threshold_m=0.5)
    with pytest.raises(TypeError, match="takes the scan"):
        segment_labels(_SCAN, 0.5, 3)
    with pytest.raises(TypeError, match="has no parameter 'treshold_m'"):
        segment_labels(_SCAN, treshold_m=0.5)
    with pytest.raises(ValueError, match="must be a SegmentationParams"):
        segment_labels(_SCAN, CircleParams())
