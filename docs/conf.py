"""Sphinx configuration of labkit's documentation: ``make docs`` builds it into docs/_build/html.

Before Sphinx reads anything, :func:`prepare` writes ``docs/_generated/`` (git-ignored):

- ``api/<family>.rst``: one page per family of :data:`docs.public_api.FAMILIES`, an autosummary
  entry for every public name at its home module (so a new public name appears by itself);
- ``course/*.ipynb``: every ``notebooks/*.ipynb`` (by glob) with its outputs, taken from the copy
  the notebook tests kept (docs/executed_notebooks.py) or executed here when there is none;
- ``exercises/*.ipynb``: the student copies of the exercises (``exercises/release/``), never the
  instructor sources, so no solution reaches the site.
"""

from __future__ import annotations

import shutil
import sys
import time
from pathlib import Path

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
if str(REPO) not in sys.path:  # conf.py is run by sphinx-build, not imported from the repository
    sys.path.insert(0, str(REPO))

from numpydoc.xref import DEFAULT_LINKS as numpydoc_default_links  # noqa: E402

import labkit  # noqa: E402
from docs import executed_notebooks, public_api, xref  # noqa: E402

GENERATED = DOCS / "_generated"

project = "labkit"
author = "labkit developers"
copyright = "labkit developers"  # noqa: A001
release = version = labkit.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.intersphinx",
    "numpydoc",
    "myst_nb",
]

exclude_patterns = ["_build", "**/.ipynb_checkpoints", "__init__.py", "*.py"]
templates_path = ["_templates"]
html_static_path: list[str] = []

# autodoc + numpydoc: the docstrings are numpydoc; class members get their own autosummary lists
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": False}
autodoc_typehints = "none"  # the signature shows the annotations; numpydoc's sections the types
numpydoc_show_class_members = False
# every cross-reference must resolve but those to other projects' names (docs/xref.py says which, and why)
nitpicky = xref.NITPICKY
nitpick_ignore_regex = xref.NITPICK_IGNORE_REGEX
numpydoc_xref_param_type = True  # a parameter's type links to the page of the labkit class it names
# numpydoc links the common words of types (float, None, array_like) into the Python and NumPy inventories,
# which an offline build has not got: the links would show as "python:float". Each such word is its own
# alias here, so it stays plain text
numpydoc_xref_aliases = {**{word: word for word in numpydoc_default_links},
                         **xref.type_aliases(public_api.public_names())}
numpydoc_xref_ignore = "all"  # ... and nothing else: "list of", "optional", numpy's names stay text
numpydoc_class_members_toctree = False

# the notebooks: rendered with the outputs prepare() put in them, never executed by myst-nb
nb_execution_mode = "off"
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
# ipywidgets need a live kernel: prepare() turns a widget's output into a note, and the pages load no
# widget JavaScript from the internet
nb_ipywidgets_js: dict[str, dict[str, str]] = {}

intersphinx_mapping: dict[str, tuple[str, None]] = {}  # offline build: no inventories fetched

html_theme = "pydata_sphinx_theme"
html_title = f"labkit {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_last_updated_fmt = None
html_copy_source = False
html_show_sourcelink = False

suppress_warnings = [
    "mystnb.unknown_mime_type",  # e.g. rerun's inline viewer: nothing to show on a static page
]


