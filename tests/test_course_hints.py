"""The graduated hints of the course notebooks (labkit.course_hints): one per task, none spells the code,
and the solution is shown only on request, saying so."""

from __future__ import annotations

import re

import nbformat
import pytest

from labkit import course_hints
from tests.test_no_answers_in_notebooks import NOTEBOOKS, _spelled_statement


def _task_names() -> dict[str, str]:
    """{function name: notebook} of every your-turn cell."""
    tasks = {}
    for nb_path in NOTEBOOKS:
        for cell in nbformat.read(nb_path, as_version=4).cells:
            if "your-turn" in cell.get("metadata", {}).get("tags", []):
                tasks[re.search(r"^def (\w+)", cell.source, re.M).group(1)] = nb_path.name
    return tasks


def test_every_task_has_hints_and_its_cell_says_how_to_ask():
    tasks = _task_names()
    assert len(tasks) >= 20
    assert sorted(set(tasks) - set(course_hints.HINTS)) == []
    for nb_path in NOTEBOOKS:
        for cell in nbformat.read(nb_path, as_version=4).cells:
            if "your-turn" in cell.get("metadata", {}).get("tags", []):
                name = re.search(r"^def (\w+)", cell.source, re.M).group(1)
                assert f'hint("{name}")' in cell.source, f"{nb_path.name}: the task {name} does not say how to ask"


def test_no_hint_spells_a_line_of_code():
    spelled = {name: piece for name, hints in course_hints.HINTS.items() for text in hints
               if (piece := _spelled_statement(text))}
    assert spelled == {}


def test_the_spelling_detector_sees_code_in_prose():
    """The check above can fail: a hint that gives the line away is caught."""
    assert _spelled_statement("Start with keep = min_points // 2, then loop") == "keep = min_points // 2"
    assert _spelled_statement("the centre = midpoint - sign(side) * h, the radius") is not None
    assert _spelled_statement("Protect the first and the last points of the run") is None


def test_hints_are_graduated_and_the_solution_says_it_was_shown(capsys, monkeypatch):
    monkeypatch.setattr(course_hints, "SHOWN", set())
    course_hints.hint("iepf")
    first = capsys.readouterr().out
    course_hints.hint("iepf", 2)
    second = capsys.readouterr().out
    assert first.startswith("iepf, hint 1 of 2") and 'hint("iepf", 2)' in first
    assert second.startswith("iepf, hint 2 of 2") and 'hint("iepf", "solution")' in second
    assert "def " not in first + second and course_hints.SHOWN == set()
    course_hints.hint("iepf", "solution")
    shown = capsys.readouterr().out
    assert "SOLUTION, shown because you asked for it" in shown and "def iepf(" in shown
    assert course_hints.SHOWN == {"iepf"}


def test_every_solution_is_found():
    for name in course_hints.HINTS:
        assert callable(course_hints._solution(name)), name


@pytest.mark.parametrize("name, level, error", [("nope", 1, KeyError), ("iepf", 3, ValueError),
                                                ("iepf", 0, ValueError), ("iepf", "all", ValueError)])
def test_bad_requests_say_what_is_allowed(name, level, error):
    with pytest.raises(error, match="tasks with hints|level must be"):
        course_hints.hint(name, level)
