"""The documentation's sources: every public name has a family page, and its docstring passes numpydoc.

numpydoc's validation (``numpydoc.validate``) runs on every public name (docs/public_api.py says which
are public and which checks are left out, and why). The findings not yet fixed are listed, one per line,
in docs/numpydoc_todo.txt: a finding that is not on the list (a new function without its Returns, a
parameter renamed but not its documentation) fails, and so does an entry of the list that is fixed
(take it off: the list only shrinks). The build of the site and its pages in a browser are
tests/test_docs_site.py.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import nbformat
import pytest

from docs import executed_notebooks, public_api

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def findings() -> set[str]:
    return {f"{name}: {code}" for name, code, _message in public_api.findings()}


def test_every_public_module_has_a_family():
    orphans = [m for m in public_api.public_modules() if m != "labkit" and public_api.family_of(m) is None]
    assert not orphans, f"public modules without a family in docs/public_api.py FAMILIES: {orphans}"


def test_every_top_level_name_is_documented_at_its_home():
    """``labkit.X`` for every X of ``labkit.__all__`` is the object of a public name of the reference
    (or a public module), so the page of labkit's own names links each to a page."""
    import labkit

    documented = {id(p.obj) for p in public_api.public_names()}
    missing = [attr for attr in labkit.__all__ if not attr.startswith("__")
               and type(getattr(labkit, attr)).__name__ != "module" and id(getattr(labkit, attr)) not in documented]
    assert not missing, f"names of labkit.__all__ without a page in the API reference: {missing}"


def test_a_public_name_is_listed_once_at_its_home():
    names = [p.name for p in public_api.public_names()]
    assert len(names) == len(set(names))
    segment_labels = [p for p in public_api.public_names() if p.obj is importlib.import_module("labkit").segment_labels]
    assert [p.name for p in segment_labels] == ["labkit.segmentation.segment_labels"]
    assert segment_labels[0].family == "segmentation"


def test_numpydoc_finds_nothing_new(findings):
    new = sorted(findings - public_api.todo())
    assert not new, ("numpydoc findings on public docstrings (fix the docstring; `python -m docs.public_api` shows "
                     "the messages):\n" + "\n".join(new))


def test_numpydoc_todo_list_only_shrinks(findings):
    fixed = sorted(public_api.todo() - findings)
    assert not fixed, "fixed, so take them off docs/numpydoc_todo.txt:\n" + "\n".join(fixed)


def test_validation_catches_a_missing_parameter(monkeypatch):
    """The check itself fails a docstring that leaves a parameter out and has no Returns."""
    import labkit.geometry

    def wrap_twice(angle, period):
        """Wrap an angle twice.

        Parameters
        ----------
        angle : float
            Radians.
        """
        return angle

    wrap_twice.__module__ = "labkit.geometry"
    monkeypatch.setattr(labkit.geometry, "wrap_twice", wrap_twice, raising=False)
    found = public_api.findings([public_api.PublicName("labkit.geometry.wrap_twice", wrap_twice, "scan_io")])
    assert {code for _name, code, _msg in found} == {"PR01", "RT01"}


def test_executed_copy_is_keyed_on_the_notebook_source(tmp_path, monkeypatch):
    """An edited notebook has another key, so the docs never render outputs of an older version."""
    monkeypatch.setattr(executed_notebooks, "STORE", tmp_path / "store")
    source = tmp_path / "07_x.ipynb"
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("1 + 1")])
    nbformat.write(nb, source)
    first = executed_notebooks.keep(source, nb)
    assert first == executed_notebooks.stored(source) and first.is_file()
    nb.cells.append(nbformat.v4.new_code_cell("2 + 2"))
    nbformat.write(nb, source)
    assert not executed_notebooks.stored(source).is_file()
    second = executed_notebooks.keep(source, nb)
    assert second != first and not first.exists(), "the copy of the older version is replaced"
