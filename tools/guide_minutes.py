"""Minutes per lesson, per section and per teaching path of the instructor's guide.

``docs/instructors.md`` gives, for every lesson, its core sections with their teaching minutes,
its exercise minutes, and three paths through the lessons (90 minutes, half a day, a whole
course) with their totals. This tool computes those numbers from the lessons themselves and
from the "Lessons" table of ``bench/RESULTS.md``, and checks that every section the guide names
still exists, so that the guide can be brought up to date after a lesson changes. The method
(an estimate, stated in the guide):

* **teaching** a section: its typed Markdown words at ``READING_WORDS_PER_MINUTE`` (the
  pace ``tools/lesson_map.py`` uses for the book's front page) plus ``MINUTES_PER_CODE_CELL``
  for each of its code cells (reading the code and its output with the class);
* **running** a lesson: its measured full-mode wall time (``bench/RESULTS.md``, "Lessons"),
  counted once whenever any part of the lesson is taught, since later cells need earlier ones;
* **an exercise**: its words at the same pace, plus ``EXERCISE_MINUTES`` for a worked
  exercise or ``EXPERIMENT_MINUTES`` for one marked "(experiment)" (predict, run, compare).

A lesson's title and goals ("intro") and its Summary come with every lesson taught. Sections
are named by their number: ``"3"`` is section 3 with its ``###`` sub-sections, ``"3!"``
section 3 without them, ``"3:Title"`` one sub-section.

Usage: ``python tools/guide_minutes.py`` (lessons, core sections, paths; exit 1 when a named
section is gone) or ``--sections NN`` (one lesson's parts).
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import nbformat

sys.path.insert(0, str(Path(__file__).resolve().parent))
from lesson_map import READING_WORDS_PER_MINUTE, bench_times, lessons, minutes  # noqa: E402

MINUTES_PER_CODE_CELL = 1.0
SETUP_MINUTES = 15
"""Minutes the 90-minute path leaves for getting every laptop running and for questions."""
EXERCISE_MINUTES, EXPERIMENT_MINUTES = 5, 10
SECTION = re.compile(r"^## (.+)$")
SUBSECTION = re.compile(r"^### (?!Exercise)(.+)$")
EXERCISE = re.compile(r"^#{2,4}\s*Exercise\s+(\d+)(.*)$")

CORE = {
    "00": ["1", "2", "3", "4"],
    "01": ["1", "2", "3", "6"],
    "02": ["1", "2", "3", "4", "5"],
    "03": ["1", "5", "6", "8"],
    "04": ["1", "2", "4!"],
    "05": ["1", "4", "5", "8"],
    "06": ["1!", "1:Reading a loss value", "2!", "3", "4!", "5"],
    "07": ["1", "2", "4", "6"],
    "08": ["1", "3", "4"],
    "09": ["1", "2", "3", "4"],
    "10": ["2", "3"],
    "11": ["1", "2", "3"],
    "12": ["1", "3"],
    "13": ["1", "2", "3", "4!"],
    "14": ["1", "3", "4"],
    "15": ["1", "2", "4", "5"],
}
"""Each lesson's core sections (the rest is optional), as the guide lists them."""

PATHS = {
    "90 minutes": {
        "00": (["1", "2", "3", "4"], [2]),
        "01": (["1"], []),
        "02": (["1"], [1]),
        "05": (["1"], []),
        "07": (["1", "4"], []),
    },
    "half a day": {
        "00": (["1", "2", "3", "4"], [2]),
        "01": (["1", "3", "6"], []),
        "02": (["1", "2", "3", "4", "5"], [1]),
        "03": (["1", "5", "6", "8"], [1]),
        "04": (["1", "4!"], []),
        "05": (["1", "4", "8"], []),
        "06": (["1!", "1:Reading a loss value", "3", "5"], [1]),
        "07": (["1", "2", "4", "6"], [1]),
    },
}
"""{path: {lesson: (sections taught, exercises set)}}; the whole course is every lesson."""


