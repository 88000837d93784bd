"""House rules for the lessons: numbered, stripped of outputs, a parameters cell, a summary."""

import json
import re

import pytest

from .conftest import REPO

NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))


def test_lessons_exist_and_are_numbered():
    names = [nb.name for nb in NOTEBOOKS]
    assert "01_events.ipynb" in names and "02_event_frames.ipynb" in names
    # lessons are numbered; the one appendix holds the lessons' "going further" sections
    assert all(re.fullmatch(r"(\d\d|appendix)_[a-z0-9_]+\.ipynb", n) for n in names), names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_is_committable(path):
    nb = json.loads(path.read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    with_output = [i for i, c in enumerate(code) if c.get("outputs") or c.get("execution_count")]
    assert not with_output, f"{path.name}: strip outputs (make strip) from code cells {with_output}"
    assert nb["metadata"]["kernelspec"]["name"] == "python3"
    tags = code[0].get("metadata", {}).get("tags", [])
    assert "parameters" in tags, "the first code cell must be tagged parameters"
    assert 'os.environ.get("E2V_QUICK") == "1"' in "".join(code[0]["source"])
    text = "".join("".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "markdown")
    assert "In this notebook you will" in text
    assert "## Summary" in text and "## Exercises" in text
    assert "set_jupyter_backend" not in json.dumps(nb)
