"""The public boundary of labkit's detectors (``labkit.params.checked_by``): real signatures whose
keywords are the parameter record's fields with the record's defaults, every value checked there
against the record's limits, and the keywords of the older call shape still working for one release
with a ``DeprecationWarning`` that names the new one.

The invalid values are generated from each record's declared limits (as scikit-learn's
``check_param_validation`` feeds generated invalid values to every estimator), so a new field is
checked without an edit here."""

from __future__ import annotations

import dataclasses
import inspect
import math

import numpy as np
import pytest

import labkit
from labkit.circles import ArcParams, CircleParams, LegsParams
from labkit.features import CornerParams
from labkit.lines import (
    AngularParams,
    HoughParams,
    IAVLineParams,
    IncrementalParams,
    RansacParams,
    RegressionParams,
    SplitMergeParams,
)
from labkit.scan import Scan
from labkit.segmentation import SegmentationParams

# Three walls 2 m away, each 0.3 m from the next: one segment at a 0.5 m threshold, three at 0.1 m
_ANGLES = np.radians(np.arange(30) * 0.5)
_SCAN = Scan(ranges=2.0 + 0.3 * (np.arange(30) // 10), angles=_ANGLES)

#: every public function checked by a record, with that record
PUBLIC = [
    (labkit.segment_labels, SegmentationParams),
    (labkit.range_segments, SegmentationParams),
    (labkit.split_and_merge, SplitMergeParams),
    (labkit.incremental_lines, IncrementalParams),
    (labkit.regression_lines, RegressionParams),
    (labkit.ransac_lines, RansacParams),
    (labkit.hough_lines, HoughParams),
    (labkit.angular_segmentation, AngularParams),
    (labkit.angular_arrays, AngularParams),
    (labkit.detect_lines_iav, IAVLineParams),
    (labkit.detect_circles, CircleParams),
    (labkit.detect_arcs, ArcParams),
    (labkit.detect_legs, LegsParams),
    (labkit.find_corners, CornerParams),
]
_IDS = [fn.__name__ for fn, _ in PUBLIC]


def _fields(record) -> list[dataclasses.Field]:
    return [f for f in dataclasses.fields(record) if f.metadata.get("record") is None
            and f.name not in record._not_passed]


@pytest.mark.parametrize(("fn", "record"), PUBLIC, ids=_IDS)
def test_the_signature_is_the_record(fn, record):
    """Every field is a keyword of the function, of the same name, whose default is the record's."""
    params = inspect.signature(fn).parameters
    assert "overrides" not in params and "params" not in params
    for f in _fields(record):
        assert f.name in params, f"{fn.__name__} has no keyword {f.name}"
        p = params[f.name]
        assert p.kind is inspect.Parameter.KEYWORD_ONLY
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        assert p.default == default, f"{fn.__name__}({f.name}=...) defaults to {p.default!r}, the record to {default!r}"
    assert fn.params_cls is record


def _invalid(f: dataclasses.Field) -> list:
    """Values the field's declared limits refuse."""
    meta = f.metadata
    kind = meta["kind"]
    if kind is bool:
        return [1, "yes"]
    if kind is str:
        return ["no such choice", 3]
    if kind is tuple:
        lo = meta["lo"] if meta["lo"] is not None else 0.0
        return [(lo + 2.0, lo + 1.0), (lo - 1.0, lo + 1.0) if meta["lo"] is not None else (1.0,), "ab"]
    out = ["many" if not meta.get("auto") else "some", None if not meta["optional"] else "none?", [1.0]]
    if meta["lo"] is not None:
        out.append(meta["lo"] if meta["strict"] else meta["lo"] - 1)
    if meta["hi"] is not None:
        out.append(meta["hi"] + 1)
    if kind is int:
        out.append(3.5)
    elif meta.get("finite"):
        out.append(math.inf)
    return out


@pytest.mark.parametrize(("fn", "record"), PUBLIC, ids=_IDS)
def test_every_invalid_value_is_refused_naming_its_keyword(fn, record):
    first = [] if fn is labkit.find_corners else _SCAN
    checked = 0
    for f in _fields(record):
        for value in _invalid(f):
            with pytest.raises(ValueError, match=f.name):
                fn(first, **{f.name: value})
            checked += 1
    assert checked >= 2 * len(_fields(record))


@pytest.mark.parametrize(("fn", "record"), PUBLIC, ids=_IDS)
def test_the_record_refuses_what_the_function_refuses(fn, record):
    """One home for the limits: the same values are refused by the record (a config file)."""
    for f in _fields(record):
        for value in _invalid(f):
            with pytest.raises(ValueError, match=f.name):
                record(**{f.name: value})


def test_a_keyword_is_the_value_it_names():
    for threshold in (0.5, 0.1, 0.5):
        labels = labkit.segment_labels(_SCAN, threshold_m=threshold, adaptive=False)
        assert labels.max() + 1 == (1 if threshold == 0.5 else 3)


def test_a_value_of_the_wrong_type_is_refused():
    labkit.segment_labels(_SCAN, adaptive=True)
    with pytest.raises(ValueError, match="adaptive must be true or false"):
        labkit.segment_labels(_SCAN, adaptive=1)
    with pytest.raises(ValueError, match="min_points must be a whole number"):
        labkit.segment_labels(_SCAN, min_points=2.0)


def test_a_misspelt_keyword_is_a_type_error():
    with pytest.raises(TypeError, match="treshold_m"):
        labkit.segment_labels(_SCAN, treshold_m=0.5)


# ---------------------------------------------------------------------------- the older call shape
def test_a_record_as_second_argument_still_works_with_a_warning():
    with pytest.warns(DeprecationWarning, match=r"segment_labels\(scan, \*\*params.kwargs\(\)\)"):
        old = labkit.segment_labels(_SCAN, SegmentationParams(threshold_m=0.5, adaptive=False))
    np.testing.assert_array_equal(old, labkit.segment_labels(_SCAN, threshold_m=0.5, adaptive=False))
    with pytest.raises(ValueError, match="must be a SegmentationParams"):
        labkit.segment_labels(_SCAN, IAVLineParams())


def test_the_old_positional_threshold_still_works_with_a_warning():
    with pytest.warns(DeprecationWarning, match="threshold_m by position"):
        old = labkit.segment_labels(_SCAN, 0.5, adaptive=False)
    np.testing.assert_array_equal(old, labkit.segment_labels(_SCAN, threshold_m=0.5, adaptive=False))
    with pytest.warns(DeprecationWarning), pytest.raises(TypeError, match="got 'threshold_m' twice"):
        labkit.segment_labels(_SCAN, 0.5, threshold_m=0.5)
    with pytest.raises(TypeError, match="one positional argument"):
        labkit.segment_labels(_SCAN, 0.5, 3)


def _room():
    from tests.test_split_merge import room_scan

    return room_scan()


@pytest.mark.parametrize(("fn", "old", "new"), [
    (labkit.split_and_merge, {"merge_dalpha": math.radians(4.0)}, {"merge_dalpha_deg": 4.0}),
    (labkit.split_and_merge, {"place_dalpha": math.radians(1.0)}, {"place_dalpha_deg": 1.0}),
    (labkit.hough_lines, {"alpha_step": math.radians(2.0)}, {"alpha_step_deg": 2.0}),
    (labkit.angular_segmentation, {"eps_theta": math.radians(5.0), "eps_dist": 0.05, "min_pts": 6},
     {"eps_theta_deg": 5.0, "eps_dist_m": 0.05, "min_points": 6}),
    (labkit.detect_lines_iav, {"mean_tolerance": math.radians(3.0)}, {"mean_tolerance_deg": 3.0}),
])
def test_an_old_keyword_is_its_new_one_with_a_warning_naming_it(fn, old, new):
    scan = _room()
    with pytest.warns(DeprecationWarning) as caught:
        got = fn(scan, **old)
    said = " ".join(str(w.message) for w in caught)
    for name in new:
        assert f"{name}=" in said
    want = fn(scan, **new)
    assert [(ln.first, ln.last) for ln in got] == [(ln.first, ln.last) for ln in want]
    assert all(math.isclose(a.r, b.r, abs_tol=1e-12) for a, b in zip(got, want, strict=True))


def test_angular_segmentations_old_positional_shape_still_works_with_a_warning():
    scan = _room()
    with pytest.warns(DeprecationWarning):
        old = labkit.angular_segmentation(scan, math.radians(4.0), 0.04, 7)
    new = labkit.angular_segmentation(scan, eps_theta_deg=4.0, eps_dist_m=0.04, min_points=7)
    assert [(ln.first, ln.last) for ln in old] == [(ln.first, ln.last) for ln in new]


def test_an_old_keyword_and_its_new_one_together_are_refused():
    with pytest.warns(DeprecationWarning), pytest.raises(TypeError, match="both"):
        labkit.split_and_merge(_room(), merge_dalpha=0.1, merge_dalpha_deg=5.0)


def test_lines_similar_takes_degrees_and_its_old_radians_with_a_warning():
    from labkit.features import line_segment

    a = line_segment(np.array([[-1.0, 2.0], [-2.0, 2.0], [-3.0, 2.0]]), [0, 1, 2])
    b = line_segment(np.array([[-4.0, 2.0], [-5.0, 2.1], [-6.0, 2.2]]), [3, 4, 5])  # about 5.7 deg apart
    far = 100.0  # |dr| does not decide here
    assert labkit.lines_similar(a, b, merge_dr_m=far, merge_dalpha_deg=10.0)[0]
    assert not labkit.lines_similar(a, b, merge_dr_m=far, merge_dalpha_deg=5.0)[0]
    with pytest.warns(DeprecationWarning, match="merge_dalpha_deg"):
        assert not labkit.lines_similar(a, b, merge_dr_m=far, merge_dalpha=math.radians(5.0))[0]
    with pytest.warns(DeprecationWarning, match="merge_dalpha_deg"):
        assert labkit.lines_similar(a, b, merge_dr_m=far, merge_dalpha=math.radians(10.0))[0]


# ---------------------------------------------------------------------------- the IAV detectors' older keywords
def _hall_with_people():
    from labkit import sim

    scan, _ = list(sim.simulate("hall", 0, n_scans=9))[8]  # columns, the bench, the walking student's legs
    return scan


def _rounded_room():
    from labkit import sim

    walls = (sim.Wall((0.0, 0.0), (6.0, 0.0)), sim.Wall((6.0, 0.0), (6.0, 4.2)), sim.Wall((5.2, 5.0), (0.0, 5.0)))
    world = sim.World("room", walls=walls, arcs=(sim.Arc((5.2, 4.2), 0.8, 0.0, math.pi / 2),))
    return sim.scan_at(world, sim.LIDARS["lms200"], (3.0, 1.5, math.pi / 2), rng=np.random.default_rng(0))[0]


def _places(found) -> list:
    return [(f.first, f.last, *np.round(f.center, 9).tolist()) for f in found]


@pytest.mark.parametrize(("fn", "scan", "old", "new"), [
    (labkit.detect_circles, _hall_with_people, {"std_max": 0.12, "mean_range": (math.radians(95), math.radians(130))},
     {"std_max_deg": math.degrees(0.12), "mean_range_deg": (95.0, 130.0)}),
    (labkit.detect_circles, _hall_with_people, {"arc_like": True, "arc_like_std_max": math.radians(20.0)},
     {"arc_like": True, "arc_like_std_max_deg": 20.0}),
    (labkit.detect_legs, _hall_with_people, {"chord_range": (0.08, 0.3)}, {"chord_range_m": (0.08, 0.3)}),
    (labkit.detect_legs, _hall_with_people, {"iav_std_max": 0.4, "iav_mean_range": None},
     {"iav_std_max_deg": math.degrees(0.4), "iav_mean_range_deg": None}),
    (labkit.detect_arcs, _rounded_room, {"line_params": {"split_threshold_m": 0.03}}, {"split_threshold_m": 0.03}),
    (labkit.detect_arcs, _rounded_room, {"mean_range": (math.radians(90.0), math.radians(160.0))},
     {"mean_range_deg": (90.0, 160.0)}),
], ids=["circles-radians", "circles-arc-like", "legs-chord_range", "legs-radians", "arcs-line_params", "arcs-radians"])
def test_the_iav_detectors_old_keywords_are_their_new_ones_with_a_warning(fn, scan, old, new):
    scan = scan()
    with pytest.warns(DeprecationWarning) as caught:
        got = fn(scan, **old)
    said = " ".join(str(w.message) for w in caught)
    for name in set(new) - set(old):
        assert f"{name}=" in said
    want = fn(scan, **new)
    assert want and _places(got) == _places(want)


def test_the_iav_detectors_old_positional_shapes_still_work_with_a_warning():
    scan = _hall_with_people()
    for fn, record in ((labkit.detect_circles, CircleParams(min_points=5)), (labkit.detect_legs, LegsParams())):
        with pytest.warns(DeprecationWarning, match=r"\*\*params.kwargs\(\)"):
            old = fn(scan, record)
        assert old and _places(old) == _places(fn(scan, **record.kwargs()))
    room = _rounded_room()
    lines = labkit.split_and_merge(room, split_threshold_m=0.02, min_length_m=0.5)
    with pytest.warns(DeprecationWarning, match="lines by position"):
        old = labkit.detect_arcs(room, lines)
    assert old and _places(old) == _places(labkit.detect_arcs(room, lines=lines))
    with pytest.raises(ValueError, match="line_params is only used when lines is None"):
        labkit.detect_arcs(room, lines=lines, line_params={"split_threshold_m": 0.03})


def test_limits_between_fields_are_checked_by_the_record_and_at_the_call():
    """One home: min_chord_m < max_chord_m and, with arc_like, arc_like_std_max_deg > std_max_deg, in the
    record (a config file) and on the keywords a call passes (with the defaults of the others)."""
    for make in (lambda **kw: CircleParams(**kw), lambda **kw: labkit.detect_circles(_SCAN, **kw)):
        with pytest.raises(ValueError, match="min_chord_m must be < max_chord_m"):
            make(min_chord_m=1.0, max_chord_m=0.5)
        with pytest.raises(ValueError, match="arc_like_std_max_deg must exceed std_max_deg"):
            make(arc_like=True, std_max_deg=30.0)
        make(arc_like=False, std_max_deg=30.0)  # (the arc-like limit is not used then)
    with pytest.raises(ValueError, match="min_chord_m must be < max_chord_m"):
        labkit.detect_arcs(_SCAN, lines=[], max_chord_m=0.1)
    with pytest.raises(ValueError, match="circles.min_chord_m must be < max_chord_m"):
        labkit.Config.from_dict({"circles": {"max_chord_m": 0.1}})


def test_a_limit_the_detector_needs_is_the_records():
    """The V-corner test needs a neighbour on each side: a config with one neighbour was accepted and made
    detect_circles(arc_like=True) raise in the middle of a scan."""
    with pytest.raises(ValueError, match="v_corner_neighbours must be >= 2"):
        labkit.Config.from_dict({"circles": {"v_corner_neighbours": 1}})
    with pytest.raises(ValueError, match="v_corner_neighbours"):
        labkit.detect_circles(_SCAN, v_corner_neighbours=1)


def test_a_pair_with_one_bound_names_itself_when_refused():
    """A pair field with a lower bound only (middle_range) raised TypeError formatting its message."""
    with pytest.raises(ValueError, match=r"middle_range must lie within \[0, inf\]"):
        labkit.Config.from_dict({"circles": {"middle_range": [-1.0, 1.0]}})