# --------------------------------------------------------------------------------------------- prepare
def _write(path: Path, text: str) -> None:
    """Write only when the text changed, so that Sphinx rebuilds only what changed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _underline(title: str, char: str = "=") -> str:
    return f"{title}\n{char * len(title)}\n"


def write_api_pages() -> None:
    """One reStructuredText page per family, listing every public name by module. The pages autosummary
    generated for the last build are removed first: one of a name no longer public would be in no toctree,
    a warning, so a failed build."""
    import importlib
    import shutil

    shutil.rmtree(GENERATED / "api" / "generated", ignore_errors=True)  # written by this build's autosummary

    names = list(public_api.public_names())
    by_family: dict[str, dict[str, list[str]]] = {}
    for pub in names:
        module = pub.name.rsplit(".", 1)[0]
        by_family.setdefault(pub.family, {}).setdefault(module, []).append(pub.name)
    modules = [m for m in public_api.public_modules() if m != "labkit"]
    for slug, title, _prefixes in public_api.FAMILIES:
        parts = [_underline(title)]
        # every public module of the family, with its names or without (a package whose names live in
        # its submodules): its ``module`` directive is the target of ``:mod:`` references and sets the module
        # its docstring's and its names' summaries' short references are resolved in
        for module in sorted({m for m in modules if public_api.family_of(m) == slug} | set(by_family.get(slug, {}))):
            doc = (importlib.import_module(module).__doc__ or "").strip().split("\n\n")[0]
            parts.append(_underline(module, "-"))
            parts.append(f".. module:: {module}\n")
            parts.append(f"{' '.join(doc.split())}\n" if doc else "")
            if module in by_family.get(slug, {}):
                parts.append(".. autosummary::\n   :toctree: generated\n   :nosignatures:\n")
                parts.extend(f"   {name.rsplit('.', 1)[1]}" for name in by_family[slug][module])
            parts.append("")
        _write(GENERATED / "api" / f"{slug}.rst", "\n".join(parts) + "\n")
    top = ["| name | documented at |", "|---|---|"]
    homes = {id(p.obj): p.name for p in names}
    for attr in labkit.__all__:
        obj = getattr(labkit, attr)
        if attr.startswith("__"):
            continue
        if hasattr(obj, "__path__") or type(obj).__name__ == "module":
            top.append(f"| `labkit.{attr}` | the module {{py:mod}}`{obj.__name__}`: its names are in the families |")
        elif id(obj) in homes:
            top.append(f"| `labkit.{attr}` | {{py:obj}}`{homes[id(obj)]}` |")
    _write(GENERATED / "api" / "top_level.md",
           "# `labkit`: the names of the package itself\n\n```{py:module} labkit\n```\n\n"
           "`import labkit` gives these names (`labkit.__all__`); each is documented once, at the module "
           "that defines it.\n\n" + "\n".join(top) + "\n")


def copy_notebooks() -> None:
    """The course with outputs (executed copies) and the exercises' student copies (without)."""
    course = sorted((REPO / "notebooks").glob("*.ipynb"))
    for notebook in course:
        copy = executed_notebooks.stored(notebook)
        if not copy.is_file():
            started = time.monotonic()
            print(f"[labkit docs] executing {notebook.name} (no executed copy of this version yet)", flush=True)
            executed_notebooks.execute(notebook)
            print(f"[labkit docs] executed {notebook.name} in {time.monotonic() - started:.0f} s", flush=True)
        _write(GENERATED / "course" / notebook.name, _static_outputs(copy))
    _prune(GENERATED / "course", {p.name for p in course})
    released = sorted((REPO / "exercises" / "release").glob("*/*.ipynb"))
    for notebook in released:
        _copy(notebook, GENERATED / "exercises" / notebook.name)
    _prune(GENERATED / "exercises", {p.name for p in released})


WIDGET = "application/vnd.jupyter.widget-view+json"
WIDGET_NOTE = "[an interactive widget: it runs in JupyterLab (make lab), not on this page]"


def _static_outputs(executed: Path) -> str:
    """The executed notebook as a static page shows it: a widget (sliders, the inline rerun viewer),
    which needs a live kernel, becomes a one-line note instead of its Python repr."""
    import nbformat

    nb = nbformat.read(executed, as_version=4)
    nb.metadata.pop("widgets", None)
    for cell in nb.cells:
        for output in cell.get("outputs", []):
            if WIDGET in output.get("data", {}):
                output["data"] = {"text/plain": WIDGET_NOTE}
    return nbformat.writes(nb)


def _copy(source: Path, target: Path) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    if not target.is_file() or target.read_bytes() != source.read_bytes():
        shutil.copyfile(source, target)


def _prune(folder: Path, keep: set[str]) -> None:
    for path in folder.glob("*.ipynb"):
        if path.name not in keep:
            path.unlink()


