"""The file-format table (labkit.io.formats): a format registered from one module is read, counted,
written, converted and offered by the command line, and gone again once unregistered."""

from __future__ import annotations

import importlib
import sys
import textwrap

import numpy as np
import pytest

import labkit
from labkit.app import cli, parallel
from labkit.errors import RefusedError
from labkit.io import FORMATS, FileFormat, detect_format, read_scans, register_format, unregister_format

# The whole of a new format: one module, one register_format call (README, "Add a file format").
TOY_MODULE = textwrap.dedent('''
    """Toy scans: a header line, then one scan a line: stamp_ns, n, n ranges, n angles."""
    from labkit import Scan
    from labkit._safe import OutputKind, safe_output, starts_with
    from labkit.io import FileFormat, register_format

    HEADER = "# toyscan"
    TOY_FILE = OutputKind("a toy scans file (.toy)", (".toy",), starts_with(HEADER.encode()))

    def read_toy(stream):
        with open(stream.path, encoding="utf-8") as fh:
            if fh.readline().strip() != HEADER:
                raise ValueError(f"{stream.path} is not a toy scans file")
            for line in fh:
                v = line.split()
                n = int(v[1])
                yield Scan(ranges=[float(x) for x in v[2:2 + n]], angles=[float(x) for x in v[2 + n:]],
                           stamp_ns=int(v[0]))

    def count_toy(path):
        with open(path, encoding="utf-8") as fh:
            return sum(1 for _ in fh) - 1

    def write_toy(scans, path, *, topic="/scan", overwrite=False, inputs=()):
        n = 0
        with safe_output(path, TOY_FILE, overwrite=overwrite, inputs=inputs) as tmp, \\
                open(tmp, "w", encoding="utf-8") as fh:
            fh.write(HEADER + "\\n")
            for s in scans:
                values = [repr(float(x)) for x in (*s.ranges, *s.angles)]
                fh.write(" ".join([str(s.stamp_ns), str(s.n_beams), *values]) + "\\n")
                n += 1
        return n

    register_format(FileFormat("toy", (".toy",), "toy scans, one per line (.toy)", read=read_toy,
                               count=count_toy, write=write_toy, output_kind=TOY_FILE))
''')

# Two scans written by hand: the truth the reader must return.
TOY_TEXT = "# toyscan\n5 3 1.0 nan 2.5 -0.5 0.0 0.5\n7 2 inf 4.0 0.0 0.25\n"


@pytest.fixture
def toy(tmp_path, monkeypatch):
    (tmp_path / "mods").mkdir()
    (tmp_path / "mods" / "toyfmt_for_test.py").write_text(TOY_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path / "mods"))
    try:
        yield importlib.import_module("toyfmt_for_test")
    finally:
        FORMATS.pop("toy", None)
        sys.modules.pop("toyfmt_for_test", None)


