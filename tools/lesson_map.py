"""The lesson map: each lesson's prerequisites and measured minutes, read from its header.

Every lesson's first cell carries two lines under its goals::

    **Prerequisites:** lessons 00, 02 (or: none)
    **Run time:** 12 s in quick mode, 2.6 min in full mode (bench/RESULTS.md, "Lessons")

The prerequisites live only there; the times are copied from the "Lessons" table of
``bench/RESULTS.md`` (written by ``bench/bench_notebooks.py``), and
``tests/test_lesson_map.py`` checks that every header agrees with that table and that the
prerequisites form no cycle. ``python tools/lesson_map.py --write`` rewrites the headers'
time lines from the table after a benchmark run. The book's map page is drawn from here.
"""

from __future__ import annotations

import argparse
import re
import sys
import textwrap
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
PREREQUISITES = re.compile(r"^\*\*Prerequisites:\*\*\s*(.+?)\s*$", re.MULTILINE)
TIME = re.compile(r"^\*\*Run time:\*\*\s*(.+?) in quick mode, (.+?) in full mode\b.*$",
                  re.MULTILINE)


# A live class's time is our estimate, not a measurement: reading the Markdown at
# READING_WORDS_PER_MINUTE (a careful pace for technical text), the full-mode run, and
# MINUTES_PER_EXERCISE for each exercise.
READING_WORDS_PER_MINUTE = 120
MINUTES_PER_EXERCISE = 5
EXERCISE = re.compile(r"\s*#{2,4}\s*Exercise\s+\d")


def lessons() -> list[Path]:
    return sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))


def time_line(quick: str, full: str) -> str:
    return f'**Run time:** {quick} in quick mode, {full} in full mode (bench/RESULTS.md, "Lessons")'


def header(path: Path) -> dict:
    """``{"number", "name", "title", "goals", "prerequisites", "quick", "full"}`` of a lesson."""
    cells = nbformat.read(path, as_version=4).cells
    first = cells[0].source
    title = first.splitlines()[0].lstrip("# ").strip()
    found = PREREQUISITES.search(first)
    if found is None:
        raise ValueError(f"{path.name}: its first cell has no '**Prerequisites:**' line")
    text = found.group(1).rstrip(".")
    prerequisites = [] if text.lower() == "none" else re.findall(r"\b(\d\d)\b", text)
    time = TIME.search(first)
    if time is None:
        raise ValueError(f"{path.name}: its first cell has no '**Run time:** ... in quick "
                         "mode, ... in full mode' line")
    goals = [line[2:].strip() for line in first.split("In this notebook you will", 1)[-1]
             .splitlines() if line.startswith("- ")]
    markdown = [c.source for c in cells if c.cell_type == "markdown"]
    return {"number": path.name[:2], "name": path.name, "title": title, "goals": goals,
            "prerequisites": prerequisites, "quick": time.group(1), "full": time.group(2),
            "words": sum(len(text.split()) for text in markdown),
            "exercises": sum(bool(EXERCISE.match(text)) for text in markdown)}


def minutes(duration: str) -> float:
    """``"91 s"`` -> 1.5167, ``"2.6 min"`` -> 2.6."""
    value, unit = duration.split()
    return float(value) / {"s": 60, "min": 1, "h": 1 / 60}[unit]


def live_minutes(h: dict) -> float:
    """Our estimate of a live class on lesson header ``h``: reading + full run + exercises."""
    return (h["words"] / READING_WORDS_PER_MINUTE + minutes(h["full"])
            + MINUTES_PER_EXERCISE * h["exercises"])


def find_cycle(graph: dict[str, list[str]]) -> list[str] | None:
    """A cycle of ``graph`` ({node: [nodes it needs]}) as a list of nodes, or None."""
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for need in graph.get(node, []):
            if state.get(need) == 1:
                return path[path.index(need):] + [need]
            if need not in state and (cycle := visit(need)):
                return cycle
        state[node] = 2
        path.pop()
        return None

    for node in graph:
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def draw_graph(headers: list[dict], path: Path) -> Path:
    """Draw the prerequisite graph (lessons as boxes in rows by depth, arrows from each
    prerequisite) to a PNG at ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by_number = {h["number"]: h for h in headers}
    depth: dict[str, int] = {}

    def depth_of(n: str) -> int:
        if n not in depth:
            depth[n] = 1 + max((depth_of(p) for p in by_number[n]["prerequisites"]), default=-1)
        return depth[n]

    rows: dict[int, list[str]] = {}
    for h in headers:
        rows.setdefault(depth_of(h["number"]), []).append(h["number"])
    width = max(len(r) for r in rows.values())
    position = {n: ((i + 0.5) * width / len(r), -d) for d, r in rows.items() for i, n in
                enumerate(r)}
    fig, ax = plt.subplots(figsize=(1.9 * width + 0.4, 1.05 * len(rows) + 0.4))
    boxes = {}
    for n, (x, y) in position.items():
        label = by_number[n]["title"].split("·", 1)[-1].split(":")[0].strip()
        text = ax.text(x, y, f"{n}\n" + textwrap.fill(label, 18), ha="center", va="center",
                       fontsize=8.5, zorder=3, bbox={"boxstyle": "round,pad=0.4",
                                                     "facecolor": "#dbe6f4",
                                                     "edgecolor": "#31567f"})
        boxes[n] = text.get_bbox_patch()
    for h in headers:
        for p in h["prerequisites"]:  # from the bottom of the prerequisite's box to the top
            ax.annotate("", xy=(0.5, 1.0), xycoords=boxes[h["number"]], xytext=(0.5, 0.0),
                        textcoords=boxes[p], zorder=2,
                        arrowprops={"arrowstyle": "-|>", "color": "#555555", "lw": 1,
                                    "shrinkA": 0, "shrinkB": 1})
    ax.set_xlim(-0.2, width + 0.2)
    ax.set_ylim(-len(rows) + 0.5, 0.5)
    ax.axis("off")
    ax.set_title("Lessons and their prerequisites\n(an arrow points from a prerequisite)",
                 fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def write_time_lines(minutes: dict[str, tuple[str, str]]) -> list[str]:
    """Rewrite every lesson header's time line from ``{notebook: (quick, full)}``."""
    changed = []
    for path in lessons():
        nb = nbformat.read(path, as_version=4)
        quick, full = minutes[path.name]
        new = TIME.sub(time_line(quick, full), nb.cells[0].source)
        if new != nb.cells[0].source:
            nb.cells[0].source = new
            nbformat.write(nb, path)
            changed.append(path.name)
    return changed


def bench_times() -> dict[str, tuple[str, str]]:
    """``{notebook: (quick, full)}`` cells of the "Lessons" table of bench/RESULTS.md."""
    sys.path.insert(0, str(ROOT))
    from e2vlib.experiments.reports import bench_table

    return {row["notebook"]: (row["quick"], row["full"]) for row in bench_table("Lessons")
            if row["notebook"].endswith(".ipynb")}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true",
                        help="rewrite the headers' time lines from bench/RESULTS.md")
    args = parser.parse_args(argv)
    if args.write:
        print("updated:", write_time_lines(bench_times()) or "nothing")
    for h in map(header, lessons()):
        print(f"{h['number']}  needs {', '.join(h['prerequisites']) or '-':12s} "
              f"{h['quick']:>8s} quick {h['full']:>8s} full  {h['title']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
