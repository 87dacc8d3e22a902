"""The speed helpers behind labkit.features give what the plain versions give.

``labkit._fastinit.fast_init`` builds the feature records; ``labkit._plainfloat`` holds the
plain-float copies of two geometry functions that :func:`labkit.find_corners` uses.
"""

from __future__ import annotations

import dataclasses
import inspect
import math

import numpy as np
import pytest

from labkit import Circle, Corner, Leg, LineSegment, find_corners, read_scans, split_and_merge
from labkit._plainfloat import intersect1, wrap1
from labkit.app.data import bundled_data
from labkit.geometry import intersect_lines, wrap_angle

RECORDS = (LineSegment, Corner, Circle, Leg)


def _plain_twin(cls):
    """The same fields as a frozen dataclass with the generated ``__init__``."""
    spec = [(f.name, f.type, dataclasses.field(default=f.default) if f.default is not dataclasses.MISSING
             else dataclasses.field()) for f in dataclasses.fields(cls)]
    return dataclasses.make_dataclass(f"Plain{cls.__name__}", spec, frozen=True, eq=False)


@pytest.mark.parametrize("cls", RECORDS, ids=lambda c: c.__name__)
def test_fast_records_are_the_dataclass_they_declare(cls):
    twin = _plain_twin(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    assert list(inspect.signature(cls).parameters) == list(inspect.signature(twin).parameters) == names
    values = [object() for _ in names]
    fast, plain = cls(*values), twin(*values)
    assert all(getattr(fast, n) is getattr(plain, n) for n in names)
    assert cls(**dict(zip(names, values, strict=True))).__dict__ == fast.__dict__
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(fast, names[0], 1)
    required = sum(f.default is dataclasses.MISSING for f in dataclasses.fields(cls))
    with pytest.raises(TypeError):
        cls(*values[:required - 1])  # a missing field is refused, as by the generated __init__
    with pytest.raises(TypeError):
        twin(*values[:required - 1])


def test_plain_float_wrap_is_wrap_angle():
    angles = np.r_[np.linspace(-20, 20, 4001), [math.pi, -math.pi, 3 * math.pi, 0.0, 1e-17]]
    assert [wrap1(float(a)) for a in angles] == wrap_angle(angles).tolist()


def test_plain_float_intersection_is_intersect_lines():
    rng = np.random.default_rng(3)
    for r1, a1, r2, a2 in zip(rng.uniform(0, 10, 2000), rng.uniform(-math.pi, math.pi, 2000),
                              rng.uniform(0, 10, 2000), rng.uniform(-math.pi, math.pi, 2000), strict=True):
        want = intersect_lines(r1, a1, r2, a2)
        got = intersect1(r1, a1, r2, a2)
        assert (got is None) == (want is None)
        if want is not None:
            assert got == pytest.approx(tuple(want), rel=1e-9, abs=1e-9)
    assert intersect1(1.0, 0.3, 2.0, 0.3) is None and intersect_lines(1.0, 0.3, 2.0, 0.3) is None


def test_corners_on_the_bundled_scans_use_the_intersections_of_their_lines():
    """On the reference scans every corner is where geometry.intersect_lines puts it."""
    n = 0
    for scan in list(read_scans(bundled_data("hall.bag")))[:100]:
        lines = split_and_merge(scan)
        for c in find_corners(lines):
            a, b = (lines[i] for i in c.lines)
            assert c.point == pytest.approx(intersect_lines(a.r, a.alpha, b.r, b.alpha), abs=1e-9)
            n += 1
    assert n > 50
