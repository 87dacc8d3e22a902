"""Reading notebooks as plain JSON (submissions are untrusted), and building the autograded notebook.

A submission is only ever *read* here: :func:`read_notebook` parses its JSON (nothing in it runs
in the grader), checks the nbformat 4 shape and caps its size. :func:`student_cells` picks the
code the worker runs: every code cell except the test cells, recognised by the grade ids of the
source notebook's test cells *and* by their text, so that a pasted copy without metadata, a
duplicated grade id or a cell with deleted metadata is still dropped. :func:`autograded_notebook`
writes what ``nbgrader generate_feedback`` and the formgrader read: the student's own cells with
their outputs cleared, the instructor's copy of every test cell (once, with the grader's verdict as
its output), and nbgrader metadata only where the gradebook knows the grade id.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

from .protocol import clean_text

__all__ = [
    "MAX_NOTEBOOK_BYTES",
    "InvalidNotebook",
    "read_notebook",
    "cell_source",
    "grade_id",
    "same_code",
    "student_cells",
    "autograded_notebook",
]

#: Larger submissions are refused as invalid notebooks (outputs count: a notebook full of plots is big).
MAX_NOTEBOOK_BYTES = 100 << 20
#: More JSON lists and objects than this make a notebook invalid: a real notebook has a few per cell and
#: output, and millions would cost the grader seconds to walk.
MAX_NOTEBOOK_CONTAINERS = 200_000
#: More JSON strings than this (counted by their quotes, before anything is parsed) make a notebook invalid:
#: 100 MB of ``"ab",`` are 20 million strings, which ``json.loads`` turned into 3.6 GB of Python objects.
#: A real notebook has a string per line of code, markdown and printed output: tens of thousands.
MAX_NOTEBOOK_STRINGS = 1_000_000
#: The parts of a notebook the grader keeps (every cell's type, source, metadata and id, the notebook's
#: metadata) may take this many bytes together; outputs and attachments are skipped, never built.
MAX_KEPT_BYTES = 32 << 20
_STRUCTURE = re.compile(rb'["{}\[\]]')  # the next character that opens or closes a string, list or object
_SPACE = re.compile(rb"[ \t\r\n]*")
_SCALAR = re.compile(rb"[^,}\]\s]*")
#: More student code than this (all code cells together) is refused.
MAX_CODE_CHARS = 2 << 20
_CELL_ID = re.compile(r"^[a-zA-Z0-9_-]{1,64}$")
_CELL_KEYS = frozenset({b'"cell_type"', b'"source"', b'"metadata"', b'"id"'})
_NOTEBOOK_KEYS = frozenset({b'"cells"', b'"metadata"', b'"nbformat"', b'"nbformat_minor"'})


class InvalidNotebook(ValueError):
    """A file that is not a readable Jupyter notebook (nbformat 4)."""


class _Reader:
    """A bounded reader of a notebook's JSON bytes: it walks the structure, builds only the values the grader
    keeps (with ``json.loads`` on their bytes) and skips the others -- outputs, attachments -- without making
    a Python object of them. Memory: the file's bytes and the kept values; time: one step per string, list
    and object of the skipped values (at most ``MAX_NOTEBOOK_STRINGS`` and ``MAX_NOTEBOOK_CONTAINERS``)."""

    def __init__(self, raw: bytes) -> None:
        self.raw = raw
        self.containers = 0
        self.kept = 0

    def fail(self, what: str, at: int) -> InvalidNotebook:
        return InvalidNotebook(f"the notebook cannot be read as JSON: {what} at byte {at}")

    def space(self, at: int) -> int:
        found = _SPACE.match(self.raw, at)
        assert found is not None, "_SPACE matches the empty string too"
        return found.end()

    def expect(self, at: int, char: bytes) -> int:
        at = self.space(at)
        if self.raw[at:at + 1] != char:
            raise self.fail(f"expected {char.decode()}", at)
        return at + 1

    def count(self, at: int) -> None:
        self.containers += 1
        if self.containers > MAX_NOTEBOOK_CONTAINERS:
            raise InvalidNotebook(f"the notebook holds more than {MAX_NOTEBOOK_CONTAINERS} JSON lists and objects")

    def string_end(self, at: int) -> int:
        """The end of the string whose opening quote is at ``at`` (found with ``bytes.find``: a regex walks a
        40 MB plot's base64 a character at a time)."""
        raw, start = self.raw, at
        while True:
            at = raw.find(b'"', at + 1)
            if at < 0:
                raise self.fail("an unterminated string", start)
            backslashes = 0
            while raw[at - 1 - backslashes] == 0x5C:  # \" is an escaped quote, \\" a backslash and the end
                backslashes += 1
            if backslashes % 2 == 0:
                return at + 1

    def skip(self, at: int) -> int:
        """The end of the JSON value that starts at ``at`` (after white space)."""
        at = self.space(at)
        first = self.raw[at:at + 1]
        if first == b'"':
            return self.string_end(at)
        if first not in (b"{", b"["):  # a number, true, false or null: up to the next delimiter
            scalar = _SCALAR.match(self.raw, at)
            assert scalar is not None, "_SCALAR matches the empty string too"
            end = scalar.end()
            if end == at:
                raise self.fail("a missing value", at)
            return end
        depth = 0
        while True:
            found = _STRUCTURE.search(self.raw, at)
            if found is None:
                raise self.fail("an unclosed list or object", at)
            char, at = found.group(), found.start()
            if char == b'"':
                at = self.string_end(at)
                continue
            at += 1
            if char in (b"{", b"["):
                depth += 1
                self.count(at)
            else:
                depth -= 1
                if depth == 0:
                    return at

    def value(self, at: int) -> tuple[object, int]:
        """The JSON value at ``at``, built, and its end."""
        start = self.space(at)
        end = self.skip(start)
        self.kept += end - start
        if self.kept > MAX_KEPT_BYTES:
            raise InvalidNotebook(f"the notebook's cells and metadata (without outputs) take more than "
                                  f"{MAX_KEPT_BYTES >> 20} MB")
        return json.loads(self.raw[start:end]), end

    def items(self, at: int):
        """Yield ``(key as raw JSON bytes, where its value starts)`` of the object at ``at``; the caller moves
        ``self.at`` past each value (:meth:`value` or :meth:`skip`)."""
        at = self.expect(at, b"{")
        self.count(at)
        at = self.space(at)
        if self.raw[at:at + 1] == b"}":
            self.at = at + 1
            return
        while True:
            at = self.space(at)
            end = self.string_end(at) if self.raw[at:at + 1] == b'"' else None
            if end is None:
                raise self.fail("expected a key", at)
            key = self.raw[at:end]
            self.at = self.expect(end, b":")
            yield key, self.at
            at = self.space(self.at)
            if self.raw[at:at + 1] == b"}":
                self.at = at + 1
                return
            at = self.expect(at, b",")

    def elements(self, at: int):
        """Yield where each element of the list at ``at`` starts; the caller moves ``self.at`` past it."""
        at = self.expect(at, b"[")
        self.count(at)
        at = self.space(at)
        if self.raw[at:at + 1] == b"]":
            self.at = at + 1
            return
        while True:
            self.at = at
            yield at
            at = self.space(self.at)
            if self.raw[at:at + 1] == b"]":
                self.at = at + 1
                return
            at = self.expect(at, b",")

    def keep(self, start: int, wanted: frozenset) -> dict:
        """The object at ``start`` with only the ``wanted`` keys built (the last of a repeated key wins)."""
        kept = {}
        for key, at in self.items(start):
            if key in wanted:
                kept[key.decode("utf-8")[1:-1]], self.at = self.value(at)
            else:
                self.at = self.skip(at)
        return kept

    def notebook(self) -> dict:
        top: dict = {}
        cells: list[dict | None] | str | None = None  # (a string: what the notebook's "cells" are instead)
        for key, at in self.items(0):
            if key == b'"cells"':
                if self.raw[self.space(at):self.space(at) + 1] != b"[":
                    cells, self.at = "not a list", self.skip(at)
                    continue
                cells = []
                for element in self.elements(at):
                    if self.raw[self.space(element):self.space(element) + 1] != b"{":
                        cells.append(None)
                        self.at = self.skip(element)
                    else:
                        cells.append(self.keep(element, _CELL_KEYS))
            elif key in _NOTEBOOK_KEYS:
                top[key.decode()[1:-1]], self.at = self.value(at)
            else:
                self.at = self.skip(at)
        if self.space(self.at) != len(self.raw):
            raise self.fail("extra data after the notebook", self.space(self.at))
        if cells is not None:
            top["cells"] = cells
        return top


def _parse(raw: bytes) -> dict:
    """The parts of a notebook the grader uses, read within bounds (see :class:`_Reader`)."""
    quotes = raw.count(b'"') - raw.count(b'\\"')
    if quotes > 2 * MAX_NOTEBOOK_STRINGS:
        raise InvalidNotebook(f"the notebook holds more than {MAX_NOTEBOOK_STRINGS} JSON strings")
    return _Reader(raw).notebook()


def read_notebook(path: Path, *, inside: Path | None = None) -> dict:
    """A notebook's JSON, checked to have the nbformat 4 shape the grader relies on.

    Every cell comes back with ``cell_type``, ``source`` (one string) and ``metadata`` (a dict); outputs
    and attachments are not read. With ``inside``, the file must be a regular file under that folder,
    reached without a symbolic link (a submission must not point at another student's notebook or a file
    of yours).

    Before anything is built, the file's size (:data:`MAX_NOTEBOOK_BYTES`) and its number of strings
    (``MAX_NOTEBOOK_STRINGS``) are checked; while it is read, its lists and objects
    (``MAX_NOTEBOOK_CONTAINERS``) and the bytes of what is kept (``MAX_KEPT_BYTES``). So reading
    one holds at most the file's bytes and 32 MB of cells in memory, however it is built.

    Parameters
    ----------
    path : Path
        The notebook file.
    inside : Path or None
        The folder the file must be in (a regular file, reached without a symbolic link); None:
        anywhere.

    Returns
    -------
    dict
        The notebook's JSON, its cells in the shape above.

    Raises
    ------
    InvalidNotebook
        Too large, not UTF-8 JSON, not nbformat 4, cells of the wrong shape, or outside ``inside``.
    """
    path = Path(path)
    if inside is not None and (path.is_symlink() or not path.resolve().is_relative_to(Path(inside).resolve())
                               or path.resolve() != path.absolute()):
        raise InvalidNotebook("the notebook is a symbolic link: hand in the file itself")
    try:
        size = path.stat().st_size
        if size > MAX_NOTEBOOK_BYTES:
            raise InvalidNotebook(f"the notebook is {size / 1e6:.0f} MB, more than the "
                                  f"{MAX_NOTEBOOK_BYTES / 1e6:.0f} MB allowed (clear its outputs)")
        with open(path, "rb") as f:
            raw = f.read(MAX_NOTEBOOK_BYTES + 1)
        if len(raw) > MAX_NOTEBOOK_BYTES:
            raise InvalidNotebook(f"the notebook is more than the {MAX_NOTEBOOK_BYTES / 1e6:.0f} MB allowed")
        data = _parse(raw)
    except InvalidNotebook:
        raise
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as error:
        raise InvalidNotebook(f"the notebook cannot be read as JSON: {str(error)[:200]}") from None
    if type(data) is not dict or data.get("nbformat") != 4 or type(data.get("cells")) is not list:
        raise InvalidNotebook("the file is not a Jupyter notebook in nbformat 4")
    cells = []
    for index, cell in enumerate(data["cells"]):
        if type(cell) is not dict or cell.get("cell_type") not in ("code", "markdown", "raw"):
            raise InvalidNotebook(f"cell {index} is not a notebook cell")
        source = cell.get("source", "")
        if type(source) is list and all(type(line) is str for line in source):
            source = "".join(source)
        if type(source) is not str:
            raise InvalidNotebook(f"cell {index} has a source that is not text")
        metadata = cell.get("metadata", {})
        cell_id = cell.get("id")
        cells.append({"cell_type": cell["cell_type"], "source": clean_text(source),
                      "metadata": metadata if type(metadata) is dict else {},
                      **({"id": clean_text(cell_id)} if type(cell_id) is str else {})})
    if sum(len(c["source"]) for c in cells if c["cell_type"] == "code") > MAX_CODE_CHARS:
        raise InvalidNotebook(f"the notebook holds more than {MAX_CODE_CHARS} characters of code")
    metadata, minor = data.get("metadata"), data.get("nbformat_minor")
    return {"nbformat": 4, "nbformat_minor": minor if type(minor) is int else 5, "cells": cells,
            "metadata": metadata if type(metadata) is dict else {}}


def cell_source(cell: dict) -> str:
    """The source of a notebook cell as one string (nbformat stores it as a string or a list of lines).

    Parameters
    ----------
    cell : dict
        The cell.

    Returns
    -------
    str
        Its source.
    """
    source = cell.get("source", "")
    return "".join(source) if isinstance(source, list) else source


def nbgrader_metadata(cell: dict) -> dict:
    meta = cell.get("metadata", {}).get("nbgrader")
    return meta if type(meta) is dict else {}


def grade_id(cell: dict) -> str | None:
    """The nbgrader ``grade_id`` of a cell, or None when it has none (or one that is not a string).

    Parameters
    ----------
    cell : dict
        The cell.

    Returns
    -------
    str or None
        Its grade id.
    """
    value = nbgrader_metadata(cell).get("grade_id")
    return value if type(value) is str else None


def _words(source: str) -> str:
    return " ".join(source.split())


def same_code(a: str, b: str) -> bool:
    """True when two cells hold the same code up to whitespace.

    Parameters
    ----------
    a : str
        One cell's source.
    b : str
        The other's.

    Returns
    -------
    bool
        Whether they are the same code.
    """
    return _words(a) == _words(b)


def student_cells(notebook: dict, test_cells: dict[str, str]) -> list[str]:
    """The code the worker runs: the notebook's code cells, in order, without its test cells.

    A cell is a test cell when its grade id is one of ``test_cells`` or when its text is one of
    theirs (up to whitespace).

    Parameters
    ----------
    notebook : dict
        The submitted notebook (:func:`read_notebook`'s).
    test_cells : dict of str to str
        Grade id -> the source notebook's text of every test cell.

    Returns
    -------
    list of str
        The sources of the cells to run.
    """
    texts = {_words(text) for text in test_cells.values()}
    return [
        cell["source"]
        for cell in notebook["cells"]
        if cell["cell_type"] == "code" and grade_id(cell) not in test_cells and _words(cell["source"]) not in texts
    ]


def _test_cell_of(cell: dict, test_cells: dict[str, str]) -> str | None:
    if cell["cell_type"] != "code":
        return None
    gid = grade_id(cell)
    if gid in test_cells:
        return gid
    words = _words(cell["source"])
    return next((name for name, text in test_cells.items() if _words(text) == words), None)


def autograded_notebook(
    submission: dict | None, release: dict, test_cells: dict[str, str], outputs: dict[str, list[dict]]
) -> dict:
    """The notebook nbgrader's feedback and formgrader show for one graded submission.

    Parameters
    ----------
    submission : dict or None
        The student's notebook as :func:`read_notebook` returned it; None when it could not be read
        (the release is shown instead).
    release : dict
        The release notebook (trusted): its test cells, locked cells and metadata are the instructor's.
    test_cells : dict
        Grade id -> source text of every test cell.
    outputs : dict
        Grade id -> the nbformat outputs to show under that graded cell.

    Returns
    -------
    dict
        The autograded notebook (nbformat 4).
    """
    release_cells = {grade_id(c): c for c in release["cells"] if grade_id(c) is not None}
    cells, seen = [], set()
    for cell in (submission or release)["cells"]:
        test = _test_cell_of(cell, test_cells)
        if test is not None or (cell["cell_type"] == "markdown" and grade_id(cell) in release_cells
                                and release_cells[grade_id(cell)]["cell_type"] == "markdown"):
            gid = test or grade_id(cell)  # a test cell or the instructor's text: the instructor's copy, once
            if gid not in seen:
                cells.append(copy.deepcopy(release_cells[gid]))
            seen.add(gid)
            continue
        gid = grade_id(cell)
        kept = {"cell_type": cell["cell_type"], "metadata": {}, "source": cell["source"]}
        if cell["cell_type"] != "code":  # the student's text, shown as text: no HTML of theirs reaches a browser
            kept = {"cell_type": "markdown", "metadata": {}, "source": _as_text(cell["source"])}
        elif gid in release_cells and release_cells[gid]["cell_type"] == "code" and gid not in seen:
            kept["metadata"] = copy.deepcopy(release_cells[gid]["metadata"])  # an answer, or a locked cell the
            seen.add(gid)  # student changed: shown as it ran
        if "id" in cell:
            kept["id"] = cell["id"]
        cells.append(kept)
    cells += [copy.deepcopy(c) for gid, c in release_cells.items() if gid not in seen]
    used: set[str] = set()
    for index, cell in enumerate(cells):
        cell_id = cell.get("id")
        if type(cell_id) is not str or not _CELL_ID.match(cell_id) or cell_id in used:
            cell["id"] = f"cell-{index}"
            while cell["id"] in used:
                cell["id"] += "x"
        used.add(cell["id"])
        if cell["cell_type"] == "code":
            gid = grade_id(cell)
            cell["outputs"] = copy.deepcopy(outputs.get(gid, []) if gid is not None else [])
            cell["execution_count"] = None
        else:
            cell.pop("outputs", None)
            cell.pop("execution_count", None)
            cell.pop("attachments", None)
    return {"cells": cells, "metadata": copy.deepcopy(release["metadata"]), "nbformat": 4,
            "nbformat_minor": release.get("nbformat_minor", 5)}


def _as_text(source: str) -> str:
    """Markdown that shows ``source`` verbatim, as a fenced block (so any HTML in it is only text)."""
    longest = max((len(run) for run in re.findall(r"`+", source)), default=0)
    fence = "`" * max(3, longest + 1)
    return f"{fence}text\n{source}\n{fence}"


def write_notebook_text(notebook: dict) -> str:
    return json.dumps(notebook, indent=1, ensure_ascii=False) + "\n"


def stream(text: str) -> dict:
    return {"output_type": "stream", "name": "stdout", "text": text}


def error(name: str, message: str, traceback: list[str] | None = None) -> dict:
    return {"output_type": "error", "ename": name, "evalue": message, "traceback": traceback or [f"{name}: {message}"]}


def code_of(notebook: dict, kinds: Any = ("code",)) -> list[dict]:
    return [cell for cell in notebook["cells"] if cell["cell_type"] in kinds]
