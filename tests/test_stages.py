"""Each detector alone, with its parameter record's defaults, gives what its pipeline stage
gives (issue 14: one source of defaults), on the simulator's scans. The pipeline is
:func:`labkit.extract_features` with the default :class:`labkit.Config`; a later stage is
compared given the segments the stages before it left (the beams of legs and circles
masked), and with the stages before it switched off, alone on the whole scan."""

from __future__ import annotations

import numpy as np
import pytest

import labkit
from labkit import sim
from labkit.lines import LINE_EXTRACTORS


def _scans():
    out = []
    for world in ("hall", "corridor", "office"):
        for k, pose in enumerate([(0.0, 0.0, 0.0), (1.0, 0.5, 0.3)]):
            scan, _ = sim.scan_at(sim.make_world(world), sim.LIDARS["lms200"], pose, 2.0,
                                  rng=np.random.default_rng(k))
            out.append(scan)
    out += [s for s, _ in list(sim.simulate("hall", 0, n_scans=20))[::4]]  # the walking student: legs
    return out


SCANS = _scans()


def _key(features):
    """Each feature's beams and geometry, exactly."""
    return [(getattr(f, "first", None), getattr(f, "last", None), *np.concatenate(
        [np.atleast_1d(np.asarray(getattr(f, a), dtype=float)) for a in ("r", "alpha", "center", "radius", "point")
         if hasattr(f, a)]).tolist()) for f in features]


def _mask(labels, taken):
    drop = np.isin(labels, [labels[f.first] for f in taken])
    return np.where(drop & (labels >= 0), -1, labels)


OFF = {"legs": {"enabled": False}, "circles": {"enabled": False}}


@pytest.mark.parametrize("i", range(len(SCANS)))
def test_segmentation_legs_circles_alone_are_the_stages(i):
    scan = SCANS[i]
    f = labkit.extract_features(scan)
    assert np.array_equal(labkit.segment_labels(scan), f.labels)
    assert _key(labkit.detect_legs(scan)) == _key(f.legs)
    assert len(labkit.pair_legs(labkit.detect_legs(scan))) == len(f.people)
    assert _key(labkit.detect_circles(scan, segments=_mask(f.labels, f.legs))) == _key(f.circles)
    alone = labkit.extract_features(scan, labkit.Config.from_dict({"legs": {"enabled": False}}))
    assert _key(labkit.detect_circles(scan)) == _key(alone.circles)


@pytest.mark.parametrize("method", list(LINE_EXTRACTORS))
def test_every_line_method_alone_is_the_stage(method):
    fn = LINE_EXTRACTORS[method].fn
    fixed = dict(LINE_EXTRACTORS[method].fixed)
    for scan in SCANS:
        # nothing taken by legs and circles: the function alone on the whole scan
        f = labkit.extract_features(scan, labkit.Config.from_dict({**OFF, "lines": {"method": method}}))
        assert _key(fn(scan, **fixed)) == _key(f.lines), method
        # the default pipeline: the function given the segments the round detectors left
        f = labkit.extract_features(scan, labkit.Config.from_dict({"lines": {"method": method}}))
        rest = _mask(_mask(f.labels, f.legs), f.circles)
        if LINE_EXTRACTORS[method].segmented:
            segments = rest
        else:
            round_beams = (f.labels >= 0) & (rest < 0)
            segments = np.where(scan.valid & ~round_beams, 0, -1) if (f.legs or f.circles) else None
        assert _key(fn(scan, segments=segments, **fixed)) == _key(f.lines), method


def test_corners_and_arcs_alone_are_the_stages():
    cfg = labkit.Config.from_dict({"arcs": {"enabled": True}})
    for scan in SCANS:
        f = labkit.extract_features(scan, cfg)
        assert _key(labkit.find_corners(list(f.lines), wrap=scan.is_full_circle)) == _key(f.corners)
        rest = _mask(_mask(f.labels, f.legs), f.circles)
        assert _key(labkit.detect_arcs(scan, segments=rest)) == _key(f.arcs)
        alone = labkit.extract_features(scan, labkit.Config.from_dict({**OFF, "arcs": {"enabled": True}}))
        assert _key(labkit.detect_arcs(scan)) == _key(alone.arcs)


def test_a_config_section_is_its_detectors_record():
    cfg = labkit.Config()
    assert isinstance(cfg.segmentation, labkit.SegmentationParams)
    assert cfg.segmentation.to_dict() == labkit.SegmentationParams().to_dict()
    assert isinstance(cfg.lines.ransac, labkit.RansacParams)
    # a non-default value reaches the detector the same way alone and in the pipeline
    scan = SCANS[0]
    cfg = cfg.updated({"lines.split_threshold_m": 0.02, "circles.min_points": 6})
    f = labkit.extract_features(scan, cfg)
    rest = _mask(_mask(f.labels, f.legs), f.circles)
    assert _key(labkit.split_and_merge(scan, **cfg.lines.kwargs(), segments=rest)) == _key(f.lines)
    assert _key(labkit.split_and_merge(scan, split_threshold_m=0.02, segments=_mask(_mask(f.labels, f.legs),
                                                                                    f.circles))) == _key(f.lines)
