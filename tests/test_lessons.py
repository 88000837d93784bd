"""Every lesson runs once, top to bottom, in quick mode; in that same kernel each exercise's check
is shown to fail on the student copy's stub and on a plausible wrong answer before the solution
makes it pass.

Before each exercise's first solution cell the run inserts four probe cells: the "your turn"
stub of ``tools/student.py`` (it must raise ``NotImplementedError``), a copy of the check (it
must fail), the wrong answer from ``tests/wrong_answers/lesson_NN.py`` (it must run) and a copy
of the check again (it must fail with an ``AssertionError``). Then the solution and the real
check run as in the lesson, so every later cell sees the state it expects. Any other cell that
raises fails the test at once, naming the cell, as nbmake would. ``make test`` runs this file
once per lesson; ``make notebooks`` runs only this file.
"""

from __future__ import annotations

import json
import os
import re
import sys

import nbformat
import pytest

from .conftest import REPO
from .test_lesson_text import WORDS

sys.path.insert(0, str(REPO / "tools"))
from student import exercises, student_copy  # noqa: E402

LESSONS = sorted((REPO / "notebooks").glob("[0-9][0-9]_*.ipynb"))
APPENDIX = REPO / "notebooks" / "appendix_going_further.ipynb"  # runs like a lesson
OUTPUT_PROCESS_TEXT = ("-dirty", "../shared")
CELL_TIMEOUT_S = 600
ANSI = re.compile(r"\x1b\[[0-9;]*m")


def wrong_answers(path) -> dict[int, str]:
    """``{exercise number: source}`` from ``tests/wrong_answers/lesson_NN.py`` (the appendix:
    ``tests/wrong_answers/appendix_going_further.py``)."""
    import importlib

    name = f"lesson_{path.name[:2]}" if path.name[:2].isdigit() else path.stem
    return importlib.import_module(f"tests.wrong_answers.{name}").WRONG


def generated_words(cells) -> int:
    """Words of the Markdown that a lesson's own code cells displayed
    (``display(Markdown(...))``); the inserted probe cells do not count."""
    return sum(len("".join(output.get("data", {}).get("text/markdown", "")).split())
               for cell in cells if cell.cell_type == "code" and "lesson_cell" in cell.metadata
               for output in cell.get("outputs", []))


def lesson_with_probes(nb, wrong: dict[int, str]):
    """``(run, expect)``: the lesson's cells with the four probe cells before each exercise's
    first solution, and ``{run cell index: (exercise number, what must happen)}`` for those."""
    stubs = student_copy(nb)
    first_solution = {min(e["solutions"]): e for e in exercises(nb)}
    cells, expect = [], {}
    for index, cell in enumerate(nb.cells):
        e = first_solution.get(index)
        if e is not None:
            check = nb.cells[e["checks"][0]].source
            probes = [(stubs.cells[index].source, "stub"), (check, "fails on the stub"),
                      (wrong[e["number"]], "wrong answer"), (check, "fails on the wrong answer")]
            for source, what in probes:
                expect[len(cells)] = (e["number"], what)
                cells.append(nbformat.v4.new_code_cell(source))
        cell.metadata["lesson_cell"] = index
        cells.append(cell)
    run = nbformat.from_dict(nb)
    run.cells = cells
    return run, expect


def verdict(cell, expected: tuple[int, str] | None) -> str | None:
    """What is wrong with an executed cell's outputs, or None."""
    errors = [o for o in cell.outputs if o.output_type == "error"]
    text = json.dumps([dict(o) for o in cell.outputs])
    printed = [phrase for phrase in OUTPUT_PROCESS_TEXT if phrase in text]
    if printed:
        return f"prints {printed[0]!r}"
    if expected is None or expected[1] == "wrong answer":
        if not errors:
            return None
        trace = ANSI.sub("", "\n".join(errors[0].get("traceback", [])))
        return f"fails:\n{cell.source}\n{trace or errors[0].ename + ': ' + errors[0].evalue}"
    if not errors:
        return f"the check passes without the solution ({expected[1]})"
    ename, evalue = errors[0].ename, errors[0].evalue
    if expected[1] == "stub" and (ename != "NotImplementedError" or "Your turn" not in evalue):
        return f"the stub raises {ename}: {evalue} instead of the 'Your turn' NotImplementedError"
    if expected[1] == "fails on the wrong answer" and ename != "AssertionError":
        return f"the check fails with {ename} instead of an assertion: {evalue}"
    return None


