"""Recorded results, read the same way by every lesson: study records and bench figures.

Lessons never retype a recorded number; they read it from here:

- :func:`load_results` reads ``experiments/results/STUDY.json`` (a record of
  :func:`e2vlib.experiments.run_study`) and names the command that makes it when it is missing
  (it and the other study readers live in :mod:`e2vlib.experiments.records`);
- :func:`report` prints a study's table (mean ± std and 95 % interval per config), each
  config against a baseline by the one rule of :func:`is_real_difference`, and where and how
  long the runs trained; :func:`finding` says the result in one sentence;
- :func:`bench_section` and :func:`bench_table` read ``bench/RESULTS.md``, the benchmarks'
  figures, by section title, with the machine the section was measured on.

The rule for "a real difference" (95 % intervals that do not overlap) is stated once, in
:mod:`e2vlib.experiments.records` and lesson 09.

Examples
--------
>>> rows = [{"config": "a", "n": 3, "mean": 0.40, "ci95": (0.35, 0.45), "values": [0.4] * 3},
...         {"config": "b", "n": 3, "mean": 0.55, "ci95": (0.50, 0.60), "values": [0.55] * 3},
...         {"config": "c", "n": 3, "mean": 0.44, "ci95": (0.40, 0.48), "values": [0.44] * 3}]
>>> is_real_difference(rows[1], rows[0]), is_real_difference(rows[2], rows[0])
(True, False)
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from e2vlib.experiments.records import (
    MissingResultsError,
    finding,
    load_results,
    minutes_per_run,
    recorded_on,
    report,
    runs_of,
)
from e2vlib.experiments.summary import is_real_difference

__all__ = ["MissingResultsError", "load_results", "is_real_difference", "runs_of",
           "minutes_per_run", "recorded_on", "finding", "report", "bench_section",
           "bench_machine", "bench_table", "lesson_minutes"]

REPO = Path(__file__).resolve().parents[2]
BENCH_RESULTS = REPO / "bench" / "RESULTS.md"


# ----------------------------------------------------------------------------- bench figures


def bench_section(title: str, path: str | os.PathLike | None = None) -> str:
    """The text of the ``## title`` section of ``bench/RESULTS.md`` (heading left out).

    ``title`` matches the start of a section heading. Raises ``KeyError`` listing the
    sections when none matches.
    """
    text = Path(path if path is not None else BENCH_RESULTS).read_text()
    sections = re.split(r"^## ", text, flags=re.MULTILINE)[1:]
    for section in sections:
        heading, _, body = section.partition("\n")
        if heading.strip().startswith(title):
            return body.strip()
    names = [s.partition("\n")[0].strip() for s in sections]
    raise KeyError(f"no section {title!r} in bench/RESULTS.md; sections: {names}")


def bench_machine(title: str, path: str | os.PathLike | None = None) -> str:
    """The ``Machine:`` line of a bench section (the CPU its figures were measured on)."""
    match = re.search(r"Machine: ([^\n]*?)(?:, Python|\.\s*$|\n)", bench_section(title, path))
    return match.group(1).strip() if match else "unknown machine"


def bench_table(title: str, path: str | os.PathLike | None = None, index: int = 0) -> list[dict]:
    """The ``index``-th markdown table of a bench section as ``[{column: cell}]`` (text cells,
    with ``**`` and backticks removed)."""
    tables, current = [], []
    for line in bench_section(title, path).splitlines() + [""]:
        if line.startswith("|"):
            cells = line.strip().strip("|").split("|")
            current.append([cell.replace("**", "").replace("`", "").strip() for cell in cells])
        elif current:
            tables.append(current)
            current = []
    if index >= len(tables):
        raise KeyError(f"section {title!r} of bench/RESULTS.md has {len(tables)} tables")
    header, _, *body = tables[index]
    return [dict(zip(header, row, strict=False)) for row in body]


def lesson_minutes(path: str | os.PathLike | None = None) -> dict[str, tuple[float, float]]:
    """``{notebook: (quick minutes, full minutes)}`` from the "Lessons" bench table."""

    def minutes(cell: str) -> float:
        value, unit = cell.split()
        return float(value) / 60 if unit == "s" else float(value)

    return {row["notebook"]: (minutes(row["quick"]), minutes(row["full"]))
            for row in bench_table("Lessons", path) if row["notebook"].endswith(".ipynb")}
