"""Recorded results, read the same way by every lesson: study records and bench figures.

Lessons never retype a recorded number; they read it from here.

- :func:`load_results` reads ``experiments/results/STUDY.json`` (a record of
  :func:`~e2vlib.experiments.run_study`) and names the command that makes it when it is
  missing; :func:`runs_of`, :func:`minutes_per_run` and :func:`recorded_on` read its runs;
  :func:`report` prints a study's table (mean ± std and 95 % interval per config), each
  config against a baseline by the one rule of :func:`~e2vlib.experiments.is_real_difference`,
  and where and how long the runs trained; :func:`finding` says the result in one sentence.
- :func:`bench_section`, :func:`bench_machine`, :func:`bench_table` and
  :func:`lesson_minutes` read ``bench/RESULTS.md``, the benchmarks' figures, by section
  title, with the machine the section was measured on.

The rule for "a real difference" is stated once, here and in lesson 09: two configs differ
beyond the seed spread only when their 95 % intervals (Student's t over the seeds) do not
overlap. With 3 seeds it is a conservative reading; a difference inside it is not a proof
of equality either.

Examples
--------
>>> rows = [{"config": "a", "n": 3, "mean": 0.40, "ci95": (0.35, 0.45), "values": [0.4] * 3},
...         {"config": "b", "n": 3, "mean": 0.55, "ci95": (0.50, 0.60), "values": [0.55] * 3},
...         {"config": "c", "n": 3, "mean": 0.44, "ci95": (0.40, 0.48), "values": [0.44] * 3}]
>>> finding(rows, "a")
'b is above a beyond the seed spread (0.550 against 0.400, +0.150); c is within it (0.440).'
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from e2vlib.experiments.provenance import REPO
from e2vlib.experiments.runner import command_line, read_results
from e2vlib.experiments.studies import STUDIES
from e2vlib.experiments.summary import (
    compare,
    format_study_table,
    is_real_difference,
    summarize,
    unique_runs,
)

RESULTS_DIR = REPO / "experiments" / "results"
"""Where the recorded studies live (``experiments/results/STUDY.json``)."""


class MissingResultsError(FileNotFoundError):
    """A recorded result a lesson reads is not on disk; the message gives the command."""


# ----------------------------------------------------------------------------- study records


def load_results(study: str, root: str | os.PathLike | None = None) -> dict:
    """The recorded study ``study`` (``ROOT/STUDY.json``, default ``experiments/results``).

    Raises :class:`MissingResultsError` naming the command that records it when the file is
    missing, and a ``ValueError`` naming the file when it is not a study record or a record
    is wrong (a key missing, a score NaN or out of range, a config the study lacks:
    :func:`~e2vlib.experiments.runner.check_results`, naming the run and the key). Each run
    (each object) is kept once, with a warning naming the copies left out.
    """
    path = Path(root if root is not None else RESULTS_DIR) / f"{study}.json"
    if not path.exists() and not path.is_symlink():
        if study in STUDIES:
            command = command_line(study, None, [0, 1, 2], False)
        elif study == "real_meshes":  # not a training study: it scores models on real meshes
            from e2vlib.experiments.real_study import COMMAND as command
        else:
            command = f"python -m e2vlib experiment {study}"
        raise MissingResultsError(f"no recorded {study!r} study at {path}: run `{command}` "
                                  "from the repository root (it resumes if interrupted)")
    results = read_results(path, study)  # the one checked reader
    objects = all("config" not in r and "id" in r for r in results["runs"])
    results["runs"] = unique_runs(results["runs"], (lambda r: r["id"]) if objects else
                                  (lambda r: (r["config"], r["seed"])), str(path))
    return results


def runs_of(results: dict, config: str) -> list[dict]:
    """The recorded runs of one config, in file order."""
    return [run for run in results["runs"] if run.get("config") == config]


def minutes_per_run(results: dict) -> dict[str, float]:
    """Mean minutes of training per run, per config (``train_seconds`` of the records)."""
    minutes: dict[str, list[float]] = {}
    for run in results["runs"]:
        if "train_seconds" in run:
            minutes.setdefault(run["config"], []).append(run["train_seconds"] / 60)
    return {config: float(np.mean(values)) for config, values in minutes.items()}


UNNAMED_CPU = "a CPU the record does not name"


def recorded_on(results: dict, config: str | None = None) -> str:
    """Where the runs (of ``config``, default all) trained: the CPU model names in the
    records (a GPU run names its device), joined; runs whose record names no CPU say so."""
    names = set()
    for run in results["runs"] if config is None else runs_of(results, config):
        device = run.get("device", "cpu")
        names.add(run.get("cpu") or (UNNAMED_CPU if device == "cpu" else device))
    return _join(sorted(names))


def _join(words: list[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def finding(rows: list[dict], baseline: str, metric: str = "iou@0.3") -> str:
    """One sentence: which configs differ from ``baseline`` beyond the seed spread, with means.

    ``rows`` come from :func:`~e2vlib.experiments.summarize`; the rule is
    :func:`is_real_difference`.
    """
    base = next((r for r in rows if r["config"] == baseline), None)
    if base is None:
        raise ValueError(f"no config {baseline!r} among {[r['config'] for r in rows]}")
    above, below, within = [], [], []
    for row in rows:
        if row is base:
            continue
        if is_real_difference(row, base):
            (above if row["mean"] > base["mean"] else below).append(row)
        else:
            within.append(row)
    parts = []
    for group, word in ((above, "above"), (below, "below")):
        if group:
            names = _join([r["config"] for r in group])
            values = ", ".join(f"{r['mean']:.3f}" for r in group)
            deltas = ", ".join(f"{r['mean'] - base['mean']:+.3f}" for r in group)
            verb = "is" if len(group) == 1 else "are"
            parts.append(f"{names} {verb} {word} {baseline} beyond the seed spread "
                         f"({values} against {base['mean']:.3f}, {deltas})")
    if within:
        names = _join([r["config"] for r in within])
        values = ", ".join(f"{r['mean']:.3f}" for r in within)
        if parts:
            verb = "is" if len(within) == 1 else "are"
            parts.append(f"{names} {verb} within it ({values})")
        else:
            parts.append(f"no config differs from {baseline} ({base['mean']:.3f}) beyond the "
                         f"seed spread: {names} score {values}")
    return "; ".join(parts) + "."


def report(results: dict, baseline: str, metric: str = "iou@0.3",
           out: Callable[[str], object] = print) -> list[dict]:
    """Print a study's table, each config against ``baseline``, and its cost; return the rows.

    The table is :func:`~e2vlib.experiments.format_study_table`; each comparison gives the
    difference, Welch's p-value and the verdict of :func:`is_real_difference`; the last line
    says how many runs, their minutes of training and the CPU they were recorded on, then the
    command (or every command, oldest first) that recorded them.
    """
    rows = summarize(results, metric)
    out(format_study_table(rows, metric))
    for d in compare(rows, baseline):
        verdict = "beyond the seed spread" if d["clear"] else "within the seed spread"
        out(f"  {d['config']:13s} {d['difference']:+.3f} vs {baseline} "
            f"(Welch p = {d['p_value']:.2f}): {verdict}")
    minutes = minutes_per_run(results)
    if minutes:
        spread = ", ".join(f"{c} {m:.1f}" for c, m in minutes.items())
        out(f"  {len(results['runs'])} runs; minutes of training per run: {spread}; recorded on "
            f"{recorded_on(results)}")
    commands = results.get("commands") or ([results["command"]] if results.get("command") else [])
    if len(commands) == 1:
        out(f"  command: {commands[0]}")
    elif commands:  # a study grown over several calls: the latest alone did not make the table
        out(f"  made by {len(commands)} commands, oldest first:")
        for command in commands:
            out(f"    {command}")
    return rows


BENCH_RESULTS = REPO / "bench" / "RESULTS.md"
"""The benchmarks' recorded figures."""


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
