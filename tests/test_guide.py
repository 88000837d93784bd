"""The instructor's guide (docs/instructors.md) names sections that exist and paths that fit."""

import re
import sys

from .conftest import REPO

sys.path.insert(0, str(REPO / "tools"))
import guide_minutes  # noqa: E402


def test_every_section_and_exercise_the_guide_names_exists(capsys):
    assert guide_minutes.main([]) == 0, capsys.readouterr().out
    out = capsys.readouterr().out
    totals = dict(re.findall(r"path (.+?): teaching .*together (\d+) min", out))
    # the 90-minute path fits its slot with 15 minutes left for setup and questions
    assert int(totals["90 minutes"]) <= 90 - guide_minutes.SETUP_MINUTES


def test_the_paths_the_guide_prints_are_the_ones_the_tool_computes(capsys):
    guide_minutes.main([])
    out = capsys.readouterr().out
    text = (REPO / "docs" / "instructors.md").read_text()
    paths = re.findall(r"path (.+?): teaching (\d+) min, exercises (\d+) min", out)
    assert len(paths) == 2
    for name, teach, exercises in paths:
        stated = f"{teach} of teaching"
        assert stated in text, f"the guide does not state the {name} path's {stated}"
        assert f"{exercises} of exercises" in text


def test_a_section_that_is_gone_is_reported(monkeypatch, capsys):
    plan = {**guide_minutes.PATHS["90 minutes"], "00": (["99"], [])}
    monkeypatch.setitem(guide_minutes.PATHS, "90 minutes", plan)
    assert guide_minutes.main([]) == 1
    assert "MISSING lesson 00: 99" in capsys.readouterr().out
