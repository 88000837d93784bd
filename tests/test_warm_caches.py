"""`make venv`'s cache warming builds ahead exactly the quick datasets the lessons ask for."""

from __future__ import annotations

import ast
import json
import sys

from .conftest import REPO

sys.path.insert(0, str(REPO / "tools"))
from warm_caches import LESSON_BUILDS  # noqa: E402


def lesson_builds() -> set[tuple]:
    """The options (besides folder, mode and progress) of every ``build_mini_dataset`` call
    in the lessons, each as sorted ``(name, value)`` pairs."""
    found = set()
    for path in sorted((REPO / "notebooks").glob("*.ipynb")):
        for cell in json.loads(path.read_text())["cells"]:
            source = "".join(cell["source"])
            if cell["cell_type"] != "code" or "build_mini_dataset(" not in source:
                continue
            for node in ast.walk(ast.parse(source)):
                if isinstance(node, ast.Call) and ast.unparse(node.func).endswith(
                        "build_mini_dataset"):
                    found.add(tuple(sorted((k.arg, ast.literal_eval(k.value))
                                           for k in node.keywords if k.arg != "progress")))
    return found


def test_the_warmed_datasets_are_the_lessons_own():
    lessons = lesson_builds()
    assert len(lessons) == 3  # clean (09, 10, 12, 13, 15), grey video (11), noise (12)
    assert lessons == {tuple(sorted(options.items())) for options in LESSON_BUILDS.values()}
