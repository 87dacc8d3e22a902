"""Data flows one way (DESIGN.md): algorithm modules import numpy, the standard library and
the labkit model only -- never a viewer, rerun, matplotlib, rosbags, ipywidgets or I/O."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

LABKIT = Path(__file__).resolve().parents[1] / "labkit"

#: the model and the algorithms: each may import the others, numpy and the standard library
ALGORITHMS = ["_checks", "_safe", "errors", "scan", "steps", "geometry", "segmentation", "fitting", "features",
              "split_merge", "dbscan1d",
              "angular", "iav", "legs", "sim", "pipeline", "evaluation",
              "incremental", "line_regression", "ransac", "hough", "poses"]


def imports_of(path: Path) -> set[str]:
    """Top-level names of every module imported by ``path``, relative imports as ``labkit.x``."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # from .x import y / from . import x
                base = node.module or ""
                names = [base] if base else [alias.name for alias in node.names]
                found |= {f"labkit.{n}" for n in names}
            else:
                found.add(node.module)
    return found


@pytest.mark.parametrize("module", ALGORITHMS)
def test_algorithm_modules_import_numpy_and_the_model_only(module):
    path = LABKIT / f"{module}.py"
    assert path.exists(), f"{path} is listed as an algorithm module but does not exist"
    bad = []
    for name in imports_of(path):
        top = name.split(".")[0]
        if name.startswith("labkit."):
            if name.split(".")[1] not in ALGORITHMS:
                bad.append(name)
        elif top not in sys.stdlib_module_names and top != "numpy":
            bad.append(name)
    assert not bad, f"labkit/{module}.py imports {sorted(bad)}; algorithms may use numpy and the model only"


def test_the_checker_sees_a_forbidden_import(tmp_path):
    path = tmp_path / "mod.py"
    path.write_text("import numpy as np\nfrom .viz import plot\nimport matplotlib.pyplot as plt\n")
    assert imports_of(path) == {"numpy", "labkit.viz", "matplotlib.pyplot"}