def write_benchmarks_page() -> None:
    """The tables of the benchmark scripts, as each printed them into docs/benchmarks/<script>.txt
    (``make benchmark-tables`` writes them; the build never runs a benchmark)."""
    parts = ["# Benchmarks\n",
             "The comparison tables of the scripts in `benchmarks/`, exactly as they printed them the last time "
             "`make benchmark-tables` ran them (on the machine and load it names; ratios are measured in the same "
             "run, so they travel better than seconds). Run a script yourself for your machine: "
             "`.venv/bin/python benchmarks/<name>.py`.\n"]
    tables = sorted((DOCS / "benchmarks").glob("*.txt"))
    for table in tables:
        parts.append(f"## `benchmarks/{table.stem}.py`\n")
        parts.append(f"```{{literalinclude}} ../benchmarks/{table.name}\n:language: text\n```\n")
    if not tables:
        parts.append("No table has been written yet: `make benchmark-tables`.\n")
    _write(GENERATED / "benchmarks.md", "\n".join(parts))


def _mathjax_dir() -> Path:
    """MathJax 3 as the ``sphinx-mathjax-offline`` package ships it (its extension is not used: it
    does not declare itself safe for a parallel build; its files are all it is needed for)."""
    import importlib.util

    spec = importlib.util.find_spec("sphinx-mathjax-offline")
    if spec is None or spec.origin is None:
        raise RuntimeError("the docs need the sphinx-mathjax-offline package: pip install -e '.[docs]'")
    return Path(spec.origin).parent / "static" / "mathjax"


MATHJAX = _mathjax_dir()
mathjax_path = "mathjax/tex-chtml.js"  # served with the site: the math renders without the internet


def _copy_mathjax(app, exc) -> None:
    from sphinx.util.fileutil import copy_asset

    if exc is None:
        copy_asset(str(MATHJAX), str(Path(app.outdir) / "_static" / "mathjax"))


def _alias_targets() -> dict[str, str]:
    """``labkit.X`` (and ``labkit.pkg.X`` re-exports) -> the dotted name X is documented under."""
    import importlib

    homes = {id(p.obj): p.name for p in public_api.public_names()}
    aliases: dict[str, str] = {}
    for modname in public_api.public_modules():
        module = importlib.import_module(modname)
        for attr in getattr(module, "__all__", ()):
            obj = getattr(module, attr, None)
            if id(obj) in homes and homes[id(obj)] != f"{modname}.{attr}":
                aliases[f"{modname}.{attr}"] = homes[id(obj)]
    return aliases


ALIASES = _alias_targets()


def _home_of(target: str) -> str | None:
    """Where ``target`` is documented when it is a re-exported name or a member of one
    (``labkit.Scan.pose`` -> ``labkit.scan.Scan.pose``); None when it is neither."""
    if target in ALIASES:
        return ALIASES[target]
    owner, _, member = target.rpartition(".")
    return f"{ALIASES[owner]}.{member}" if owner in ALIASES else None


def _resolve_alias(app, env, node, contnode):
    """A reference to a re-exported name (``:func:`labkit.split_and_merge```) goes to the page of its
    home (``labkit.lines.split_merge.split_and_merge``), where it is documented once."""
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "")
    home = _home_of(target)
    if home is None and not target.startswith("labkit."):
        # a short name in a docstring: of the module's own package, or of a package above it that
        # re-exports it (``log_steps`` in labkit.viz.rr.blueprint is labkit.viz.rr's)
        parts = (node.get("py:module") or "").split(".")
        while home is None and parts and parts[0]:
            home = _home_of(f"{'.'.join(parts)}.{target}")
            parts.pop()
    if home is None:
        return None
    domain = env.get_domain("py")
    node["reftarget"] = home
    return domain.resolve_xref(env, node["refdoc"], app.builder, node["reftype"], home, node, contnode)


def setup(app):
    app.connect("build-finished", _copy_mathjax)
    app.connect("missing-reference", _resolve_alias)
    return {"parallel_read_safe": True, "parallel_write_safe": True}


def prepare() -> None:
    write_api_pages()
    write_benchmarks_page()
    copy_notebooks()


prepare()
