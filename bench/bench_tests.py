"""Wall time of `make test` on its first run after `make venv` and warm, and of `make test-all`.

The run builds its own virtual environment with `make venv VENV=build/bench_tests/venv` (the
student's `.venv` is left alone), after removing the repository's `__pycache__` folders, as a
new clone has none; then `make test` twice (first run, warm run) and `make test-all` once, all
in that environment. Writes the "Tests" section of bench/RESULTS.md with each time, pytest's
closing line, the CPU and how many times each lesson executes. A failing command is reported
and nothing is written. Run on a quiet machine: ``python bench/bench_tests.py``.
"""

from __future__ import annotations

import os
import platform
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, write_section  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
LOG_DIR = REPO / "build" / "bench_tests"
VENV = LOG_DIR / "venv"
BUILD_CACHE = LOG_DIR / "build_cache"
"""The lessons' dataset cache during the benchmark (``E2V_BUILD_CACHE``), empty at the start as
on a new machine; the student's cache in the temporary folder is left alone."""
SUMMARY = re.compile(r"^=+ (.*\d+ passed.*) in [\d.]+s.*=+$", re.M)


def run(target: str, label: str) -> dict:
    """Run ``make target`` in the benchmark's environment; return its seconds and pytest's
    closing counts (none for ``venv``)."""
    LOG_DIR.mkdir(parents=True, exist_ok=True)
    log = LOG_DIR / f"{label}.log"
    start = time.perf_counter()
    with log.open("w") as out:
        done = subprocess.run(["make", target, f"VENV={VENV.relative_to(REPO)}"], cwd=REPO,
                              stdout=out, stderr=subprocess.STDOUT,
                              env={**os.environ, "E2V_BUILD_CACHE": str(BUILD_CACHE)})
    seconds = time.perf_counter() - start
    text = log.read_text()
    if done.returncode != 0:
        raise SystemExit(f"`make {target}` failed (exit {done.returncode}); see {log}:\n"
                         + "\n".join(text.splitlines()[-20:]))
    counts = SUMMARY.findall(text)
    return {"seconds": seconds, "counts": counts[-1] if counts else "-"}


def new_clone_state() -> None:
    """No benchmark environment, no bytecode or numba cache in the repository, no dataset
    build cache."""
    shutil.rmtree(VENV, ignore_errors=True)
    shutil.rmtree(BUILD_CACHE, ignore_errors=True)
    for folder in REPO.glob("[!.]*/**/__pycache__"):
        if VENV not in folder.parents and "build" not in folder.parts:
            shutil.rmtree(folder, ignore_errors=True)


def cpu_details() -> str:
    """``model name (family F, model M)`` from /proc/cpuinfo, else :func:`platform.processor`."""
    fields = {}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            fields.setdefault(key.strip(), value.strip())
    except OSError:
        return platform.processor() or platform.machine()
    return (f"{fields.get('model name', 'unknown')} (family {fields.get('cpu family', '?')}, "
            f"model {fields.get('model', '?')})")


def lessons_per_command() -> int:
    """How many lesson executions ``tests/test_lessons.py`` collects (one per lesson)."""
    out = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q",
                          "-p", "no:cacheprovider", "tests/test_lessons.py",
                          "-k", "test_lesson_runs"], cwd=REPO, capture_output=True, text=True)
    return sum(1 for line in out.stdout.splitlines() if "::test_lesson_runs" in line)


def main() -> str:
    lessons = len(sorted((REPO / "notebooks").glob("[0-9][0-9]_*.ipynb")))
    executions = lessons_per_command()
    new_clone_state()
    steps = [("venv", "make venv", "install (pip's cache warm)"),
             ("test", "make test", "first run after `make venv`"),
             ("test", "make test", "warm (second run)"),
             ("test-all", "make test-all", "after the two above")]
    rows = []
    for number, (target, command, when) in enumerate(steps):
        result = run(target, f"{number}_{target}")
        rows.append(f"| `{command}` | {when} | {result['seconds'] / 60:.1f} min "
                    f"({result['seconds']:.0f} s) | {result['counts']} |")
        print(rows[-1], flush=True)
    body = f"""Command: `python bench/bench_tests.py`. Machine: {machine()}; CPU {cpu_details()}.

Wall time of each command from the repository root, run once each in the benchmark's own
environment (`build/bench_tests/venv`), starting as a new clone on a new machine does: no
bytecode, no numba cache, no dataset build cache (the lessons' mini datasets are built on the
first run and copied on later ones, `experiments.build_cache`). `make test` runs ruff, the
import contracts, the doctests, the unit tests without the `slow` tier (10 Hypothesis examples
per property) and every lesson in quick mode, in two pytest-xdist processes with one torch
thread each (`OMP_NUM_THREADS`, the cores shared out); `make test-all` (CI) adds the tests
marked `slow` and the full Hypothesis counts (150).

| command | when | wall time | pytest's count |
| --- | --- | --- | --- |
{chr(10).join(rows)}

Lesson executions: {executions} for {lessons} lessons under each command (once each, in
`tests/test_lessons.py`, with every exercise's stub and wrong-answer probes in the same run);
CI then executes lessons 00 and 08 again in JupyterLab (`make browser`) and every lesson for
the quick book (`make book QUICK=1`, cached).
"""
    write_section("Tests", body)
    return body


if __name__ == "__main__":
    print(main())
