"""Every lesson's exercises have the shape tools/student.py expects, and a student copy's checks
fail without the solutions."""

from __future__ import annotations

import os
import sys

import nbformat
import pytest

from .conftest import REPO

sys.path.insert(0, str(REPO / "tools"))
from student import exercises, student_copy  # noqa: E402

STUDENT_LESSON = "07_evaluation.ipynb"  # quick to run, five exercises
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


def test_a_student_copy_stubs_every_solution_and_its_checks_fail(tmp_path):
    """Run one student copy: every stub raises "your turn", every check then fails."""
    from nbclient import NotebookClient

    nb = nbformat.read(REPO / "notebooks" / STUDENT_LESSON, as_version=4)
    copy = student_copy(nb)
    found = exercises(copy)
    for e in found:
        for index in e["solutions"]:
            assert "NotImplementedError" in copy.cells[index].source
    os.environ.setdefault("E2V_QUICK", "1")
    client = NotebookClient(copy, timeout=600, kernel_name="python3", allow_errors=True,
                            resources={"metadata": {"path": str(REPO / "notebooks")}})
    client.execute()
    for e in found:
        for index in e["solutions"]:
            errors = [o for o in copy.cells[index].outputs if o.output_type == "error"]
            assert errors and errors[0].ename == "NotImplementedError", e
            assert "Your turn" in errors[0].evalue
        check_errors = [o for o in copy.cells[e["checks"][0]].outputs if o.output_type == "error"]
        assert check_errors, f"exercise {e['number']}: its check passes without the solution"
