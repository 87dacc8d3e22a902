"""One registry of line extractors (issue 14): a toy extractor registered once is seen by the
pipeline's Config, extract_features, the CLI's extract/evaluate --method, the experiments and
the contract suite; and every registered extractor run through the registry gives what its
function gives with its documented defaults."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np
import pytest

import labkit
from labkit import sim
from labkit.app import experiments
from labkit.app.cli import build_parser
from labkit.lines import LINE_EXTRACTORS, Params, register, unregister


@dataclass(frozen=True)
class ToyParams(Params):
    """One line through the first and last valid beam of every segment (metres)."""

    min_length_m: float = 0.5


def toy_lines(scan, *, segments=None, min_length_m=0.5):
    """A line through the points of each range segment, kept when longer than min_length_m."""
    labels = labkit.segment_labels(scan) if segments is None else segments
    out = []
    for lab in np.unique(labels[labels >= 0]):
        idx = np.flatnonzero(labels == lab)
        if idx.size >= 3:
            line = labkit.line_segment(scan.points[idx], idx)
            if line.length >= min_length_m:
                out.append(line)
    return out


@pytest.fixture
def toy():
    entry = register("toy", toy_lines, ToyParams, "a toy: one line per segment", label="toy lines")
    yield entry
    unregister("toy")


def _wall_scan():
    world = sim.World("wall", walls=(sim.Wall((3.0, -5.0), (3.0, 5.0)),))
    return sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))


def test_a_registered_extractor_is_seen_everywhere(toy):
    scan, truth = _wall_scan()
    cfg = labkit.Config.from_dict({"lines": {"method": "toy"}})  # Config validation reads the registry
    f = labkit.extract_features(scan, cfg)  # the pipeline runs it
    (line,) = f.lines
    (wall,) = truth.walls
    assert line.r == pytest.approx(wall.r, abs=1e-3) and abs(labkit.angle_difference(line.alpha, wall.alpha)) < 1e-3
    parser = build_parser()
    assert parser.parse_args(["extract", "in.bag", "--method", "toy"]).method == "toy"
    assert parser.parse_args(["evaluate", "--method", "toy"]).method == ["toy"]
    assert "toy lines" in experiments.LINE_EXTRACTORS  # the experiments compare it, by its label
    rows = experiments.compare_lines([experiments.SimScan("wall", 0.0, scan, truth)],
                                     {k: experiments.LINE_EXTRACTORS[k] for k in ["toy lines"]})
    assert rows[0]["method"] == "toy lines" and rows[0]["lines_per_scan"] == 1
    assert toy.run(scan, min_length_m=100.0) == []  # overrides are fields of the record
    with pytest.raises(TypeError, match="'min_length'"):
        toy.run(scan, min_length=1.0)


def test_unregistered_names_are_refused():
    with pytest.raises(ValueError, match="lines.method"):
        labkit.Config.from_dict({"lines": {"method": "toy"}})
    with pytest.raises(SystemExit):
        build_parser().parse_args(["extract", "in.bag", "--method", "toy"])
    with pytest.raises(ValueError, match="already registered"):
        register("iepf", toy_lines, ToyParams, "again")


def test_the_contract_suite_keeps_a_registered_extractor_to_the_common_contract(toy):
    from tests import test_line_extractors as contract

    contract.test_every_registered_extractor_keeps_the_common_contract("toy")


def test_the_contract_suite_reads_the_registry():
    from tests import test_line_extractors as contract

    assert all(name in LINE_EXTRACTORS for name in contract.CONTRACT)
    assert contract.EXTRACTORS == [LINE_EXTRACTORS[n].fn for n in contract.CONTRACT]


#: what each registry name ran as before the registry (issue 14: no behaviour change)
BEFORE = {
    "iepf": labkit.split_and_merge,
    "split_and_merge": partial(labkit.split_and_merge, method="fit"),
    "incremental": labkit.incremental_lines,
    "regression": labkit.regression_lines,
    "ransac": labkit.ransac_lines,
    "hough": labkit.hough_lines,
    "angular": partial(labkit.angular_segmentation, split_gap_m=0.3),  # as experiments ran it
    "iav": labkit.detect_lines_iav,
}


@pytest.mark.parametrize("name", list(BEFORE))
@pytest.mark.parametrize("world", ["hall", "corridor", "office"])
def test_every_registered_extractor_gives_what_its_function_gives(name, world):
    scan, _ = sim.scan_at(sim.make_world(world), sim.LIDARS["lms200"], (1.0, 0.5, 0.3), 2.0,
                          rng=np.random.default_rng(1))
    got = [(ln.r, ln.alpha, ln.first, ln.last) for ln in LINE_EXTRACTORS[name].run(scan)]
    want = [(ln.r, ln.alpha, ln.first, ln.last) for ln in BEFORE[name](scan)]
    assert got == want


@pytest.mark.parametrize("name", list(BEFORE))
def test_every_registered_extractor_runs_in_the_pipeline(name):
    scan, truth = sim.scan_at(sim.make_world("hall"), sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    f = labkit.extract_features(scan, labkit.Config.from_dict({"lines": {"method": name}}))
    assert len(f.lines) > 0
    assert all(-math.pi < ln.alpha <= math.pi for ln in f.lines)


def test_one_label_per_name():
    labels = [e.label for e in LINE_EXTRACTORS.values()]
    assert len(set(labels)) == len(labels) == len(LINE_EXTRACTORS)
