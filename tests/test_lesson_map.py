"""The lesson map: every lesson's header agrees with the bench table, and the prerequisite
graph is a real one (known lessons, earlier numbers, no cycle)."""

from __future__ import annotations

import sys

import pytest

from .conftest import REPO

sys.path.insert(0, str(REPO / "tools"))
import lesson_map  # noqa: E402

HEADERS = [lesson_map.header(path) for path in lesson_map.lessons()]


def test_every_lesson_has_a_header():
    assert [h["name"] for h in HEADERS] == [p.name for p in lesson_map.lessons()]
    assert len(HEADERS) >= 13
    for h in HEADERS:
        assert h["goals"], f"{h['name']}: no 'In this notebook you will' goals"


@pytest.mark.parametrize("h", HEADERS, ids=lambda h: h["name"])
def test_header_run_time_matches_the_bench_table(h):
    quick, full = lesson_map.bench_times()[h["name"]]
    assert (h["quick"], h["full"]) == (quick, full), (
        f"{h['name']}: header says {h['quick']} / {h['full']}, bench/RESULTS.md 'Lessons' says "
        f"{quick} / {full}; run `python tools/lesson_map.py --write`")


def test_the_bench_table_times_every_lesson_and_nothing_else():
    assert sorted(lesson_map.bench_times()) == [h["name"] for h in HEADERS]


def test_prerequisites_are_earlier_known_lessons():
    numbers = {h["number"] for h in HEADERS}
    for h in HEADERS:
        for need in h["prerequisites"]:
            assert need in numbers, f"{h['name']} needs lesson {need}, which does not exist"
            assert need < h["number"], f"{h['name']} needs a later lesson, {need}"
    assert HEADERS[0]["prerequisites"] == [], "lesson 00 is where a student starts"


def test_the_prerequisite_graph_has_no_cycle():
    graph = {h["number"]: h["prerequisites"] for h in HEADERS}
    assert lesson_map.find_cycle(graph) is None


def test_find_cycle_finds_a_known_cycle_and_accepts_a_chain():
    assert lesson_map.find_cycle({"a": ["b"], "b": ["c"], "c": []}) is None
    assert lesson_map.find_cycle({"a": ["b"], "b": ["c"], "c": ["a"]}) == ["a", "b", "c", "a"]
    assert lesson_map.find_cycle({"x": [], "y": ["y"]}) == ["y", "y"]


def test_header_parses_prerequisites_and_rejects_a_missing_line(tmp_path):
    import nbformat

    cell = ("# 99 · A test lesson\n\n**In this notebook you will:**\n\n- learn one thing;\n\n"
            "**Prerequisites:** lessons 02, 07\n\n" + lesson_map.time_line("4 s", "1.5 min"))
    path = tmp_path / "99_test.ipynb"
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell(cell)]), path)
    h = lesson_map.header(path)
    assert (h["prerequisites"], h["quick"], h["full"]) == (["02", "07"], "4 s", "1.5 min")
    assert h["goals"] == ["learn one thing;"]
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell(
        cell.replace("**Prerequisites:** lessons 02, 07", ""))]), path)
    with pytest.raises(ValueError, match="Prerequisites"):
        lesson_map.header(path)