def lesson_parts(path: Path) -> list[dict]:
    """``[{"key", "title", "words", "code", "exercises"}]`` of a lesson in order: "intro"
    (before the first ``##`` heading), each section (key: its number, or its title when it
    has none, such as "Summary" and "Exercises"), each ``###`` sub-section (key:
    ``"3:Title"``); ``exercises`` holds ``[number, words, is_experiment]`` per exercise."""
    cells = nbformat.read(path, as_version=4).cells
    parts = [{"key": "intro", "title": "(title, goals, set-up)", "words": 0, "code": 0,
              "exercises": []}]
    section = "intro"
    for cell in cells:
        if cell.cell_type != "markdown":
            parts[-1]["code"] += 1
            continue
        for line in cell.source.splitlines():
            if heading := SECTION.match(line):
                title = heading.group(1).strip()
                section = title.split(".")[0] if re.match(r"\d+\.", title) else title
                parts.append({"key": section, "title": title, "words": 0, "code": 0,
                              "exercises": []})
            elif heading := SUBSECTION.match(line):
                title = heading.group(1).strip()
                parts.append({"key": f"{section}:{title}", "title": f"  {title}", "words": 0,
                              "code": 0, "exercises": []})
            if exercise := EXERCISE.match(line.strip()):
                parts[-1]["exercises"].append(
                    [int(exercise.group(1)), 0, "experiment" in exercise.group(2)])
            parts[-1]["words"] += len(line.split())
            if parts[-1]["exercises"]:
                parts[-1]["exercises"][-1][1] += len(line.split())
    return parts


def part_minutes(part: dict) -> float:
    return part["words"] / READING_WORDS_PER_MINUTE + MINUTES_PER_CODE_CELL * part["code"]


def exercise_minutes(words: int, experiment: bool) -> float:
    return (words / READING_WORDS_PER_MINUTE
            + (EXPERIMENT_MINUTES if experiment else EXERCISE_MINUTES))


def selected(parts: list[dict], names: list[str]) -> tuple[list[dict], list[str]]:
    """The parts named by ``names`` ("3", "3!", "3:Title"), and the names found nowhere."""
    chosen, missing = [], []
    for name in names:
        if name.endswith("!"):
            found = [p for p in parts if p["key"] == name[:-1]]
        elif ":" in name:
            found = [p for p in parts if p["key"] == name]
        else:
            found = [p for p in parts if p["key"] == name or p["key"].startswith(name + ":")]
        chosen += found
        missing += [] if found else [name]
    return chosen, missing


def plan_minutes(number: str, names: list[str], exercises: list[int] | None,
                 run: float) -> tuple[float, float, list[str]]:
    """Teaching and exercise minutes of ``names`` of one lesson (with its intro, Summary and
    run) and of ``exercises`` (None: all), and what is missing."""
    path = next(p for p in lessons() if p.name.startswith(number))
    parts = lesson_parts(path)
    chosen, missing = selected(parts, names)
    always = [p for p in parts if p["key"] in ("intro", "Summary")]
    teach = run + sum(part_minutes(p) for p in always + chosen)
    found = {n: (w, x) for p in parts for n, w, x in p["exercises"]}
    wanted = sorted(found) if exercises is None else exercises
    missing += [f"exercise {n}" for n in wanted if n not in found]
    done = sum(exercise_minutes(*found[n]) for n in wanted if n in found)
    return teach, done, [f"lesson {number}: {m}" for m in missing]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sections", metavar="NN", help="list one lesson's parts")
    args = parser.parse_args(argv)
    runs = {name[:2]: minutes(full) for name, (_, full) in bench_times().items()}
    if args.sections:
        path = next(p for p in lessons() if p.name.startswith(args.sections))
        for part in lesson_parts(path):
            print(f"{part_minutes(part):5.1f} min {part['words']:5d} words {part['code']:3d} "
                  f"code cells  {part['key']:<8.8s} {part['title']}")
        return 0
    missing: list[str] = []
    totals = [0.0, 0.0]
    print("lesson   all sections  core  exercises  full-mode run")
    for path in lessons():
        number = path.name[:2]
        every = [p["key"] for p in lesson_parts(path)
                 if p["key"] not in ("intro", "Summary", "Exercises") and ":" not in p["key"]]
        teach, done, _ = plan_minutes(number, every, None, runs[number])
        core, _, gone = plan_minutes(number, CORE[number], [], runs[number])
        missing += gone
        totals[0] += teach
        totals[1] += done
        print(f"{number}       {teach:5.0f}     {core:5.0f}   {done:5.0f}       "
              f"{runs[number]:4.1f} min")
    print(f"whole course: teaching {totals[0]:.0f} min, exercises {totals[1]:.0f} min, "
          f"together {sum(totals) / 60:.1f} h")
    for name, plan in PATHS.items():
        teach = done = 0.0
        for number, (names, exercises) in plan.items():
            t, d, gone = plan_minutes(number, names, exercises, runs[number])
            teach, done, missing = teach + t, done + d, missing + gone
        print(f"path {name}: teaching {teach:.0f} min, exercises {done:.0f} min, "
              f"together {teach + done:.0f} min")
    for line in missing:
        print("MISSING", line)
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
