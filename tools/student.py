"""Student copies of the lessons: every cell tagged ``solution`` becomes a "your turn" stub.

Exercises follow one shape (checked by tests/test_exercises.py): a markdown cell opening with
``### Exercise N`` (``### Exercise N (experiment)`` for an experiment), one or more code
cells tagged ``solution``, then a code cell tagged ``check`` whose asserts pass with the
solution and fail without it. ``make student`` writes the copies to ``student/``
(git-ignored); instructors hand those out, and the check cells tell a student when an answer
is right.

Usage: ``python tools/student.py [--out student] notebooks/*.ipynb``
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import nbformat

EXERCISE = re.compile(r"^\s*#{2,4}\s*Exercise\s+(\d+)", re.IGNORECASE)


def stub_source(number: int | str) -> str:
    """The code a student sees in place of a solution."""
    return (f"# Exercise {number}: your turn. Replace this cell with your answer, then run "
            "the check cell below.\n"
            f'raise NotImplementedError("Your turn: write your answer to exercise {number} '
            'here, then run the check cell below")\n')


def exercises(nb) -> list[dict]:
    """``[{"number", "question", "experiment", "solutions": [i...], "checks": [i...]}]``."""
    found: list[dict] = []
    for index, cell in enumerate(nb.cells):
        tags = cell.get("metadata", {}).get("tags", [])
        match = EXERCISE.match(cell.source) if cell.cell_type == "markdown" else None
        if match:
            found.append({"number": int(match.group(1)), "question": index,
                          "experiment": "(experiment)" in cell.source.splitlines()[0].lower(),
                          "solutions": [], "checks": []})
        elif found and cell.cell_type == "code" and "solution" in tags:
            found[-1]["solutions"].append(index)
        elif found and cell.cell_type == "code" and "check" in tags:
            found[-1]["checks"].append(index)
    return found


def student_copy(nb):
    """A copy of ``nb`` whose solution cells are stubs that raise a "your turn" error."""
    copy = nbformat.from_dict(nb)
    number_of = {}
    for exercise in exercises(copy):
        for index in exercise["solutions"]:
            number_of[index] = exercise["number"]
    for index, cell in enumerate(copy.cells):
        if "solution" in cell.get("metadata", {}).get("tags", []):
            cell.source = stub_source(number_of.get(index, "?"))
            cell.outputs = []
            cell.execution_count = None
    return copy


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, default=Path("student"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for path in args.notebooks:
        nb = nbformat.read(path, as_version=4)
        target = args.out / path.name
        nbformat.write(student_copy(nb), target)
        print(f"wrote {target} ({len(exercises(nb))} exercises)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
