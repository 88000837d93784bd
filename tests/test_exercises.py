"""Every lesson's exercises have the shape tools/student.py expects, and a student copy's checks
fail without the solutions."""

from __future__ import annotations

import json
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


OUTPUT_PROCESS_TEXT = ("-dirty", "../shared")


def _wrong_answers(path) -> dict[int, str]:
    import importlib

    module = importlib.import_module(f"tests.wrong_answers.lesson_{path.name[:2]}")
    return module.WRONG


@pytest.mark.parametrize("path", LESSONS, ids=lambda p: p.name)
def test_every_check_fails_on_a_plausible_wrong_answer(path):
    """Run the lesson with, before each exercise's solution, a wrong answer and a copy of its
    check: that copy must fail with an AssertionError, the real check must then pass, and no
    other cell may fail or print process text."""
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    found = exercises(nb)
    wrong = _wrong_answers(path)
    assert sorted(wrong) == [e["number"] for e in found], (
        f"{path.name}: tests/wrong_answers/lesson_{path.name[:2]}.py must hold one wrong answer "
        f"per exercise {[e['number'] for e in found]}, has {sorted(wrong)}")
    first_solution = {min(e["solutions"]): e for e in found}
    cells, probes = [], {}
    for index, cell in enumerate(nb.cells):
        if index in first_solution:
            e = first_solution[index]
            solution = "\n".join(nb.cells[i].source for i in e["solutions"])
            assert wrong[e["number"]].strip() not in solution, (
                f"{path.name} exercise {e['number']}: the wrong answer is the solution")
            cells.append(nbformat.v4.new_code_cell(wrong[e["number"]]))
            probes[len(cells)] = e["number"]
            cells.append(nbformat.v4.new_code_cell(nb.cells[e["checks"][0]].source))
        cells.append(cell)
    run = nbformat.from_dict(nb)
    run.cells = cells
    os.environ.setdefault("E2V_QUICK", "1")
    NotebookClient(run, timeout=600, kernel_name="python3", allow_errors=True,
                   resources={"metadata": {"path": str(REPO / "notebooks")}}).execute()
    for index, cell in enumerate(run.cells):
        if cell.cell_type != "code":
            continue
        errors = [o for o in cell.outputs if o.output_type == "error"]
        if index in probes:
            name = f"{path.name} exercise {probes[index]}"
            assert errors, f"{name}: the check passes on the wrong answer"
            assert errors[0].ename == "AssertionError", (
                f"{name}: the check fails with {errors[0].ename} instead of an assertion: "
                f"{errors[0].evalue}")
        else:
            where = "the wrong answer" if index + 1 in probes else f"cell {index}"
            assert not errors, (f"{path.name}: {where} fails: {errors[0].ename}: "
                                f"{errors[0].evalue}" if errors else "")
        text = json.dumps([dict(o) for o in cell.outputs])
        for phrase in OUTPUT_PROCESS_TEXT:
            assert phrase not in text, f"{path.name} cell {index} prints {phrase!r}"

