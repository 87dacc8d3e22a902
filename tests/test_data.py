"""The bundled recordings: regenerated bit for bit, readable, with matching ground truth."""

from __future__ import annotations

import filecmp

import numpy as np
import pytest

from labkit import bundled_data, read_scans, sim
from labkit.app.data import BUNDLED, generate_bundled

from .conftest import DATA


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory):
    out = tmp_path_factory.mktemp("data")
    generate_bundled(out)
    return out


def _files(root):
    return sorted(p.relative_to(root) for p in root.rglob("*") if p.is_file())


def test_data_folder_is_exactly_what_the_simulator_writes(regenerated):
    assert _files(DATA) == _files(regenerated), "data/ holds files the generator does not make (or lacks some)"
    for rel in _files(DATA):
        assert filecmp.cmp(DATA / rel, regenerated / rel, shallow=False), (
            f"data/{rel} differs from a fresh `labkit simulate --bundled`: run `make data` and commit")


def test_data_is_small():
    total = sum(p.stat().st_size for p in DATA.rglob("*") if p.is_file())
    assert total < 8e6


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_every_scan_has_its_ground_truth(name):
    scenario, fmt, _ = BUNDLED[name]
    stream = read_scans(bundled_data(name))
    assert stream.format == fmt
    truth = sim.read_truth(bundled_data(name.split(".")[0] + ".truth.jsonl"))
    scans = list(stream)
    assert len(scans) == len(truth) == sim.scenario(scenario).n_scans
    for s in scans[::50]:
        tr = truth[s.stamp_ns]
        assert tr.hits.shape == (s.n_beams,)
        # beams that hit nothing read "no return" (or dropped out): never valid
        assert not s.valid[tr.hits < 0].any()


def test_bundled_data_finds_or_makes_files(tmp_path, monkeypatch):
    assert bundled_data("hall.bag") == DATA / "hall.bag"
    assert bundled_data("hall") == DATA / "hall.bag"
    assert bundled_data("office.truth.jsonl") == DATA / "office.truth.jsonl"
    with pytest.raises(ValueError, match="hall.bag"):
        bundled_data("atrium.bag")
    monkeypatch.setenv("LABKIT_DATA", str(tmp_path))
    path = bundled_data("office")  # not there: generated once
    assert path == tmp_path / "office" and (tmp_path / "office.truth.jsonl").exists()
    ref = list(read_scans(DATA / "office"))
    got = list(read_scans(path))
    assert all(np.array_equal(a.ranges, b.ranges, equal_nan=True) for a, b in zip(ref, got, strict=True))