def first_problem(nb, wrong: dict[int, str], folder, ran: list | None = None) -> str | None:
    """Run ``nb`` with its probes in one kernel started in ``folder``; stop at the first cell
    whose outputs are wrong and say which cell and why, or return None when all is well.
    ``ran``, when given, receives the executed cells."""
    from nbclient import NotebookClient

    run, expect = lesson_with_probes(nb, wrong)
    if ran is not None:
        ran.extend(run.cells)
    # the verdict is in once the last cell ran: stop the kernel at once rather than wait
    # about 1.3 s for a graceful exit (torch's teardown), 17 times in make test
    client = NotebookClient(run, timeout=CELL_TIMEOUT_S, kernel_name="python3",
                            allow_errors=True, shutdown_kernel="immediate",
                            resources={"metadata": {"path": str(folder)}})
    with client.setup_kernel():
        for index, cell in enumerate(run.cells):
            if cell.cell_type != "code":
                continue
            client.execute_cell(cell, index)
            problem = verdict(cell, expect.get(index))
            if problem is None:
                continue
            if index in expect:
                number, what = expect[index]
                return f"exercise {number}, {what} probe: {problem}"
            return f"cell {cell.metadata['lesson_cell']} {problem}"
    return None


@pytest.mark.parametrize("path", [*LESSONS, APPENDIX], ids=lambda p: p.name)
def test_lesson_runs_and_its_checks_reject_stubs_and_wrong_answers(path, monkeypatch):
    """... and the Markdown its code generates fits the lesson's share of the word budget
    (``WORDS`` in tests/test_lesson_text.py, which checks the typed share)."""
    monkeypatch.setenv("E2V_QUICK", os.environ.get("E2V_QUICK", "1"))
    monkeypatch.setenv("PYVISTA_JUPYTER_BACKEND",
                       os.environ.get("PYVISTA_JUPYTER_BACKEND", "static"))
    nb = nbformat.read(path, as_version=4)
    ran = []
    problem = first_problem(nb, wrong_answers(path), path.parent, ran)
    if problem is not None:
        pytest.fail(f"{path.name}: {problem}", pytrace=False)
    if path in LESSONS:
        words, budget = generated_words(ran), WORDS[path.name[:2]][1]
        print(f"{path.name}: {words} words of generated Markdown (budget {budget})")
        assert words <= budget, (f"{path.name} generates {words} words of Markdown; its share "
                                 f"of the budget is {budget} (tests/test_lesson_text.py)")


def _tiny_lesson(check: str, after: str = "print('done')"):
    """Exercise 1 asks for ``answer = 6 * 7``; ``check`` is its check cell."""
    new = nbformat.v4
    cells = [new.new_markdown_cell("### Exercise 1\nCompute 6 x 7."),
             new.new_code_cell("answer = 6 * 7", metadata={"tags": ["solution"]}),
             new.new_code_cell(check, metadata={"tags": ["check"]}),
             new.new_code_cell(after)]
    return new.new_notebook(cells=cells)


@pytest.mark.parametrize(("check", "after", "problem"), [
    ("assert answer == 42", "print('done')", None),
    ("assert answer == 42", "1 / 0", "cell 3 fails:\n1 / 0"),
    ("assert True", "print('done')", "exercise 1, fails on the stub probe: the check passes"),
], ids=["good", "cell error", "check passes on the stub"])
def test_the_runner_names_the_first_problem(check, after, problem, tmp_path):
    """A tiny lesson run in a real kernel (wrong answer: ``answer = 41``)."""
    found = first_problem(_tiny_lesson(check, after), {1: "answer = 41\n"}, tmp_path)
    if problem is None:
        assert found is None
    else:
        assert found is not None and found.startswith(problem), found


def _ran(*outputs):
    cell = nbformat.v4.new_code_cell("answer = 41")
    cell.outputs = [nbformat.v4.new_output(**o) for o in outputs]
    return cell


def _error(ename: str, evalue: str = "") -> dict:
    return {"output_type": "error", "ename": ename, "evalue": evalue, "traceback": []}


@pytest.mark.parametrize(("cell", "expected", "problem"), [
    (_ran(), None, None),
    (_ran(), (1, "wrong answer"), None),
    (_ran(_error("AssertionError")), (1, "fails on the wrong answer"), None),
    (_ran(_error("NameError", "answer")), (1, "fails on the stub"), None),
    (_ran(_error("NotImplementedError", "Your turn: write")), (1, "stub"), None),
    (_ran(), (1, "fails on the wrong answer"), "the check passes without the solution"),
    (_ran(_error("ZeroDivisionError")), (1, "fails on the wrong answer"),
     "the check fails with ZeroDivisionError instead of an assertion"),
    (_ran(_error("ValueError", "x")), (1, "stub"), "the stub raises ValueError"),
    (_ran(_error("KeyError", "'a'")), (1, "wrong answer"), "fails:\nanswer = 41\nKeyError: 'a'"),
    (_ran({"output_type": "stream", "name": "stdout", "text": "v1.0-dirty"}), None,
     "prints '-dirty'"),
], ids=["fine", "wrong answer runs", "assertion", "stub check fails", "stub raises",
        "check passes on wrong answer", "check crashes", "stub wrong error", "wrong answer fails",
        "process text"])
def test_verdict_on_each_kind_of_cell(cell, expected, problem):
    found = verdict(cell, expected)
    if problem is None:
        assert found is None
    else:
        assert found is not None and found.startswith(problem), found
