"""The class study of lessons 09-13: the mini dataset, its overrides, a run, the figure."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from e2vlib.data import E2VDataset  # noqa: E402
from e2vlib.experiments import classroom, reports  # noqa: E402


def test_overrides_point_every_input_at_the_mini_set_with_the_class_budget():
    quick = classroom.class_overrides("/x/data", quick=True)
    assert quick == {"data": "/x/data", "events": "/x/data", "frame_size": 32, "epochs": 1,
                     "per_category": None}
    full = classroom.class_overrides("/x/data", quick=False, loss="bce_dice")
    assert full["epochs"] == classroom.CLASS_EPOCHS["full"] and full["loss"] == "bce_dice"


@pytest.fixture(scope="module")
def class_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("class")
    data = classroom.build_mini_dataset(root / "data", quick=True, progress=False)
    rows = classroom.run_class_study("representation", ["binary", "count"], data,
                                     root / "results", quick=True, seeds=(0, 1),
                                     progress=False)
    return root, data, rows


def test_the_mini_set_has_three_categories_with_raw_events_of_every_object(class_run):
    _, data, _ = class_run
    ids = []
    for split in ("train", "val", "test"):
        dataset = E2VDataset(data, split)
        ids += dataset.ids
        assert all(dataset.raw_events_path(i) is not None for i in range(len(dataset)))
    per_category = classroom.CLASS_PER_CATEGORY["quick"]
    assert len(ids) == len(set(ids)) == per_category * len(classroom.CLASS_CATEGORIES)
    assert {i.rsplit("_", 1)[0] for i in ids} == set(classroom.CLASS_CATEGORIES)


def test_a_class_study_records_every_seed_and_returns_its_rows(class_run):
    root, data, rows = class_run
    assert [r["config"] for r in rows] == ["binary", "count"]
    assert all(r["n"] == 2 and len(r["values"]) == 2 for r in rows)
    recorded = reports.load_results("representation", root / "results")
    assert recorded["protocol"]["data"] == str(data)
    assert recorded["protocol"]["epochs"] == classroom.CLASS_EPOCHS["quick"]
    assert sorted((r["config"], r["seed"]) for r in recorded["runs"]) == [
        ("binary", 0), ("binary", 1), ("count", 0), ("count", 1)]
    assert all(r["checkpoint"] for r in recorded["runs"])  # kept, to score on the test set
    test = E2VDataset(classroom.class_test_path(data), "test")
    n_test = classroom.CLASS_TEST_PER_CATEGORY["quick"] * len(classroom.CLASS_CATEGORIES)
    assert len(test) == n_test  # ids repeat the mini set's names; the seed makes other objects
    for row in rows:
        assert row["ids"] == test.ids and len(row["per_object"]) == n_test
        assert np.isclose(row["mean"], np.mean(row["per_object"]))  # seeds x objects averaged


def test_the_class_test_set_holds_other_objects_than_the_mini_set(class_run):
    _, data, _ = class_run
    from e2vlib.data.config import dataset_config

    mini, test = dataset_config(data), dataset_config(classroom.class_test_path(data))
    assert test["seed"] == classroom.CLASS_TEST_SEED != mini["seed"]
    assert test["splits"] == ["test"] and test["frame_size"] == mini["frame_size"]


def test_paired_difference_and_the_objects_that_would_tell():
    rows = [{"config": "a", "per_object": [0.5, 0.6, 0.7, 0.6]},
            {"config": "b", "per_object": [0.4, 0.6, 0.5, 0.6]}]
    d = classroom.paired_difference(rows, "a", "b")
    assert d["n"] == 4 and np.isclose(d["mean"], 0.075) and d["wins"] == 2
    diff = np.array([0.1, 0.0, 0.2, 0.0])
    assert d["objects_to_tell"] == int(np.ceil((1.96 * diff.std(ddof=1) / diff.mean()) ** 2))
    assert classroom.objects_to_tell([0.1, -0.1]) is None


def test_a_class_verdict_uses_the_paired_interval_over_objects():
    gain = np.linspace(0.01, 0.05, 40)  # every object better under b: beyond chance
    rows = [{"config": "a", "mean": 0.5, "ci95": (0.3, 0.7), "per_object": list(0.5 - gain)},
            {"config": "b", "mean": 0.53, "ci95": (0.33, 0.73), "per_object": [0.5] * 40}]
    assert classroom.leader(rows) == "b"  # the seed intervals overlap; the pairs do not
    noise = np.resize([0.02, -0.02], 40)
    rows[0]["per_object"] = list(0.5 + noise)
    assert classroom.leader(rows) is None


def test_the_figure_puts_the_class_study_beside_the_record_from_zero(class_run):
    _, _, rows = class_run
    recorded = [{"config": "count", "n": 3, "mean": 0.5, "ci95": (0.3, 0.7),
                 "values": [0.4, 0.5, 0.6]},
                {"config": "binary", "n": 3, "mean": 0.6, "ci95": (0.5, 0.9),
                 "values": [0.55, 0.6, 0.65]},
                {"config": "edges", "n": 3, "mean": 0.1, "ci95": (0.0, 0.2),
                 "values": [0.1, 0.1, 0.1]}]
    fig = classroom.plot_class_study(rows, recorded, question="which input?")
    left, right = fig.axes
    assert left.get_ylim()[0] == 0 and right.get_ylim()[0] == 0
    assert right.get_ylim()[1] >= 0.9  # the widest interval is not cut
    labels = [t.get_text() for t in right.get_xticklabels()]
    assert labels == ["binary", "count"]  # the record's rows in the class study's order
    heights = [p.get_height() for p in right.patches]
    assert np.allclose(heights, [0.6, 0.5])
    alone = classroom.plot_class_study(rows)
    assert len(alone.axes) == 1


def _row(config: str, mean: float, low: float, high: float) -> dict:
    return {"config": config, "mean": mean, "ci95": (low, high)}


@pytest.mark.parametrize(("mine", "record", "quick", "word", "named"), [
    ((0.50, 0.40, 0.60), (0.45, 0.40, 0.50), False, "agrees", "neither"),
    ((0.50, 0.48, 0.52), (0.60, 0.58, 0.62), False, "agrees", "`b` ahead"),
    ((0.50, 0.40, 0.60), (0.60, 0.58, 0.62), False, "cannot tell", "`b` ahead"),
    ((0.40, 0.38, 0.42), (0.50, 0.40, 0.60), False, "disagrees with the record", "puts `a` ahead"),
    ((0.40, 0.38, 0.42), (0.60, 0.58, 0.62), False, "disagrees with the record", "puts `b` ahead"),
    ((0.50, 0.48, 0.52), (0.60, 0.58, 0.62), True, "is a smoke test", "E2V_QUICK"),
], ids=["both overlap", "both b", "class cannot tell", "record cannot tell", "opposite",
        "quick"])
def test_the_verdict_names_who_is_ahead_in_the_class_study_and_the_record(
        mine, record, quick, word, named):
    """``a`` scores 0.45 (0.43-0.47) in both; ``b`` is given as (mean, low, high)."""
    a = _row("a", 0.45, 0.43, 0.47)
    rows = [a, _row("b", *mine)]
    recorded = [_row("b", *record), a]  # another order, the configs matched by name
    found, sentence = classroom.class_verdict(rows, recorded, quick)
    assert found == word and named in sentence, sentence


def test_a_panel_title_gives_the_range_of_seeds_when_configs_differ():
    rows = [{"config": "a", "n": 3, "mean": 0.4, "ci95": (0.3, 0.5), "values": [0.3, 0.4, 0.5]},
            {"config": "b", "n": 5, "mean": 0.5, "ci95": (0.45, 0.55),
             "values": [0.45, 0.5, 0.5, 0.5, 0.55]}]
    fig = classroom.plot_class_study(rows[:1], rows)
    assert fig.axes[0].get_title() == "your study (3 seeds, mini set)"
    assert fig.axes[1].get_title() == "recorded study (3 seeds, data_small)"  # only a's row
    fig = classroom.plot_class_study(rows, rows)
    assert fig.axes[1].get_title() == "recorded study (3-5 seeds, data_small)"


UNIX_ONLY = ("fcntl", "resource", "termios", "pwd", "grp")
"""Standard-library modules Windows lacks: a lesson's path must import none of them."""

