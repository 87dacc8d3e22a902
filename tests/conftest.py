"""Shared fixtures: paths to the repository, its bundled data and the real datasets."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
from hypothesis import settings

# The fuzz tests run a fixed, reproducible set of examples by default, so a red `make test`
# always means a change broke something. To hunt for new failures with fresh random examples:
#   HYPOTHESIS_PROFILE=explore .venv/bin/python -m pytest tests -k fuzz
# No per-example deadline: under load (both cores busy with notebooks and grading) an example can
# take several times its usual time, and a deadline would turn that into a failure.
settings.register_profile("repeatable", derandomize=True, print_blob=True, deadline=None)
settings.register_profile("explore", derandomize=False, print_blob=True, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "data"
SHARED_DATASETS = Path(os.environ.get("LABKIT_SHARED_DATASETS", REPO.parent / "shared" / "datasets"))


@pytest.fixture(scope="session")
def shared_datasets() -> Path:
    """The real public recordings in ../shared/datasets (skip when absent)."""
    if not SHARED_DATASETS.is_dir():
        pytest.skip(f"real datasets not found at {SHARED_DATASETS} (they live beside the repository, "
                    "in ../shared/datasets; set LABKIT_SHARED_DATASETS to point elsewhere)")
    return SHARED_DATASETS


# The Ctrl-C tests send SIGINT to a command as a terminal does to a command run in the foreground, where
# SIGINT has its default action. A test run started in the background by a script (`make test &`,
# `nohup ... &`) starts with SIGINT ignored, which every command it starts would inherit (Python keeps an
# ignored SIGINT ignored): those commands would rightly ignore the Ctrl-C (labkit grade's timed-out tests,
# labkit extract's "finished before Ctrl-C arrived" skips). Each test process gives it back its default.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


# Slow steps: a test may record_property("slow_steps", ["cell 12: 45 s", ...]) (the notebook tests
# do); the controller (under xdist too: user properties travel with the report) lists them at the
# end of the run, so a stall that does not fail a test still shows where it happened.
_SLOW_STEPS: list[tuple[str, list[str]]] = []


def pytest_runtest_logreport(report):
    if report.when == "call":
        for name, value in report.user_properties:
            if name == "slow_steps" and value:
                _SLOW_STEPS.append((report.nodeid, list(value)))


def pytest_terminal_summary(terminalreporter):
    if _SLOW_STEPS:
        terminalreporter.section("slow steps")
        for nodeid, steps in _SLOW_STEPS:
            terminalreporter.write_line(f"{nodeid}: {', '.join(steps)}")


# labkit's numba engines compile into an on-disk cache (labkit/**/__pycache__) the first time they
# run. `make` compiles them at set-up; where the cache is missing or stale (an edited engine), the two
# xdist workers would each compile them at once, about 30 s of CPU each. The controller compiles them
# (or loads them, about a second) before it starts the workers, which then load its cache.
def pytest_configure(config):
    from labkit import _jit

    if _jit.ENABLED and getattr(config.option, "numprocesses", None) and not hasattr(config, "workerinput"):
        from labkit.lines._split_merge_engine import compile_all

        compile_all()


@pytest.fixture
def labkit_cli():
    """The command line in this process (:func:`tests.cli_here.in_process`); no case shows a traceback."""
    from tests.cli_here import in_process

    def run(*args):
        p = in_process(*args)
        assert "Traceback" not in p.stderr, p.stderr
        return p

    return run
