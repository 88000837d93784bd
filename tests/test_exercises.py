"""Every lesson's exercises have the shape tools/student.py expects, a student copy stubs every
solution, and every exercise has a plausible wrong answer in tests/wrong_answers/ that is not its
solution. tests/test_lessons.py then runs each lesson once and proves, in that run, that each
check fails on the stub and on the wrong answer and passes on the solution."""

from __future__ import annotations

import importlib
import sys

import nbformat
import pytest

from .conftest import REPO

sys.path.insert(0, str(REPO / "tools"))
from student import exercises, student_copy  # noqa: E402

LESSONS = sorted((REPO / "notebooks").glob("[0-9][0-9]_*.ipynb"))


@pytest.mark.parametrize("path", LESSONS, ids=lambda p: p.name)
def test_exercises_are_question_solution_check(path):
    nb = nbformat.read(path, as_version=4)
    found = exercises(nb)
    assert len(found) >= 4, f"{path.name}: {len(found)} exercises, need at least 4"
    assert any(e["experiment"] for e in found), f"{path.name}: no exercise is an experiment"
    for e in found:
        name = f"{path.name} exercise {e['number']}"
        assert e["solutions"], f"{name}: no cell tagged 'solution'"
        assert len(e["checks"]) == 1, f"{name}: needs exactly one cell tagged 'check'"
        check = nb.cells[e["checks"][0]]
        assert "assert" in check.source, f"{name}: the check cell asserts nothing"
        assert max(e["solutions"]) < e["checks"][0], f"{name}: the check comes before the solution"
        assert e["question"] < min(e["solutions"]), f"{name}: the solution must follow the question"
    numbers = [e["number"] for e in found]
    assert numbers == list(range(1, len(found) + 1)), f"{path.name}: exercises numbered {numbers}"


@pytest.mark.parametrize("path", LESSONS, ids=lambda p: p.name)
def test_a_student_copy_stubs_every_solution(path):
    nb = nbformat.read(path, as_version=4)
    copy = student_copy(nb)
    for e in exercises(nb):
        for index in e["solutions"]:
            assert "NotImplementedError" in copy.cells[index].source, (
                f"{path.name} exercise {e['number']}: solution cell {index} is not stubbed")
            assert "Your turn" in copy.cells[index].source
            assert copy.cells[index].outputs == []
        check = e["checks"][0]
        assert copy.cells[check].source == nb.cells[check].source, "the check cell must stay"


@pytest.mark.parametrize("path", LESSONS, ids=lambda p: p.name)
def test_every_exercise_has_a_wrong_answer_that_is_not_its_solution(path):
    nb = nbformat.read(path, as_version=4)
    found = exercises(nb)
    wrong = importlib.import_module(f"tests.wrong_answers.lesson_{path.name[:2]}").WRONG
    assert sorted(wrong) == [e["number"] for e in found], (
        f"{path.name}: tests/wrong_answers/lesson_{path.name[:2]}.py must hold one wrong answer "
        f"per exercise {[e['number'] for e in found]}, has {sorted(wrong)}")
    for e in found:
        solution = "\n".join(nb.cells[i].source for i in e["solutions"])
        assert wrong[e["number"]].strip() not in solution, (
            f"{path.name} exercise {e['number']}: the wrong answer is the solution")
        compile(wrong[e["number"]], f"wrong answer {e['number']}", "exec")
