"""Every public name of labkit, grouped by family, and numpydoc's verdict on each docstring.

One list serves three readers: ``docs/conf.py`` writes the API reference from it (one page per
family, one autosummary entry per name), ``tests/test_docs.py`` checks that every public name has a
family and a clean docstring, and ``make lint`` runs this file::

    python -m docs.public_api          # new numpydoc findings (not on docs/numpydoc_todo.txt): exit 1

A public name is one that ``labkit.__all__`` or the ``__all__`` of a public module (no leading
underscore in its dotted path) lists. It is documented once, at its home: the module that defines it.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

# numpydoc checks left out, and why (numpydoc.validate's codes; the rest must all pass):
IGNORED_CHECKS = {
    "ES01": "an extended summary is welcome, not required: many one-liners say all there is",
    "EX01": "examples where they help (the notebooks are the worked examples), not on every name",
    "SA01": "See Also where it helps, not on every name",
    "GL01": "the summary may start on the line of the opening quotes (the house style of labkit)",
    "GL02": "closing quotes may follow the last line of text (the house style of labkit)",
    "RT02": "a return's name is allowed (numpydoc allows both styles; the NumPy guide names them)",
    "SS05": "a summary in the imperative mood or the indicative, as the sentence needs",
    "PR09": "a parameter's description may end with a closing bracket or code, not only a full stop",
    "RT05": "a return's description may end with a closing bracket or code, not only a full stop",
    "YD01": "generators say what they yield in their Returns or summary",
}

# The families of the API reference: (slug, title, module prefixes). A module belongs to the first
# family one of whose prefixes its dotted name starts with.
FAMILIES: list[tuple[str, str, tuple[str, ...]]] = [
    ("scan_io", "Scans and I/O", ("labkit.scan", "labkit.geometry", "labkit.features", "labkit.io", "labkit.errors",
                                  "labkit.poses", "labkit.tables", "labkit.steps", "labkit.params")),
    ("segmentation", "Segmentation", ("labkit.segmentation",)),
    ("lines", "Lines", ("labkit.fitting", "labkit.lines")),
    ("dbscan", "DBSCAN1D", ("labkit.dbscan",)),
    ("iav", "IAV, circles and legs", ("labkit.iav", "labkit.circles")),
    ("noise", "Range noise", ("labkit.noise",)),
    ("pipeline", "Pipeline", ("labkit.pipeline",)),
    ("evaluation", "Evaluation", ("labkit.evaluation",)),
    ("tracking", "Tracking", ("labkit.tracking",)),
    ("simulator", "Simulator", ("labkit.sim",)),
    ("viewers", "Viewers", ("labkit.viz",)),
    ("course", "Course", ("labkit.course",)),
    ("grading", "Grading", ("labkit.grading",)),
    ("applications", "Applications", ("labkit.app",)),
]


@dataclass(frozen=True)
class PublicName:
    """One public name at its home module.

    Attributes
    ----------
    name : str
        The dotted path the reference documents it under, e.g. ``labkit.segmentation.segment_labels``.
    obj : object
        The object itself.
    family : str
        The slug of its family in :data:`FAMILIES`.
    """

    name: str
    obj: object
    family: str


def family_of(module: str) -> str | None:
    """The slug of the family a module belongs to, or None when none claims it."""
    for slug, _title, prefixes in FAMILIES:
        if any(module == p or module.startswith(p + ".") or module.startswith(p + "_") for p in prefixes):
            return slug
    return None


def public_modules() -> list[str]:
    """Every importable public module of labkit (no path part starting with an underscore)."""
    import labkit

    names = ["labkit"]
    for info in pkgutil.walk_packages(labkit.__path__, "labkit."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return sorted(names)


def _home(obj: object, fallback: str) -> str:
    module = getattr(obj, "__module__", None)
    if inspect.ismodule(obj):
        return obj.__name__
    if isinstance(module, str) and module.startswith("labkit") and not any(
            p.startswith("_") for p in module.split(".")):
        return module
    return fallback


def public_names() -> Iterator[PublicName]:
    """Every public name once, at its home module, in the order of the modules and their ``__all__``."""
    seen: set[str] = set()
    seen_objects: set[int] = set()
    for modname in public_modules():
        module = importlib.import_module(modname)
        for attr in getattr(module, "__all__", ()):
            if attr.startswith("__"):
                continue
            obj = getattr(module, attr)
            if inspect.ismodule(obj):
                continue  # modules are documented as modules, by their own page
            home = _home(obj, modname)
            qualified = f"{home}.{getattr(obj, '__name__', attr)}" if home != modname else f"{modname}.{attr}"
            documented = inspect.isclass(obj) or callable(obj)
            if qualified in seen or (documented and id(obj) in seen_objects):
                continue
            seen.add(qualified)
            seen_objects.add(id(obj))
            yield PublicName(qualified, obj, family_of(home) or "")


def findings(names: list[PublicName] | None = None) -> list[tuple[str, str, str]]:
    """numpydoc's findings on every public name: ``(name, code, message)``, ignored codes left out."""
    from numpydoc.validate import validate

    out = []
    for pub in public_names() if names is None else names:
        if not (inspect.isclass(pub.obj) or inspect.isroutine(pub.obj)):
            continue  # constants and instances: their page shows their value, not a docstring of their type
        result = validate(pub.name)
        for code, message in result["errors"]:
            if code not in IGNORED_CHECKS:
                out.append((pub.name, code, message))
    return out


TODO = Path(__file__).resolve().parent / "numpydoc_todo.txt"


def todo() -> set[str]:
    """The findings not fixed yet (``name: CODE`` lines of docs/numpydoc_todo.txt): the list only shrinks."""
    lines = TODO.read_text(encoding="utf-8").splitlines() if TODO.is_file() else []
    return {line.strip() for line in lines if line.strip() and not line.startswith("#")}


def main(argv: list[str]) -> int:
    """``python -m docs.public_api [--write-todo]``: every finding not on the to-do list, exit 1 when
    there is one or when the list names a finding that is fixed (take it off)."""
    found = findings()
    keys = {f"{name}: {code}" for name, code, _message in found}
    if "--write-todo" in argv:
        TODO.write_text("# numpydoc findings on public docstrings not fixed yet (docs/public_api.py); fix, then "
                        "take the line off\n" + "".join(f"{k}\n" for k in sorted(keys)), encoding="utf-8")
    listed = todo()
    new = [(n, c, m) for n, c, m in found if f"{n}: {c}" not in listed]
    fixed = sorted(listed - keys)
    for name, code, message in new:
        print(f"{name}: {code} {message}")
    for key in fixed:
        print(f"{key}: fixed, take it off {TODO.name}")
    validated = sum(1 for p in public_names() if inspect.isclass(p.obj) or inspect.isroutine(p.obj))
    print(f"numpydoc: {len(found)} findings on {validated} public functions and classes, {len(listed)} on the to-do "
          f"list, {len(new)} new, {len(fixed)} fixed but listed (checks left out: {', '.join(sorted(IGNORED_CHECKS))})")
    return 1 if new or fixed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
