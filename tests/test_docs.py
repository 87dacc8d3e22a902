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
import os
import subprocess
import sys
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


def _make_docs_sphinx_options() -> list[str]:
    """The options ``make docs`` passes to Sphinx (the Makefile's ``SPHINX =`` line)."""
    line = next(line for line in (REPO / "Makefile").read_text(encoding="utf-8").splitlines()
                if line.startswith("SPHINX ="))
    words = line.split()
    return words[words.index("sphinx") + 1:]


TINY_CONF = """
import sys
sys.path.insert(0, {repo!r})
from docs import xref
extensions = ["sphinx.ext.autodoc", "numpydoc"]
nitpicky = xref.NITPICKY
nitpick_ignore_regex = xref.NITPICK_IGNORE_REGEX
numpydoc_xref_param_type = True
numpydoc_xref_aliases = {{"Thing": "tinymod.Thing"}}
numpydoc_xref_ignore = "all"
numpydoc_show_class_members = False
"""

TINY_MODULE = '''
class Thing:
    """A documented class."""


def helper(x):
    """The target of a good reference.

    Parameters
    ----------
    x : Thing
        A labkit-like class, linked by numpydoc's type aliases.

    Returns
    -------
    int
        A builtin type: numpydoc links it into Python's inventory, which the offline build lacks.
    """
    return 0


def user(values):
    """Uses :func:`helper`, :class:`numpy.ndarray`, :class:`ValueError` and :func:`tinymod.helper`.

    And one reference that goes nowhere: :func:`tinymod.not_there`.

    Parameters
    ----------
    values : list of Thing or None
        Words of a type that are not aliases stay text.
    """
'''


def test_a_broken_cross_reference_fails_make_docs(tmp_path):
    """``make docs`` is nitpicky and turns warnings into errors, with the ignore list of docs/xref.py:
    a small site built with the same options and settings fails on its one broken reference, and on
    nothing else (references to numpy, to builtins and numpydoc's links for ``int`` are let through;
    the labkit-like ones resolve)."""
    options = _make_docs_sphinx_options()
    assert "-n" in options and "-W" in options, f"make docs must build with -n -W: {options}"
    src = tmp_path / "src"
    src.mkdir()
    (src / "conf.py").write_text(TINY_CONF.format(repo=str(REPO)), encoding="utf-8")
    (src / "tinymod.py").write_text(TINY_MODULE, encoding="utf-8")
    (src / "index.rst").write_text("Tiny\n====\n\n.. automodule:: tinymod\n   :members:\n", encoding="utf-8")
    run = subprocess.run([sys.executable, "-m", "sphinx", *options, str(src), str(tmp_path / "html")],
                         cwd=src, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(src)})
    warnings = [line for line in run.stderr.splitlines() if "WARNING" in line or "ERROR" in line]
    assert run.returncode != 0, "a broken reference must fail the build"
    assert len(warnings) == 1 and "tinymod.not_there" in warnings[0], run.stderr[-3000:]


def test_docs_conf_takes_the_cross_reference_settings():
    """docs/conf.py is nitpicky with docs/xref.py's ignore list (also for builds that do not pass -n,
    such as tests/test_docs_site.py's)."""
    import ast

    tree = ast.parse((REPO / "docs" / "conf.py").read_text(encoding="utf-8"))
    assigned = {target.id: ast.unparse(node.value) for node in tree.body if isinstance(node, ast.Assign)
                for target in node.targets if isinstance(target, ast.Name)}
    assert assigned.get("nitpicky") == "xref.NITPICKY"
    assert assigned.get("nitpick_ignore_regex") == "xref.NITPICK_IGNORE_REGEX"
    from docs import xref

    assert xref.NITPICKY is True


def test_the_ignore_list_never_lets_a_labkit_name_through():
    """docs/xref.py lets other projects' names through, never labkit's own: its patterns are checked
    against labkit names, public or private, and against the outside names they are meant for."""
    import re

    from docs import xref

    def ignored(kind: str, target: str) -> bool:
        return any(re.fullmatch(k, kind) and re.fullmatch(t, target) for k, t in xref.NITPICK_IGNORE_REGEX)

    for target in ("labkit", "labkit.Scan", "labkit._safe.check_output", "labkit.sim.World.objects", "Scan",
                   "segment_labels", "STATUS", "CorruptFileError"):
        assert not ignored("py:func", target) and not ignored("py:class", target), target
    for kind, target in (("py:class", "numpy.ndarray"), ("py:class", "ValueError"), ("py:class", "python:int"),
                         ("std:ref", "python:bltin-boolean-values"), ("py:func", "json.loads"),
                         ("py:class", "rerun.RecordingStream"), ("py:class", "pathlib.Path")):
        assert ignored(kind, target), target


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
