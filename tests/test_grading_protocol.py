"""The wire format between the grader and the student's worker (:mod:`labkit.grading.protocol`).

What the trusted side decodes is built from scratch out of plain JSON: exact built-in types and
plain ndarrays of numeric dtypes, never an object of the student's. Every way to smuggle
something else (a subclass, an object array, a wrong size, deep nesting, a huge frame, an
unknown exception class) is tried and refused.
"""

from __future__ import annotations

import base64
import json
import math

import numpy as np
import pytest

from labkit.grading.protocol import (
    HEADER,
    MAX_CONTAINERS,
    MAX_DEPTH,
    MAX_FRAME_BYTES,
    MAX_ITEMS,
    NUMERIC_DTYPES,
    ProtocolError,
    clean_text,
    decode,
    encode,
    exception_names,
    frame_length,
    pack,
    rebuild_exception,
    unpack,
)


def through(value):
    """``value`` sent over the wire and decoded on the trusted side."""
    return decode(unpack(pack({"value": encode(value)})[HEADER.size:])["value"])


@pytest.mark.parametrize("value", [
    None, True, False, 0, -7, 2**80, 1.5, -0.0, math.inf, -math.inf, "text", "", [], [1, [2.0, None]], (1, "a"),
    (), {"a": 1, "b": [1, 2]}, np.float64(0.1), np.int32(-3), np.bool_(True), np.complex128(1 + 2j),
    np.arange(6, dtype=np.int64).reshape(2, 3), np.zeros((0, 2)), np.array(3.5), np.array([True, False]),
    np.arange(4, dtype=np.uint8), np.linspace(0, 1, 5, dtype=np.float32),
])
def test_plain_values_cross_unchanged(value):
    got = through(value)
    assert type(got) is type(value)
    if isinstance(value, np.ndarray):
        assert got.dtype == value.dtype and got.shape == value.shape and np.array_equal(got, value)
        assert got.flags.writeable
    elif isinstance(value, np.generic):
        assert got.dtype == value.dtype and got == value
    else:
        assert got == value


def test_nan_crosses_as_a_float():
    got = through([math.nan, np.float64(math.nan)])
    assert type(got[0]) is float and math.isnan(got[0]) and math.isnan(got[1])


def test_an_ndarray_subclass_arrives_as_a_plain_array():
    class Equal(np.ndarray):
        def __eq__(self, other):
            return True

    got = through(np.zeros(3, dtype=np.int64).view(Equal))
    assert type(got) is np.ndarray
    assert not np.array_equal(got, [1, 2, 3])


def test_subclasses_of_builtins_arrive_as_their_base_type():
    class Liar(float):
        def __eq__(self, other):
            return True

    class Text(str):
        pass

    got = through((Liar(1.0), Text("x")))
    assert type(got[0]) is float and got[0] != 2.0 and type(got[1]) is str


def test_byte_order_is_made_native():
    got = through(np.arange(3, dtype=">f8"))
    assert got.dtype == np.dtype("<f8") and got.tolist() == [0.0, 1.0, 2.0]


@pytest.mark.parametrize("value", [
    np.array([object()]), np.array(["a"]), {1: "non-str key"}, {1, 2}, object(), b"bytes", lambda: 0,
    np.datetime64("2025-01-01"), (x for x in ()),
])
def test_other_objects_cannot_be_sent(value):
    with pytest.raises(TypeError):
        encode(value)


def test_recursive_and_deep_values_cannot_be_sent():
    loop = []
    loop.append(loop)
    with pytest.raises(TypeError, match="nest"):
        encode(loop)


def array(dtype: str, shape: list, raw: bytes) -> dict:
    return {"A": dtype, "s": shape, "b": base64.b64encode(raw).decode()}


@pytest.mark.parametrize(("data", "match"), [
    (array("|O", [1], b"\0" * 8), "not a numeric dtype"),
    (array("<U1", [1], b"a\0\0\0"), "not a numeric dtype"),
    (array(">f8", [1], b"\0" * 8), "not a numeric dtype"),
    (array("<f8", [2], b"\0" * 8), "does not hold"),
    (array("<f8", [-1], b""), "shape"),
    (array("<f8", [1.5], b"\0" * 8), "shape"),
    ({"A": "<f8", "s": [1], "b": "!!!!!!!!!!!="}, "base64"),
    ({"A": "<f8", "s": [1], "b": "AAAAAAAAAAA=", "extra": 1}, "unknown"),
    ({"S": "|O", "b": "AAAAAAAAAAA="}, "not a numeric dtype"),
    ({"T": "not a list"}, "unknown"),
    ({"D": [["k"]]}, "dict entry"),
    ({"D": [[1, 2]]}, "dict entry"),
    ({"X": 1}, "unknown"),
    ({}, "unknown"),
])
def test_malformed_values_are_refused(data, match):
    with pytest.raises(ProtocolError, match=match):
        decode(data)