def test_toy_format_is_read_counted_written_and_converted(toy, tmp_path):
    assert "toy" in FORMATS and "toy" in labkit.io.writable_formats()
    src = tmp_path / "hand.toy"
    src.write_text(TOY_TEXT)
    assert detect_format(src) == "toy"
    stream = read_scans(src)
    assert stream.format == "toy" and stream.count == 2 and len(stream) == 2
    scans = list(stream)
    assert [s.stamp_ns for s in scans] == [5, 7]
    np.testing.assert_array_equal(scans[0].ranges, [1.0, np.nan, 2.5])
    np.testing.assert_array_equal(scans[0].angles, [-0.5, 0.0, 0.5])
    np.testing.assert_array_equal(scans[1].ranges, [np.inf, 4.0])
    with pytest.raises(RefusedError, match="topic does not apply"):
        read_scans(src, topic="/scan")

    # simulated scans -> .toy -> .jsonl: every range, angle and stamp survives
    truth = [s for s, _ in labkit.sim.simulate("office", seed=3, n_scans=4)]
    assert labkit.write_scans(truth, tmp_path / "sim.toy") == 4
    assert read_scans(tmp_path / "sim.toy").count == 4
    assert labkit.convert(tmp_path / "sim.toy", tmp_path / "sim.jsonl") == 4
    back = list(read_scans(tmp_path / "sim.jsonl"))
    for a, b in zip(truth, back, strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
        np.testing.assert_array_equal(a.angles, b.angles)
        assert a.stamp_ns == b.stamp_ns
    # into a bag and back (stamps pass through the bag's checks), then back to .toy
    assert labkit.convert(tmp_path / "sim.toy", tmp_path / "sim.bag") == 4
    assert labkit.convert(tmp_path / "sim.bag", tmp_path / "again.toy") == 4
    again = list(read_scans(tmp_path / "again.toy"))
    np.testing.assert_array_equal(again[2].ranges, truth[2].ranges)
    # overwriting is for its own kind only
    with pytest.raises(RefusedError):
        labkit.convert(tmp_path / "sim.bag", tmp_path / "again.toy")
    assert labkit.convert(tmp_path / "sim.bag", tmp_path / "again.toy", overwrite=True) == 4
    # a folder given to extract picks .toy recordings up, and names their outputs without the suffix
    assert parallel.recordings_in([tmp_path]) == sorted([src, tmp_path / "sim.toy", tmp_path / "again.toy",
                                                         tmp_path / "sim.bag"])
    assert parallel.output_paths([src], tmp_path / "o")[0].name == "hand.features.jsonl"


def test_toy_format_in_the_command_line(toy, tmp_path, capsys):
    src = tmp_path / "hand.toy"
    src.write_text(TOY_TEXT)
    with pytest.raises(SystemExit) as exit_:
        cli.main(["convert", "-h"])
    assert exit_.value.code == 0
    help_text = " ".join(capsys.readouterr().out.split())
    assert ".toy" in help_text and "toy}" in help_text  # in the recordings listed and in --format's choices
    assert cli.main(["convert", "-q", str(src), str(tmp_path / "out.jsonl")]) == 0
    assert "wrote 2 scans" in capsys.readouterr().out
    assert cli.main(["convert", "-q", str(tmp_path / "out.jsonl"), str(tmp_path / "out.toy"), "--format", "toy"]) == 0
    capsys.readouterr()
    assert cli.main(["info", str(tmp_path / "out.toy")]) == 0
    out = capsys.readouterr().out
    assert "toy scans, one per line (.toy)" in out and "2 scans" in out

    unregister_format("toy")
    with pytest.raises(ValueError, match="supported formats") as err:
        detect_format(src)
    assert "toy:" not in str(err.value).split("supported formats")[1]
    assert cli.main(["info", str(src)]) == 2  # refused, as any unknown file
    with pytest.raises(SystemExit) as exit_:
        cli.main(["convert", str(tmp_path / "out.jsonl"), str(tmp_path / "x.toy"), "--format", "toy"])
    assert exit_.value.code == 2 and "invalid choice: 'toy'" in capsys.readouterr().err


def test_read_only_format_and_refused_registrations(tmp_path):
    def read(stream):
        return iter([])

    register_format(FileFormat("ro", (".ro",), "read-only test files (.ro)", read=read))
    try:
        (tmp_path / "a.ro").write_text("")
        assert list(read_scans(tmp_path / "a.ro")) == [] and read_scans(tmp_path / "a.ro").count is None
        with pytest.raises(RefusedError, match="labkit reads ro files but does not write them"):
            labkit.write_scans([], tmp_path / "b.ro")
        with pytest.raises(ValueError, match="writable formats"):
            labkit.write_scans([], tmp_path / "b.jsonl", format="ro")
        with pytest.raises(ValueError, match="exists"):
            register_format(FileFormat("ro", (".ro2",), "again", read=read))
        with pytest.raises(ValueError, match=r"\.bag already belong"):
            register_format(FileFormat("ro2", (".bag",), "steals .bag", read=read))
        with pytest.raises(ValueError, match="output_kind"):
            FileFormat("w", (".w",), "writes without a kind", read=read, write=lambda *a, **k: 0)
        with pytest.raises(ValueError, match="lower-case"):
            FileFormat("w", ("W",), "bad suffix", read=read)
    finally:
        unregister_format("ro")
    assert "ro" not in FORMATS and "ro2" not in FORMATS
    with pytest.raises(KeyError):
        unregister_format("ro")


def test_builtin_rows():
    """The table holds what the README promises, with the suffixes detect_format goes by."""
    assert list(FORMATS) == ["ros1", "ros2", "mcap", "carmen", "json", "jsonl"]
    assert labkit.io.writable_formats() == ("ros1", "ros2", "mcap", "json", "jsonl")
    assert FORMATS["carmen"].suffixes == (".log", ".log.gz", ".clf", ".clf.gz") and not FORMATS["carmen"].writable
    assert str(FORMATS["ros1"]) == "ROS1 bag (.bag)"  # FORMATS[name] still formats as its description
