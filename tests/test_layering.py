"""Data flows one way (DESIGN.md): algorithm modules import numpy, the standard library and
the labkit model only -- never a viewer, rerun, matplotlib, rosbags, ipywidgets or I/O."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

LABKIT = Path(__file__).resolve().parents[1] / "labkit"

#: the model and the algorithms (modules, or whole family packages): each may import the
#: others, numpy and the standard library
ALGORITHMS = ["_validate", "_jit", "_safe", "iav", "_iav_batch", "_iav_noise", "params", "_fastinit", "_plainfloat",
              "_dbscan_fast", "_kernels", "_segmentation_engine", "_noise_engine", "_iav_engine", "_tracking_engine",
              "_pipeline_engine",
              "errors", "scan", "steps", "geometry", "noise", "segmentation", "fitting",
              "features", "dbscan", "pipeline", "evaluation", "poses", "lines", "circles", "sim",
              "tracking", "tracking_metrics"]
#: scipy where a well-kept routine does the job (DESIGN.md): the assignment problem of tracking
SCIPY = {"tracking.py": {"scipy.optimize"}, "tracking_metrics.py": {"scipy.optimize"}}


def _module_name(path: Path) -> list[str]:
    """``labkit/lines/hough.py`` -> ``["labkit", "lines", "hough"]``; a file outside labkit is
    taken as a top-level labkit module."""
    try:
        rel = path.resolve().relative_to(LABKIT)
    except ValueError:
        rel = Path(path.name)
    parts = ["labkit", *rel.with_suffix("").parts]
    return parts[:-1] if parts[-1] == "__init__" else parts


def imports_of(path: Path) -> set[str]:
    """Dotted names of every module imported by ``path``, relative imports resolved."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # from .x import y / from ..x import y / from . import x
                base = package[: len(package) - node.level + 1]
                if node.module:
                    found.add(".".join([*base, node.module]))
                else:
                    found |= {".".join([*base, alias.name]) for alias in node.names}
            else:
                found.add(node.module)
    return found


def _algorithm_files() -> list[Path]:
    out = []
    for name in ALGORITHMS:
        package = LABKIT / name
        out += sorted(package.glob("*.py")) if package.is_dir() else [LABKIT / f"{name}.py"]
    return out


@pytest.mark.parametrize("path", _algorithm_files(), ids=lambda p: str(p.relative_to(LABKIT)))
def test_algorithm_modules_import_numpy_and_the_model_only(path):
    assert path.exists(), f"{path} is listed as an algorithm module but does not exist"
    bad = []
    for name in imports_of(path):
        top = name.split(".")[0]
        if name.startswith("labkit."):
            if name.split(".")[1] not in ALGORITHMS:
                bad.append(name)
        elif top not in sys.stdlib_module_names and top != "numpy" and name not in SCIPY.get(path.name, ()) and not (
                top in ("numba", "llvmlite") and path.stem.endswith(("_engine", "_kernels"))):
            bad.append(name)  # (numba only in the private compiled engines, DESIGN.md)
    assert not bad, f"{path.relative_to(LABKIT)} imports {sorted(bad)}; algorithms may use numpy and the model only"


def test_every_family_package_is_checked():
    """A new module in labkit/lines, labkit/circles or labkit/sim is checked without an edit here."""
    checked = set(_algorithm_files())
    for family in ("lines", "circles", "sim"):
        for path in (LABKIT / family).glob("*.py"):
            assert path in checked


def test_the_checker_sees_a_forbidden_import(tmp_path):
    path = tmp_path / "mod.py"
    path.write_text("import numpy as np\nfrom .viz import plot\nimport matplotlib.pyplot as plt\n")
    assert imports_of(path) == {"numpy", "labkit.viz", "matplotlib.pyplot"}


def test_the_checker_resolves_imports_of_a_family_module():
    assert {"labkit.features", "labkit.lines._runs"} <= imports_of(LABKIT / "lines" / "hough.py")
    assert "labkit.circles.iav_circles" in imports_of(LABKIT / "circles" / "__init__.py")


# ---------------------------------------------------------------------------- one home per idea
def _modules() -> dict[str, Path]:
    """Every module of labkit by its dotted name (a package by its ``__init__``)."""
    out = {}
    for path in sorted(LABKIT.rglob("*.py")):
        out[".".join(_module_name(path))] = path
    return out


