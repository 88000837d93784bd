"""The lessons' prose: no typed computed numbers, no text about how the project was made,
and a word budget.

A number in a lesson's Markdown that comes from a computation must be printed by code (a
Markdown output rendered with ``IPython.display.Markdown``) or asserted beside it. The check
below reads every decimal number, percentage and duration of every static Markdown cell and
accepts it only when it is

- a fact of the paper (a value of ``e2vlib.paper``),
- one of the few settings listed in ``SETTINGS`` (values a student sets, not results),
- or written in an ``assert`` of the code cell just before or just after the Markdown cell.

Exercise questions are exempt: their numbers are the givens of a problem.
"""

from __future__ import annotations

import json
import re

import pytest

from e2vlib import paper

from .conftest import REPO

LESSONS = sorted((REPO / "notebooks").glob("[0-9][0-9]_*.ipynb"))
RUN_TIME_LINE = re.compile(r"^\*\*Run time:\*\*.*$", re.MULTILINE)
WORD_BUDGET = 21_500
"""Words of prose over all lessons: Markdown typed in the notebooks plus Markdown their code
generates (``display(Markdown(...))``)."""
WORDS = {  # lesson -> (typed Markdown words, generated Markdown words) it may hold
    "00": (1138, 170), "01": (1086, 83), "02": (1362, 83), "03": (1499, 250),
    "04": (1169, 146), "05": (1366, 130), "06": (1487, 236), "07": (1472, 102),
    "08": (1171, 3), "09": (1021, 200), "10": (1021, 246), "11": (840, 240),
    "12": (875, 252), "13": (956, 300),
    "14": (915, 200),
    "15": (1251, 230),
}
"""Each lesson's share of :data:`WORD_BUDGET`; tests/test_lessons.py checks the generated
share of every lesson it runs."""

# Settings a lesson names (inputs the student can change), not results of a computation.
SETTINGS = {
    "0.1", "0.2", "0.3", "0.4", "0.5",  # thresholds and contrast thresholds a lesson sets
    "0.05", "0.95",  # the threshold sweep's ends
    "1e-3", "0.001",  # log epsilon of the simulator
    "2.5", "0.25",  # the 200 x 2.5 ms config, the 0.25x data_scale config
    "95", "1", "20", "50", "100",  # "95 % interval", F@1 %, F@20 %, 50 %, 100 %
    "0.975",  # Student's t quantile of a 95 % interval
}

# Words that narrate how the project was built: a student cannot use them.
PROCESS_TEXT = (
    "session", "earlier build", "first written", "being made", "prototype of this project",
    "throw-away prototype", "timed in another", "under load", "used to be", "-dirty",
    "../shared", "shared/paper.md", "this project was", "we later", "were later", "now also",
)

NUMBER = re.compile(
    r"(?<![\w.@^_/\\-])"  # not part of a name, an IoU@0.3 key, an exponent or a path
    r"(?:(\d[\d,]*\.\d+|\.\d+)(?:\s?%)?"  # 0.346, .346, 14.1, 2.5 %
    r"|(\d[\d,]*)\s?%"  # 56 %
    r"|(\d[\d,]*)\s?(?:min|minutes|h|hours|s|seconds)\b"  # 41 min, 11 minutes, 3 h, 90 s
    r"|\d{1,3}(?:,\d{3})+)"  # counts such as 71,035
    r"(?![\w.]*\d)"
)
CODE_SPAN = re.compile(r"`[^`]*`|```.*?```", re.DOTALL)
LINK_TARGET = re.compile(r"\]\([^)]*\)")


def _paper_values() -> set[str]:
    """Every number in ``e2vlib.paper`` as it may be written (0.346, .346, 34.6, 149,155,905)."""
    values: set[float] = set()

    def walk(value):
        if isinstance(value, bool):
            return
        if isinstance(value, (int, float)):
            values.add(float(value))
        elif isinstance(value, dict):
            for v in value.values():
                walk(v)
        elif isinstance(value, (tuple, list)):
            for v in value:
                walk(v)

    for name in dir(paper):
        if name.isupper():
            walk(getattr(paper, name))
    values |= {v / 1e6 for v in (paper.DT_US, paper.RECORDING_US)}  # 0.005 s, 0.5 s
    values |= {v / 1e3 for v in (paper.DT_US,)}  # 5 ms
    values |= {v * 100 for v in list(values) if v < 1}  # 34.6 %
    values |= {v / 1e6 for v in (paper.N_PARAMETERS,)}  # 149.16 M
    written = set()
    for v in values:
        written |= {repr(v), f"{v:g}", f"{v:,g}", f"{v:.3f}".rstrip("0").rstrip(".")}
        if v == int(v):
            written.add(f"{v:,.0f}")
    written |= {w.lstrip("0") for w in written if w.startswith("0.")}
    return written


PAPER_VALUES = _paper_values()


def _plain(text: str) -> str:
    return LINK_TARGET.sub("]", CODE_SPAN.sub(" ", text))


