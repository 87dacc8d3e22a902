"""The fallbacks a notebook goes on with while a "your turn" cell is a stub give the task's answer: checked
against values worked out by hand."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from labkit import course_fallbacks as fallbacks


def test_pair_two_legs_by_the_distance_between_the_centres():
    # (0, 0) and (0.3, 0.4) are 0.5 m apart: one person, at the midpoint (0.15, 0.2)
    np.testing.assert_allclose(fallbacks.pair_two_legs((0.0, 0.0), (0.3, 0.4)), (0.15, 0.2))
    np.testing.assert_allclose(fallbacks.pair_two_legs((0.0, 1.0), (0.6, 1.0)), (0.3, 1.0))   # 0.6 m: the limit pairs
    assert fallbacks.pair_two_legs((0.0, 0.0), (0.5, 0.5)) is None       # 0.71 m, though 0.5 m apart in x and in y
    assert fallbacks.pair_two_legs((2.0, 1.0), (2.3, 1.0), max_distance_m=0.2) is None
    np.testing.assert_allclose(fallbacks.pair_two_legs((2.0, 1.0), (2.3, 1.0), max_distance_m=0.35), (2.15, 1.0))


def test_fewer_lines_share_counts_strictly_fewer_scan_by_scan():
    def run(*counts):  # a run's features of some scans, each with `count` lines
        return [SimpleNamespace(lines=[object()] * n) for n in counts]

    a, b = run(3, 2, 5, 0), run(1, 2, 6, 0)                 # fewer in scan 0 only; equal in 1 and 3
    assert fallbacks.fewer_lines_share(a, b) == 0.25
    assert fallbacks.fewer_lines_share(b, a) == 0.25          # scan 2: the first run has fewer
    assert fallbacks.fewer_lines_share(a, a) == 0.0
    with pytest.raises(ValueError):
        fallbacks.fewer_lines_share(a, b[:3])                  # not the same scans