def _import_nodes(path: Path):
    """``(module, names, node)`` for every import anywhere in ``path`` (inside functions too),
    ``module`` resolved to a dotted name."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name[:-1]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, [], node
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module
            yield module, [alias.name for alias in node.names], node


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the labkit modules it imports, at the top or inside a function: ``from .x import
    y`` is an edge to ``x``, or to ``x.y`` alone when that is a module (``from . import sim``)."""
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for m, path in modules.items():
        for module, names, _ in _import_nodes(path):
            submodules = [f"{module}.{n}" for n in names if f"{module}.{n}" in modules]
            graph[m].update(submodules)
            if module in modules and len(submodules) < max(len(names), 1):
                graph[m].add(module)
        graph[m].discard(m)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _parent(module: str) -> str:
    return module.rsplit(".", 1)[0]


def test_no_import_cycle_even_inside_functions():
    """A package imports its modules; no module imports its way back (an import inside a function
    hides a cycle from Python, not from this test)."""
    graph = import_graph(_modules())
    # a package's __init__ re-exporting its own modules is the direction data flows; a module of
    # the package importing the package (its __init__) back is a cycle
    found = cycles(graph)
    assert not found, "import cycles: " + "; ".join(" <-> ".join(c) for c in found)


def test_the_cycle_finder_finds_one_hidden_in_a_function(tmp_path):
    graph = {"labkit.a": {"labkit.b"}, "labkit.b": {"labkit.c"}, "labkit.c": {"labkit.a"}, "labkit.d": {"labkit.a"}}
    assert cycles(graph) == [["labkit.a", "labkit.b", "labkit.c"]]
    path = tmp_path / "x.py"  # (taken as a top-level module of labkit)
    path.write_text("import numpy\n\n\ndef f():\n    from .viz import plot\n")
    assert {m for m, _, _ in _import_nodes(path)} == {"numpy", "labkit.viz"}


def _family(module: str) -> str:
    """``labkit.lines.hough`` -> ``labkit.lines``; a top-level module is a family of its own."""
    parts = module.split(".")
    return ".".join(parts[:2])


def test_no_private_name_is_imported_from_another_family():
    """``from x import _y`` only inside one family (a package's modules share their internals;
    what is shared across families lives in a module whose names are public)."""
    modules = _modules()
    bad = []
    for m, path in modules.items():
        for module, names, node in _import_nodes(path):
            if not module.startswith("labkit"):
                continue
            for n in names:
                if n.startswith("_") and not n.startswith("__") and _family(module) != _family(m):
                    bad.append(f"{path.relative_to(LABKIT.parent)}:{node.lineno} imports {n} from {module}")
    assert not bad, f"{len(bad)} private names imported across families:\n" + "\n".join(bad)


def test_no_two_modules_share_a_name():
    seen: dict[str, list[str]] = {}
    for path in LABKIT.rglob("*.py"):
        if path.name in ("__init__.py", "__main__.py"):
            continue
        seen.setdefault(path.stem.lstrip("_"), []).append(str(path.relative_to(LABKIT)))
    twice = {k: v for k, v in seen.items() if len(v) > 1}
    assert not twice, f"modules sharing a name: {twice}"


def test_the_library_never_imports_the_applications():
    """``labkit.app`` (command line, demo, bench, experiments, Dask, bundled data) sits above the library:
    no module outside it imports it, inside functions either (``labkit/__init__`` re-exports
    ``bundled_data`` for the notebooks)."""
    bad = []
    for m, path in _modules().items():
        if m == "labkit" or m == "labkit.app" or m.startswith("labkit.app."):
            continue
        for module, _names, node in _import_nodes(path):
            if module == "labkit.app" or module.startswith("labkit.app."):
                bad.append(f"{path.relative_to(LABKIT.parent)}:{node.lineno} imports {module}")
    assert not bad, "the library imports its applications:\n" + "\n".join(bad)


def test_every_name_in___all___resolves():
    import importlib

    missing = []
    for m in _modules():
        if m.endswith("__main__"):
            continue
        module = importlib.import_module(m)
        for name in getattr(module, "__all__", ()):
            if not hasattr(module, name):
                missing.append(f"{m}.{name}")
    assert not missing, f"names in __all__ that do not exist: {missing}"


def test_star_import_works():
    import subprocess

    done = subprocess.run([sys.executable, "-c", "from labkit import *; print(len(dir()))"], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
