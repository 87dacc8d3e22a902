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
ALGORITHMS = ["_checks", "_safe", "iav", "_iav_batch", "_iav_noise", "params", "_records", "_plainfloat",
              "_dbscan_fast", "errors", "scan", "steps", "geometry", "noise", "segmentation", "fitting",
              "features", "dbscan", "pipeline", "evaluation", "poses", "lines", "circles", "sim"]


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
        elif top not in sys.stdlib_module_names and top != "numpy":
            bad.append(name)
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