WITHOUT_UNIX_MODULES = """
import json, sys
from pathlib import Path
for name in {unix_only!r}:
    sys.modules[name] = None  # `import name` now raises ImportError, as on Windows
data, out = Path(sys.argv[1]), Path(sys.argv[2])

from e2vlib.experiments import classroom
from e2vlib.experiments.runner import results_lock, update_results

# a lesson's class study, then a second process's results update of the same folder
rows = classroom.run_class_study("representation", ["binary"], data, out, quick=True,
                                 seeds=(0,), progress=False)
recorded = json.loads((out / "representation.json").read_text())
later = {{**recorded["runs"][0], "seed": 7}}
merged = update_results(out / "representation.json", {{**recorded, "runs": [later]}})
try:  # the lock still excludes: a second holder waits, then gives up
    with results_lock(out), results_lock(out, timeout_s=0.2):
        held_twice = True
except TimeoutError:
    held_twice = False
print(json.dumps({{"n": rows[0]["n"], "seeds": [r["seed"] for r in merged["runs"]],
                  "held_twice": held_twice,
                  "loaded": sorted(n for n in {unix_only!r} if sys.modules.get(n))}}))
"""


def test_a_class_study_and_a_results_update_run_without_unix_only_modules(class_run,
                                                                          tmp_path):
    """Lessons 09-13 run their class studies on Windows too: with fcntl, resource, termios,
    pwd and grp unimportable, a study runs, records, merges a second writer's run and still
    locks the results folder."""
    import json
    import subprocess
    import sys

    from .conftest import REPO

    _, data, _ = class_run
    code = WITHOUT_UNIX_MODULES.format(unix_only=UNIX_ONLY)
    done = subprocess.run([sys.executable, "-c", code, str(data), str(tmp_path / "results")],
                          cwd=REPO, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found == {"n": 1, "seeds": [0, 7], "held_twice": False, "loaded": []}
