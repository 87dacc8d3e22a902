"""The code passes ruff (style, imports, common bugs) and mypy (types, with its default settings and the
exceptions listed in pyproject.toml), so `make test` keeps it clean."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def test_ruff_is_clean():
    ruff = shutil.which("ruff") or str(Path(sys.executable).parent / "ruff")
    if not Path(ruff).exists():
        pytest.skip("ruff is not installed (pip install -e '.[dev]')")
    proc = subprocess.run([ruff, "check", "labkit", "tests", "benchmarks"], cwd=REPO, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_mypy_is_clean():
    """``mypy labkit``: its cache lives in the venv, so a second run takes seconds (a cold one, about a minute
    of CPU)."""
    mypy = Path(sys.executable).parent / "mypy"
    if not mypy.exists():
        pytest.skip("mypy is not installed (pip install -e '.[dev]')")
    cache = Path(sys.prefix) / ".mypy_cache"
    proc = subprocess.run([str(mypy), "--cache-dir", str(cache), "labkit"], cwd=REPO, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
