"""Wall time of `make test` and `make test-all` from a warm `.venv` (tracker issue 36).

Each command runs once, from the repository root, as a student or CI would type it; the
virtual environment must already be built (`make venv`), so no install is timed. Writes the
"Tests" section of bench/RESULTS.md with both times, pytest's closing line for each (tests per
tier) and how many times each lesson executes. A failing command is reported and nothing is
written. Run on a quiet machine: ``python bench/bench_tests.py``.
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, write_section  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
TARGETS = ("test", "test-all")
LOG_DIR = REPO / "build" / "bench_tests"
SUMMARY = re.compile(r"^=+ (.*\d+ passed.*) in [\d.]+s.*=+$", re.M)


def run(target: str) -> dict:
    """Run ``make target``; return its seconds and pytest's closing counts."""
    if not (REPO / ".venv" / ".installed").exists():
        raise SystemExit("no warm .venv: run `make venv` first, then time the tests")
    LOG_DIR.mkdir(parents=True, exist_ok=True)
    log = LOG_DIR / f"make_{target}.log"
    start = time.perf_counter()
    with log.open("w") as out:
        done = subprocess.run(["make", target], cwd=REPO, stdout=out, stderr=subprocess.STDOUT)
    seconds = time.perf_counter() - start
    text = log.read_text()
    if done.returncode != 0:
        raise SystemExit(f"`make {target}` failed (exit {done.returncode}); see {log}:\n"
                         + "\n".join(text.splitlines()[-20:]))
    counts = SUMMARY.findall(text)
    return {"seconds": seconds, "counts": counts[-1] if counts else "no pytest summary"}


def lessons_per_command() -> int:
    """How many lesson executions ``tests/test_lessons.py`` collects (one per lesson)."""
    out = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q",
                          "-p", "no:cacheprovider", "tests/test_lessons.py",
                          "-k", "test_lesson_runs"], cwd=REPO, capture_output=True, text=True)
    return sum(1 for line in out.stdout.splitlines() if "::test_lesson_runs" in line)


def main() -> str:
    lessons = len(sorted((REPO / "notebooks").glob("[0-9][0-9]_*.ipynb")))
    executions = lessons_per_command()
    rows = []
    for target in TARGETS:
        result = run(target)
        rows.append(f"| `make {target}` | {result['seconds'] / 60:.1f} min "
                    f"({result['seconds']:.0f} s) | {result['counts']} |")
        print(rows[-1], flush=True)
    body = f"""Command: `python bench/bench_tests.py`. Machine: {machine()}.

Wall time of each command from the repository root with `.venv` already built (no install
timed), run once each. `make test` runs ruff, the import contracts, the doctests, the unit
tests without the `slow` tier (10 Hypothesis examples per property) and every lesson in quick
mode; `make test-all` (CI) adds the tests marked `slow` and the full Hypothesis counts (150).

| command | wall time | pytest's count |
| --- | --- | --- |
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