def test_nesting_and_size_are_capped():
    deep = 0
    for _ in range(MAX_DEPTH + 2):
        deep = [deep]
    with pytest.raises(ProtocolError, match="nest"):
        decode(deep)
    with pytest.raises(ProtocolError, match="values in one message"):
        decode([0] * (1 << 21 + 1))


class ClaimsNoBytes(np.ndarray):
    nbytes = property(lambda self: 0)


def test_answers_too_big_for_a_frame_are_refused_before_they_are_copied():
    # 8 TB of zeros as a broadcast view: any copy (C order, tobytes, base64) would fail with MemoryError
    for huge in (np.broadcast_to(0.0, (10 ** 12,)), np.broadcast_to(0.0, (10 ** 12,)).view(ClaimsNoBytes)):
        with pytest.raises(TypeError, match="larger than"):
            encode(huge)
    with pytest.raises(TypeError, match="larger than"):  # each piece fits, together they do not
        encode([np.zeros(1 << 20)] * 2)
    with pytest.raises(TypeError, match="larger than"):
        encode({"k": "x" * (MAX_FRAME_BYTES + 1)})
    with pytest.raises(TypeError, match="values in one answer"):
        encode([0] * (MAX_ITEMS + 1))
    fits = np.arange(1 << 20, dtype=np.float64)  # 8 MB, 11.2 MB of base64: fits in one frame
    assert np.array_equal(decode(unpack(pack({"v": encode(fits)})[HEADER.size:])["v"]), fits)


def test_every_numeric_dtype_is_little_or_no_endian():
    assert all(name[0] in "<|" for name in NUMERIC_DTYPES)
    assert {np.dtype(name).kind for name in NUMERIC_DTYPES} == set("biufc")


def test_frames_are_capped_and_must_hold_an_object():
    with pytest.raises(ProtocolError, match="larger than"):
        frame_length(HEADER.pack(MAX_FRAME_BYTES + 1))
    assert frame_length(HEADER.pack(12)) == 12
    for body, match in [(b"[1, 2]", "JSON object"), (b"\xff", "not JSON"), (b"{" * 100_000, "not JSON")]:
        with pytest.raises(ProtocolError, match=match):
            unpack(body)
    with pytest.raises(TypeError, match="bytes"):
        pack({"value": "x" * (MAX_FRAME_BYTES + 1)})
    assert json.loads(pack({"a": 1})[HEADER.size:]) == {"a": 1}


class StudentError(ValueError):
    pass


@pytest.mark.parametrize(("error", "expected"), [
    (StudentError("bad"), ValueError("bad")),
    (NotImplementedError(), NotImplementedError("")),
    (AssertionError("no"), AssertionError("no")),
    (UnicodeDecodeError("utf-8", b"x", 0, 1, "why"), None),
    (KeyboardInterrupt(), RuntimeError("KeyboardInterrupt: ")),
    (SystemExit(3), RuntimeError("SystemExit: 3")),
])
def test_an_exception_comes_back_as_its_first_builtin_class(error, expected):
    rebuilt = rebuild_exception(exception_names(error), str(error))
    if expected is None:
        assert type(rebuilt) is UnicodeError  # UnicodeDecodeError wants five arguments: its base class
    else:
        assert type(rebuilt) is type(expected) and str(rebuilt) == str(expected)


@pytest.mark.parametrize(("names", "message"), [("ValueError", "m"), ([1], "m"), (["ValueError"], 3)])
def test_malformed_exceptions_are_refused(names, message):
    with pytest.raises(ProtocolError):
        rebuild_exception(names, message)


def test_exception_messages_are_cut_and_unknown_names_are_runtime_errors():
    rebuilt = rebuild_exception(["NoSuchError", "Exception"], "x" * 10_000)
    assert type(rebuilt) is Exception and len(str(rebuilt)) == 4000
    assert type(rebuild_exception(["BaseExceptionGroup"], "m")) is RuntimeError


def test_a_frame_of_countless_containers_is_refused_before_it_is_parsed():
    body = b'{"id":1,"value":[' + b"{}," * (MAX_CONTAINERS + 1) + b"{}]}"
    assert len(body) < MAX_FRAME_BYTES  # it fits a frame, but would cost json.loads a lot of memory
    with pytest.raises(ProtocolError, match="lists and objects"):
        unpack(body)


@pytest.mark.parametrize("shape", [[0, 10**30], [0, 2**62, 2**62], [0] + [1 << 24] * 5, [0] * 40])
def test_absurd_shapes_are_protocol_errors(shape):
    with pytest.raises(ProtocolError):
        decode({"A": "<f8", "s": shape, "b": ""})


