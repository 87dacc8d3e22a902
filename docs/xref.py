"""Cross-references of the docs: every one must resolve, except those to other projects' names.

``docs/conf.py`` takes its settings from here, and so does the small build of tests/test_docs.py that
proves a broken reference fails the build. ``nitpicky`` makes Sphinx warn on every reference it
cannot resolve, and ``make docs`` turns warnings into errors.

The build is offline: no intersphinx inventory is fetched, so a reference to a name of numpy, scipy,
matplotlib, rerun, pyarrow, ... or of Python itself cannot resolve. :data:`NITPICK_IGNORE_REGEX`
lets those through, one pattern per outside package (by its dotted prefix) and the builtin names,
never a pattern that would also let a ``labkit`` name through: labkit's own names must resolve.

A parameter's type is cross-referenced (``numpydoc_xref_param_type``) only where it names a labkit
class (:func:`type_aliases`): ``list of Scan`` links ``Scan`` to its page and leaves ``list of`` as
text (``numpydoc_xref_ignore = "all"``: words that are not aliases are never references).
"""

from __future__ import annotations

import builtins
import inspect
import re

NITPICKY = True

#: Outside packages whose names docstrings mention, by the dotted prefix they are written with
#: (no inventory of theirs is available offline). Python's standard library is among them.
EXTERNAL_PREFIXES = (
    # the scientific stack and the viewers
    "numpy", "np", "scipy", "matplotlib", "rerun", "rr", "pyarrow", "pandas", "ipywidgets", "numba",
    # reading bags, running notebooks, grading, running on many cores
    "rosbags", "mcap", "nbformat", "nbclient", "nbgrader", "jupyter_client", "distributed", "dask", "tqdm",
    # Python's standard library
    "pathlib", "collections", "typing", "dataclasses", "enum", "json", "os", "io", "subprocess", "functools",
    "itertools", "contextlib", "argparse", "sqlite3", "tempfile", "signal", "resource", "concurrent", "threading",
    "multiprocessing", "logging", "warnings", "gzip", "zlib", "struct", "hashlib", "shutil", "types", "datetime",
)

#: Python's builtin types and exceptions (``:class:`ValueError```, ``:class:`float```).
BUILTIN_NAMES = tuple(sorted(name for name in dir(builtins)
                             if not name.startswith("_") and isinstance(getattr(builtins, name), type)))


def _alternatives(names) -> str:
    return "|".join(re.escape(n) for n in names)


#: (reference type, target) patterns, full matches, of the references left unresolved on purpose: names
#: of the outside packages; Python's builtin types; and the links numpydoc adds itself for the common words
#: of parameter types (``int``, ``None``, ``bool``, ``array_like``, ``iterable``: its ``DEFAULT_LINKS``),
#: which point into the Python and NumPy inventories (``python:float``, ``numpy:array_like``).
NITPICK_IGNORE_REGEX = [
    (r"py:.*", rf"(?:{_alternatives(EXTERNAL_PREFIXES)})(?:\..+)?"),
    (r"py:.*", rf"(?:{_alternatives(BUILTIN_NAMES)})(?:\.\w+)?"),
    (r"py:.*|std:term|std:ref", r"(?:python|numpy):.+"),
]


def type_aliases(public_names) -> dict[str, str]:
    """numpydoc's type aliases: a labkit class's name (when no other public class has it), its home's
    dotted path and every dotted path it is re-exported under -> the dotted path it is documented at.

    Parameters
    ----------
    public_names : iterable of docs.public_api.PublicName
        Every public name at its home.

    Returns
    -------
    dict of str to str
        Term -> target.
    """
    import importlib

    classes = [p for p in public_names if inspect.isclass(p.obj)]
    by_short: dict[str, set[str]] = {}
    for p in classes:
        by_short.setdefault(p.name.rsplit(".", 1)[1], set()).add(p.name)
    aliases = {short: next(iter(homes)) for short, homes in by_short.items() if len(homes) == 1}
    homes = {id(p.obj): p.name for p in classes}
    for p in classes:
        aliases[p.name] = p.name
    modules = {p.name.rsplit(".", 1)[0] for p in classes} | {"labkit"}
    for modname in sorted(modules | {m.rsplit(".", 1)[0] for m in modules if "." in m}):
        module = importlib.import_module(modname)
        for attr in getattr(module, "__all__", ()):
            home = homes.get(id(getattr(module, attr, None)))
            if home is not None:
                aliases.setdefault(f"{modname}.{attr}", home)
    return aliases
