"""Pages of the book generated from the repository: the README, the lesson map, the paper.

``write_pages(out)`` writes ``readme.md``, ``map.md`` (with ``lesson_graph.png``),
``paper.md`` and ``live.inc`` (the front page's table of live-class times, included by
``book/index.md``) to ``out`` (``book/_generated/``, git-ignored). Nothing here is typed twice: the
README is converted, the map is read from the lesson headers and bench/RESULTS.md
(``tools/lesson_map.py``), the paper's facts from ``e2vlib.paper``.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))

FIGURE_BLOCK = re.compile(
    r'<p align="center">\s*<img src="(?P<src>[^"]+)"(?: width="(?P<width>[^"]+)")?'
    r' alt="(?P<alt>[^"]*)"><br>\s*<em>(?P<caption>.*?)</em>\s*</p>', re.DOTALL)


def _write(path: Path, text: str) -> None:
    """Write only when changed, so that Sphinx does not rebuild an unchanged page."""
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def readme_page() -> str:
    """README.md with its HTML figures as MyST figures and its paths seen from _generated/."""
    text = (ROOT / "README.md").read_text()

    def figure(match: re.Match) -> str:
        caption = re.sub(r"<code>(.*?)</code>", r"`\1`", match["caption"]).replace("&ge;", "≥")
        width = f":width: {match['width']}\n" if match["width"] else ""
        return (f"```{{figure}} ../../{match['src']}\n:alt: {match['alt']}\n{width}\n"
                f"{caption}\n```")

    text = text.replace("# e2v notebooks\n", "# About the collection (README)\n", 1)
    text = FIGURE_BLOCK.sub(figure, text)
    text = re.sub(r"\]\((?!https?:|#)([^)]+)\)", r"](../../\1)", text)
    return text


def _headers() -> list[dict]:
    from lesson_map import find_cycle, header, lessons

    headers = [header(p) for p in lessons()]
    cycle = find_cycle({h["number"]: h["prerequisites"] for h in headers})
    if cycle:
        raise ValueError(f"the lessons' prerequisites form a cycle: {' -> '.join(cycle)}")
    return headers


def live_page() -> str:
    """The front page's table: each lesson's live-class estimate and how it is made."""
    from lesson_map import MINUTES_PER_EXERCISE, READING_WORDS_PER_MINUTE, live_minutes

    headers = _headers()
    rows = ["| lesson | words to read | exercises | run (full mode) | live class, about |",
            "| --- | --- | --- | --- | --- |"]
    for h in headers:
        rows.append(f"| [{h['title']}](../notebooks/{h['name']}) | {h['words']:,} | "
                    f"{h['exercises']} | {h['full']} | {live_minutes(h):.0f} min |")
    total = sum(live_minutes(h) for h in headers)
    return (f"{chr(10).join(rows)}\n\nA live class is our estimate, not a measurement: reading "
            f"at {READING_WORDS_PER_MINUTE} words a minute, the full-mode run of the \"Lessons\" "
            f"table of `bench/RESULTS.md`, and {MINUTES_PER_EXERCISE} minutes per exercise; all "
            f"{len(headers)} lessons come to about {total / 60:.1f} hours.\n")


def map_page(out: Path) -> str:
    from lesson_map import draw_graph

    headers = _headers()
    draw_graph(headers, out / "lesson_graph.png")
    rows = ["| lesson | prerequisites | quick mode | full mode | you will |",
            "| --- | --- | --- | --- | --- |"]
    for h in headers:
        needs = ", ".join(h["prerequisites"]) or "none"
        goals = "; ".join(g.rstrip(";.") for g in h["goals"][:3])
        rows.append(f"| [{h['title']}](../../notebooks/{h['name']}) | {needs} | {h['quick']} | "
                    f"{h['full']} | {goals} |")
    alt = "; ".join(f"{h['number']} needs {' and '.join(h['prerequisites'])}"
                    for h in headers if h["prerequisites"])
    return f"""# Lesson map

Every lesson runs on its own (each loads what it needs from `data_small/`, including a trained
checkpoint); the arrows say which lessons explain what a later one builds on. The times are
measured wall times of a whole run, kernel start included, in quick mode (`E2V_QUICK=1`, what CI
runs) and in full mode (a student's run), from the "Lessons" table of `bench/RESULTS.md`; a live
class takes longer, for reading and the exercises (the front page estimates how much).

```{{figure}} lesson_graph.png
:alt: The lessons as boxes, with an arrow from each prerequisite: {alt}.

The prerequisite graph of the lessons.
```

{chr(10).join(rows)}
"""


def paper_page() -> str:
    sys.path.insert(0, str(ROOT))
    from e2vlib import paper

    return f"""# The paper's facts

Chen, Chung, Tan, Chen, *Dense Voxel 3D Reconstruction Using a Monocular Event Camera*, ICVR
2023, pp. 30-35, doi:10.1109/ICVR57957.2023.10169359. The lessons read these numbers from
`e2vlib.paper` (`paper.describe()` prints this table); none is retyped.

## What the paper states

{paper.describe(ours=False)}

## Our choices, where the paper is silent

{paper.describe(ours=True)}

## Citing

The paper this collection rebuilds:

```bibtex
@inproceedings{{chen2023e2v,
  author    = {{Chen, Haodong and Chung, Vera and Tan, Li and Chen, Xiaoming}},
  title     = {{Dense Voxel 3D Reconstruction Using a Monocular Event Camera}},
  booktitle = {{International Conference on Virtual Reality (ICVR)}},
  pages     = {{30--35}},
  year      = {{2023}},
  doi       = {{10.1109/ICVR57957.2023.10169359}}
}}
```

The collection itself: see `CITATION.cff` in the repository.
"""


def write_pages(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    _write(out / "readme.md", readme_page())
    _write(out / "map.md", map_page(out))
    _write(out / "live.inc", live_page())
    _write(out / "paper.md", paper_page())
