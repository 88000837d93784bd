"""Wall time of every lesson in quick mode (CI) and full mode (a student's run).

Each notebook is executed with nbclient in a fresh kernel, from notebooks/, with
``PYVISTA_JUPYTER_BACKEND=static``. Run: ``python bench/bench_notebooks.py [--quick-only]``;
writes the "Lessons" section of bench/RESULTS.md. ``--only NOTEBOOK`` times one lesson and
replaces (or adds) its row, keeping the others; the totals are summed again and a row timed
on another machine than the section's says so.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, write_section  # noqa: E402

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


def run(path: Path, quick: bool) -> float:
    """Seconds to execute ``path`` top to bottom (kernel start included)."""
    os.environ["PYVISTA_JUPYTER_BACKEND"] = "static"
    if quick:
        os.environ["E2V_QUICK"] = "1"
    else:
        os.environ.pop("E2V_QUICK", None)
    nb = nbformat.read(path, as_version=4)
    start = time.perf_counter()
    NotebookClient(nb, timeout=1800, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    return time.perf_counter() - start


def main(quick_only: bool = False) -> str:
    rows, total_quick, total_full = [], 0.0, 0.0
    for path in NOTEBOOKS:
        quick = run(path, quick=True)
        full = None if quick_only else run(path, quick=False)
        total_quick += quick
        total_full += full or 0.0
        full_text = "not run" if full is None else f"{full:.0f} s"
        rows.append(f"| `{path.name}` | {quick:.0f} s | {full_text} |")
        print(rows[-1], flush=True)
    full_total = "not run" if quick_only else f"{total_full / 60:.1f} min"
    body = f"""Command: `python bench/bench_notebooks.py`. Machine: {machine()}.

Wall time per notebook, kernel start included (nbclient, `PYVISTA_JUPYTER_BACKEND=static`).
Quick mode is what `make test` runs (`E2V_QUICK=1`); full mode is a student's run.

| notebook | quick | full |
| --- | --- | --- |
{chr(10).join(rows)}
| **all** | **{total_quick / 60:.1f} min** | **{full_total}** |
"""
    write_section("Lessons", body)
    return body


def only(name: str) -> str:
    """Time one notebook (quick and full) and put its row into the existing section."""
    import re

    path = next((p for p in NOTEBOOKS if p.name == name), None)
    if path is None:
        raise SystemExit(f"no notebook {name!r} in notebooks/")
    quick, full = run(path, quick=True), run(path, quick=False)
    text = (Path(__file__).resolve().parent / "RESULTS.md").read_text()
    section = re.search(r"^## Lessons\n(.*?)(?=^## |\Z)", text, re.S | re.M).group(1)
    section_machine = re.search(r"Machine: (.*?)\.\n", section).group(1)
    rows = {m.group(1): m.group(0) for m in
            re.finditer(r"^\| `([^`]+)` \| (\d+) s \| (\d+) s \|.*$", section, re.M)}
    elsewhere = dict(re.findall(r"`([^`]+)` on ([^;.]+)", (re.search(
        r"^Timed on other machines: (.*)$", section, re.M) or re.match("", "")).group(0)))
    elsewhere.pop(name, None)
    if machine() != section_machine:
        elsewhere[name] = machine().split(",")[0]
    rows[name] = f"| `{name}` | {quick:.0f} s | {full:.0f} s |"
    ordered = [rows[k] for k in sorted(rows)]
    seconds = [re.match(r"\| `[^`]+` \| (\d+) s \| (\d+) s", r).groups() for r in ordered]
    total_quick = sum(int(q) for q, _ in seconds) / 60
    total_full = sum(int(f) for _, f in seconds) / 60
    other = ("\nTimed on other machines: " + "; ".join(f"`{k}` on {v}" for k, v in
                                                      sorted(elsewhere.items())) + ".\n"
             if elsewhere else "")
    body = f"""Command: `python bench/bench_notebooks.py` (one lesson: `--only NOTEBOOK`).
Machine: {section_machine}.

Wall time per notebook, kernel start included (nbclient, `PYVISTA_JUPYTER_BACKEND=static`).
Quick mode is what `make test` runs (`E2V_QUICK=1`); full mode is a student's run.

| notebook | quick | full |
| --- | --- | --- |
{chr(10).join(ordered)}
| **all** | **{total_quick:.1f} min** | **{total_full:.1f} min** |
{other}"""
    write_section("Lessons", body)
    return body


if __name__ == "__main__":
    if "--only" in sys.argv:
        print(only(sys.argv[sys.argv.index("--only") + 1]))
    else:
        print(main(quick_only="--quick-only" in sys.argv))