def _asserted(cell: dict | None) -> str:
    if cell is None or cell["cell_type"] != "code":
        return ""
    return "\n".join(line for line in "".join(cell["source"]).splitlines() if "assert" in line)


def _forms(number: str) -> set[str]:
    """How an asserted number may be written: 56 % as 56 or 0.56; 1,234 as 1234 or 1_234."""
    bare = number.replace(",", "").replace("%", "").strip()
    forms = {bare, bare.replace(",", "_"), number.replace(",", "_")}
    if number.endswith("%"):
        try:
            forms |= {f"{float(bare) / 100:g}", f"{float(bare) / 100:.3f}".rstrip("0")}
        except ValueError:
            pass
    if bare.startswith("."):
        forms.add("0" + bare)
    return forms


def typed_numbers(path) -> list[tuple[int, str, str]]:
    """``[(cell index, number, the sentence around it)]`` of numbers the rule does not accept."""
    cells = json.loads(path.read_text())["cells"]
    found = []
    for index, cell in enumerate(cells):
        source = "".join(cell["source"])
        if cell["cell_type"] != "markdown" or re.match(r"\s*#{2,4}\s*Exercise", source):
            continue
        if index == 0:  # the header's run time is checked against bench/RESULTS.md
            source = RUN_TIME_LINE.sub("", source)  # by tests/test_lesson_map.py
        before = next((c for c in reversed(cells[:index]) if c["cell_type"] == "code"), None)
        after = next((c for c in cells[index + 1:] if c["cell_type"] == "code"), None)
        asserted = _asserted(before) + "\n" + _asserted(after)
        for match in NUMBER.finditer(_plain(source)):
            number = match.group(0).strip()
            value = re.sub(r"\s?(%|min|minutes|h|hours|s|seconds)$", "", number).replace(",", "")
            if value in SETTINGS or value in PAPER_VALUES or value.lstrip("0") in PAPER_VALUES:
                continue
            if any(re.search(rf"(?<![\d.]){re.escape(f)}(?!\d)", asserted)
                   for f in _forms(number)):
                continue
            start = max(0, match.start() - 50)
            found.append((index, number, _plain(source)[start:match.end() + 30].replace("\n", " ")))
    return found


@pytest.mark.parametrize("path", LESSONS, ids=lambda p: p.name)
def test_every_number_in_the_prose_is_printed_or_asserted(path):
    found = typed_numbers(path)
    listing = "\n".join(f"  cell {i}: {n!r} in '...{context}...'" for i, n, context in found)
    assert not found, (f"{path.name}: {len(found)} typed numbers; print them from code "
                       "(IPython.display.Markdown) or assert them in the next code cell:\n"
                       f"{listing}")


@pytest.mark.parametrize("path", LESSONS, ids=lambda p: p.name)
def test_no_text_about_how_the_project_was_made(path):
    cells = json.loads(path.read_text())["cells"]
    hits = [(i, phrase) for i, cell in enumerate(cells) for phrase in PROCESS_TEXT
            if phrase in "".join(cell["source"]).lower()]
    assert not hits, f"{path.name}: process text a student cannot use (cell, phrase): {hits}"


def markdown_words(path) -> int:
    cells = json.loads(path.read_text())["cells"]
    return sum(len("".join(c["source"]).split()) for c in cells if c["cell_type"] == "markdown")


def test_the_shares_add_up_to_the_collection_budget_and_cover_every_lesson():
    assert sorted(WORDS) == [p.name[:2] for p in LESSONS]
    total = sum(typed + generated for typed, generated in WORDS.values())
    assert total <= WORD_BUDGET, f"the lessons' shares add up to {total:,} words"


def test_each_lesson_fits_its_share_of_typed_words():
    counts = {p.name: markdown_words(p) for p in LESSONS}
    print("\nMarkdown words typed per lesson (share):")
    for name, n in counts.items():
        print(f"  {name:48s} {n:6,d} ({WORDS[name[:2]][0]:,})")
    print(f"  {'all lessons':48s} {sum(counts.values()):6,d}")
    over = {name: n for name, n in counts.items() if n > WORDS[name[:2]][0]}
    assert not over, f"over their share of typed words: {over}"


def test_the_number_rule_catches_a_typed_number_and_accepts_an_asserted_one(tmp_path):
    def notebook(markdown: str, code: str) -> object:
        path = tmp_path / "nb.ipynb"
        path.write_text(json.dumps({"cells": [
            {"cell_type": "markdown", "source": [markdown], "metadata": {}},
            {"cell_type": "code", "source": [code], "metadata": {}, "outputs": []}]}))
        return path

    typed = notebook("The run took 41 min and scored 0.583 (56 % of pixels).", "x = 1")
    assert [n for _, n, _ in typed_numbers(typed)] == ["41 min", "0.583", "56 %"]
    checked = notebook("It scored 0.583 on 56 % of pixels.",
                       "assert round(score, 3) == 0.583 and round(share, 2) == 0.56")
    assert typed_numbers(checked) == []
    facts = notebook("The paper's E2V scores 0.346 at IoU@0.35 with `lr = 0.123`.", "")
    assert typed_numbers(facts) == []
