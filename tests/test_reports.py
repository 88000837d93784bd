"""e2vlib.experiments.reports: study records and bench figures read the same way by every lesson."""

import json

import pytest

from e2vlib import experiments, paper
from e2vlib.experiments import reports

from .conftest import REPO


def _results(values: dict[str, list[float]]) -> dict:
    runs = [{"config": c, "params": {}, "seed": s, "metrics": {"iou@0.3": v},
             "train_seconds": 60.0 * (s + 1), "cpu": "Test CPU"}
            for c, vs in values.items() for s, v in enumerate(vs)]
    return {"runs": runs, "command": "python -m e2vlib experiment toy"}


def test_load_results_reads_a_record_and_names_the_command_when_missing(tmp_path):
    (tmp_path / "loss.json").write_text(json.dumps(_results({"bce": [0.4, 0.5]})))
    assert len(reports.load_results("loss", tmp_path)["runs"]) == 2
    with pytest.raises(reports.MissingResultsError,
                       match=r"python -m e2vlib experiment time --seeds 0 1 2"):
        reports.load_results("time", tmp_path)
    with pytest.raises(reports.MissingResultsError,
                       match=r"python -m e2vlib\.experiments\.real_study "):
        reports.load_results("real_meshes", tmp_path)
    (tmp_path / "noise.json").write_text("{not json")
    with pytest.raises(ValueError, match="noise.json is not a readable results file"):
        reports.load_results("noise", tmp_path)
    (tmp_path / "input.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match="no 'runs' list"):
        reports.load_results("input", tmp_path)


def test_every_committed_study_loads():
    for study in ("representation", "time", "encoder", "loss", "input", "noise", "data_scale",
                  "render"):
        results = reports.load_results(study)
        assert {r["config"] for r in results["runs"]} <= set(experiments.STUDIES[study].configs)


def test_the_rule_for_a_real_difference_is_interval_overlap():
    # hand-computed: 3 seeds 0.40 0.42 0.44 -> 0.42 +- 4.303 * 0.02 / sqrt 3 = 0.370..0.470
    rows = experiments.summarize(_results({"a": [0.40, 0.42, 0.44], "b": [0.51, 0.53, 0.55],
                                           "c": [0.44, 0.46, 0.48], "d": [0.9]}))
    by = {r["config"]: r for r in rows}
    assert experiments.is_real_difference(by["b"], by["a"])  # 0.480..0.580 vs 0.370..0.470: apart
    assert not experiments.is_real_difference(by["c"], by["a"])
    assert not experiments.is_real_difference(by["d"], by["a"])  # one seed: no interval
    # the same verdict as experiments.compare's "clear"
    clear = {d["config"]: d["clear"] for d in experiments.compare(rows, "a")}
    assert clear == {c: experiments.is_real_difference(by[c], by["a"]) for c in "bcd"}


def test_finding_states_the_result_in_one_sentence():
    rows = experiments.summarize(_results({"base": [0.40, 0.41, 0.42], "up": [0.60, 0.61, 0.62],
                                           "same": [0.39, 0.41, 0.43]}))
    text = reports.finding(rows, "base")
    assert text == ("up is above base beyond the seed spread (0.610 against 0.410, +0.200); "
                    "same is within it (0.410).")
    tie = reports.finding([r for r in rows if r["config"] != "up"], "base")
    assert tie == "no config differs from base (0.410) beyond the seed spread: same score 0.410."
    with pytest.raises(ValueError, match="no config 'x'"):
        reports.finding(rows, "x")
    three = experiments.summarize(_results({"b": [0.4, 0.41, 0.42], "x": [0.4, 0.41, 0.43],
                                            "y": [0.4, 0.42, 0.43], "z": [0.41, 0.42, 0.43]}))
    assert reports.finding(three, "b").startswith("no config differs from b (0.410) beyond the "
                                                  "seed spread: x, y and z score ")


def test_recorded_on_names_cpus_and_says_when_a_record_does_not():
    results = _results({"a": [0.4, 0.5]})
    assert reports.recorded_on(results) == "Test CPU"
    del results["runs"][0]["cpu"]
    results["runs"][0]["device"] = "cpu"
    assert reports.recorded_on(results) == "Test CPU and a CPU the record does not name"


def test_report_prints_table_verdicts_minutes_and_cpu():
    lines = []
    rows = reports.report(_results({"a": [0.40, 0.42, 0.44], "b": [0.50, 0.52, 0.54]}), "a",
                          out=lines.append)
    assert [r["config"] for r in rows] == ["a", "b"]
    text = "\n".join(lines)
    assert "| a | 3 | 0.420 ± 0.020 | 0.370–0.470 |" in text
    assert "+0.100 vs a" in text and "beyond the seed spread" in text
    assert "minutes of training per run: a 2.0, b 2.0; recorded on Test CPU" in text
    assert "command: python -m e2vlib experiment toy" in text
    # a study grown over several calls names each of them, not only the latest
    grown = _results({"a": [0.40, 0.42, 0.44]})
    grown["commands"] = ["python -m e2vlib experiment toy --configs a --seeds 0",
                         "python -m e2vlib experiment toy --configs a --seeds 1 2"]
    lines.clear()
    reports.report(grown, "a", out=lines.append)
    assert lines[-3:] == ["  made by 2 commands, oldest first:",
                          "    python -m e2vlib experiment toy --configs a --seeds 0",
                          "    python -m e2vlib experiment toy --configs a --seeds 1 2"]


def test_bench_tables_and_lesson_minutes(tmp_path):
    page = tmp_path / "RESULTS.md"
    page.write_text("# Bench\n\n## Lessons\n\nCommand: x. Machine: Toy CPU, 2 cores, Python 3.11."
                    "\n\n| notebook | quick | full |\n| --- | --- | --- |\n"
                    "| `00_a.ipynb` | 30 s | 2.5 min |\n| `x` (y) | 1 s | 2 s |\n"
                    "| **all** | **30 s** | **2.5 min** |\n\n"
                    "## Other\n\ntext\n")
    assert reports.bench_machine("Lessons", page) == "Toy CPU, 2 cores"
    assert reports.bench_table("Lessons", page)[0] == {"notebook": "00_a.ipynb", "quick": "30 s",
                                                       "full": "2.5 min"}
    assert reports.bench_table("Lessons", page)[1]["notebook"] == "x (y)"
    assert reports.lesson_minutes(page) == {"00_a.ipynb": (0.5, 2.5)}
    assert reports.bench_section("Other", page) == "text"
    with pytest.raises(KeyError, match="sections: \\['Lessons', 'Other'\\]"):
        reports.bench_section("Missing", page)
    # the committed page: every lesson has a row
    minutes = reports.lesson_minutes()
    lessons = sorted(p.name for p in (REPO / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    # quick mode never does more work than full mode; where both do the same (lesson 05), the
    # two timings differ only by noise
    assert sorted(minutes) == lessons and all(q <= 1.2 * f for q, f in minutes.values())


def test_paper_describe_marks_facts_and_choices():
    table = paper.describe(["N_EVENT_FRAMES", "IOU_THRESHOLD"])
    lines = table.splitlines()
    assert lines[2].startswith("| `N_EVENT_FRAMES` | 100 | paper: ")
    assert lines[3].startswith("| `IOU_THRESHOLD` | 0.3 | **our choice**: ")
    facts = paper.describe(ours=False)
    assert "`N_PARAMETERS` | 149,155,905" in facts and "our choice" not in facts
    assert "`TABLE_I` | train: 0.742; test: 0.352; large_test: 0.346 (overall)" in facts
    with pytest.raises(KeyError, match="NOT_A_FACT"):
        paper.describe(["NOT_A_FACT"])