def test_text_that_no_file_can_hold_is_cleaned():
    """A lone surrogate is valid JSON and a valid Python str, but no UTF-8 file, CSV or database takes it."""
    assert decode(["ok", "half an emoji: \ud83d"]) == ["ok", "half an emoji: ?"]
    assert str(rebuild_exception(["ValueError"], "bad \udcff")) == "bad ?"
    assert clean_text("müller ✓") == "müller ✓"


# ---------------------------------------------------------------------------- notebooks, the other untrusted input
def _reference_cells(path):
    """A notebook's cells as json.loads reads them (the reader must agree on every honest notebook)."""
    from pathlib import Path

    data = json.loads(Path(path).read_text(encoding="utf-8"))
    return [{"cell_type": c["cell_type"], "source": "".join(c["source"]) if isinstance(c["source"], list)
             else c["source"], "metadata": c.get("metadata", {}), **({"id": c["id"]} if "id" in c else {})}
            for c in data["cells"]], data["metadata"]


def test_the_bounded_reader_reads_every_notebook_of_the_repository_as_json_does():
    from pathlib import Path

    from labkit.grading.notebook import read_notebook

    root = Path(__file__).resolve().parents[1]
    paths = sorted(root.glob("exercises/*/*/*.ipynb")) + sorted(root.glob("notebooks/*.ipynb"))
    assert len(paths) > 30
    for path in paths:
        notebook = read_notebook(path)
        assert (notebook["cells"], notebook["metadata"]) == _reference_cells(path), path


def test_outputs_are_skipped_whatever_they_hold(tmp_path):
    """Outputs and attachments are walked, never built: brackets and quotes inside their strings, escapes, other
    scripts and nesting do not change what is read."""
    from labkit.grading.notebook import read_notebook

    tricky = ['"]}{[', '\\', 'a\\"b', "\u00e9\U0001F600", "\n" * 3, "}" * 50]
    cells = [{"cell_type": "code", "id": "c1", "metadata": {"x": [1, {"y": '"'}]}, "source": ['a = "]"\n', "b = 2"],
              "execution_count": 3, "outputs": [{"output_type": "stream", "name": "stdout", "text": tricky},
                                                {"output_type": "display_data", "data": {"image/png": "iV" * 1000},
                                                 "metadata": {"deep": [[[[[[{}]]]]]]}}]},
             {"cell_type": "markdown", "metadata": {}, "source": "text", "attachments": {"a.png": {"x": tricky}}}]
    path = tmp_path / "tricky.ipynb"
    for indent in (None, 1):
        path.write_text(json.dumps({"nbformat": 4, "nbformat_minor": 5, "metadata": {"m": tricky}, "cells": cells},
                                   indent=indent, ensure_ascii=bool(indent)), encoding="utf-8")
        notebook = read_notebook(path)
        assert (notebook["cells"], notebook["metadata"]) == _reference_cells(path)
        assert "outputs" not in notebook["cells"][0] and "attachments" not in notebook["cells"][1]


@pytest.mark.parametrize(("content", "match"), [
    (b'{"nbformat": 4, "nbformat_minor": 5, "metadata": {}, "cells": [], "x": [' + b'"ab",' * 1_100_000 + b'"ab"]}',
     "more than 1000000 JSON strings"),  # the string bomb: 3.6 GB for json.loads at 100 MB, refused unparsed
    (b'{"nbformat": 4, "nbformat_minor": 5, "metadata": {"x": [' + b"{}," * 300_000 + b"{}]}, \"cells\": []}",
     "more than 200000 JSON lists and objects"),
    (b"", "expected {"), (b'{"cells": [', "missing value"), (b'{"a": 1,}', "expected a key"),
    (b'{"nbformat": 4, "cells": [], "metadata": {}} trailing', "extra data"),
    (b'{"nbformat": 4 "cells": []}', "expected ,"),
    (b'{"nbformat": 4, "cells": [{"cell_type": "code", "source": "\xff"}], "metadata": {}}', "cannot be read"),
    (b'{"nbformat": 3, "cells": [], "metadata": {}}', "nbformat 4"),
])
def test_notebooks_that_are_not_are_refused_before_they_cost_memory(tmp_path, content, match):
    from labkit.grading.notebook import InvalidNotebook, read_notebook

    path = tmp_path / "bad.ipynb"
    path.write_bytes(content)
    with pytest.raises(InvalidNotebook, match=match):
        read_notebook(path)


def test_student_text_loses_its_escapes_and_its_numbers():
    from labkit.grading.text import one_line, printable, without_numbers

    attack = "0/10\x1b[1A\x1b[2K10/10\x1b]0;title\x07\r\n\x00\x9b2J\u202eevil"
    assert printable(attack) == "0/1010/10\nevil"
    assert one_line(attack) == "0/1010/10 evil"
    assert printable("x" * 5000, 100) == "x" * 100 + " [...]"
    assert without_numbers("a scene at 1.2345, -0.5 and 1e-3; stamp 1700000000123; row 12") == \
        "a scene at #, # and #; stamp #; row 12"
