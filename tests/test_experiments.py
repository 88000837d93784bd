"""The experiment runner: one record per run, resumable, protocols never mixed."""

import json

import numpy as np
import pytest

from e2vlib.data import BuildConfig, build_dataset
from e2vlib.experiments import (
    STUDIES,
    best_threshold,
    command_line,
    compare,
    load_split,
    run_study,
    summarize,
)

RECORD_KEYS = {"config", "params", "seed", "metrics", "best_epoch", "train_seconds", "device",
               "commit"}


@pytest.fixture(scope="module")
def tiny_events_dataset(tmp_path_factory):
    """2 categories x 3 objects at 64 px with the raw events of every sample."""
    root = tmp_path_factory.mktemp("tiny_events")
    config = BuildConfig(categories=("chair", "table"), per_category=3, resolution=64,
                         frame_size=32, oversample=2, raw_events_per_category=3)
    build_dataset(root, config, progress=False)
    return root


def _overrides(root):
    return {"data": str(root), "events": str(root)}


def test_a_study_records_one_run_per_config_and_seed_and_resumes(tiny_events_dataset, tmp_path):
    overrides = _overrides(tiny_events_dataset)
    path = run_study("representation", ["binary", "polarity"], seeds=[0], out=tmp_path,
                     quick=True, progress=False, base_overrides=overrides)
    results = json.loads(path.read_text())
    assert [(r["config"], r["seed"]) for r in results["runs"]] == [("binary", 0),
                                                                 ("polarity", 0)]
    for run in results["runs"]:
        assert RECORD_KEYS <= set(run)
        assert {"iou@0.2", "iou@0.3", "iou@0.4", "iou@0.5", "fscore@1%",
                "iou@val_threshold"} <= set(run["metrics"])
        assert 0.0 <= run["metrics"]["iou@0.3"] <= 1.0
    assert results["runs"][1]["params"] == {"representation": "polarity"}
    assert results["protocol"]["epochs"] == 1 and results["protocol"]["data"] == overrides["data"]
    assert results["command"] == ("python -m e2vlib experiment representation --configs binary "
                                  "polarity --seeds 0 --quick")
    before = path.read_text()
    run_study("representation", ["binary", "polarity"], seeds=[0], out=tmp_path, quick=True,
              progress=False, base_overrides=overrides)  # everything recorded: nothing runs
    assert json.loads(path.read_text())["runs"] == json.loads(before)["runs"]


def test_another_protocol_is_refused(tiny_events_dataset, tmp_path):
    overrides = _overrides(tiny_events_dataset)
    path = tmp_path / "loss.json"
    path.write_text(json.dumps({"study": "loss", "protocol": {"epochs": 99}, "runs": []}))
    with pytest.raises(ValueError, match="another protocol"):
        run_study("loss", ["bce"], seeds=[0], out=tmp_path, quick=True, progress=False,
                  base_overrides=overrides)


def test_unknown_study_and_config_are_named():
    with pytest.raises(ValueError, match="unknown study 'colour'"):
        run_study("colour")
    with pytest.raises(ValueError, match="has no configs"):
        run_study("loss", ["mse"])


def test_inputs_follow_the_protocol(tiny_events_dataset):
    protocol = {**STUDIES["time"].protocol(quick=True), **_overrides(tiny_events_dataset),
                "n_frames": 10, "dt_us": 50_000, "representation": "count"}
    train = load_split(protocol, "train")
    assert tuple(train.frames.shape[1:]) == (10, 32, 32)
    assert train.config["n_frames"] == 10 and train.config["representation"] == "count"
    stored = load_split({**protocol, "representation": "binary", "n_frames": 100,
                         "dt_us": 5000}, "train")
    computed = load_split({**protocol, "representation": "binary_paper", "n_frames": 100,
                           "dt_us": 5000}, "train")
    assert stored.frames.shape == computed.frames.shape == (2, 100, 32, 32)


def test_summaries_and_comparisons_by_hand():
    runs = [{"config": c, "params": {}, "seed": s, "metrics": {"iou@0.3": v}}
            for c, values in (("base", [0.40, 0.42, 0.44]), ("better", [0.60, 0.61, 0.62]),
                              ("same", [0.39, 0.43, 0.45]))
            for s, v in enumerate(values)]
    rows = summarize({"runs": runs})
    assert [r["config"] for r in rows] == ["base", "better", "same"]
    diffs = {d["config"]: d for d in compare(rows, "base")}
    assert diffs["better"]["difference"] == pytest.approx(0.19)
    assert diffs["better"]["clear"] and diffs["better"]["p_value"] < 0.01
    assert not diffs["same"]["clear"] and diffs["same"]["p_value"] > 0.5


def test_best_threshold_maximises_iou():
    gt = np.zeros((2, 32, 32, 32))
    gt[:, :8] = 1
    probabilities = np.where(gt > 0, 0.45, 0.1)
    assert best_threshold(probabilities, gt) == 0.15  # 0.15 .. 0.45 all perfect: lowest wins


def test_recorded_command_reproduces_the_call():
    assert command_line("time", None, [0, 1, 2], False) == (
        "python -m e2vlib experiment time --seeds 0 1 2")


def test_a_run_with_the_same_full_protocol_is_reused_and_a_fresh_one_agrees(
        tiny_events_dataset, tmp_path):
    overrides = _overrides(tiny_events_dataset)
    first = run_study("representation", ["binary"], seeds=[0], out=tmp_path, quick=True,
                      progress=False, base_overrides=overrides)
    original = json.loads(first.read_text())["runs"][0]
    # loss "bce" is the base protocol, the same as representation "binary"; "focal" is not
    loss = run_study("loss", ["bce", "focal"], seeds=[0], out=tmp_path, quick=True,
                     progress=False, base_overrides=overrides)
    copied, focal = json.loads(loss.read_text())["runs"]
    assert copied["reused_from"] == "representation/binary"
    assert copied["config"] == "bce" and copied["params"] == {"loss": "bce"}
    assert copied["metrics"] == original["metrics"]
    assert "reused_from" not in focal
    # trained afresh (another folder, reuse off): CPU training is deterministic
    fresh = run_study("loss", ["bce"], seeds=[0], out=tmp_path / "fresh", quick=True,
                      progress=False, base_overrides=overrides, reuse=False)
    fresh_run = json.loads(fresh.read_text())["runs"][0]
    assert "reused_from" not in fresh_run
    assert fresh_run["metrics"]["iou@0.3"] == pytest.approx(original["metrics"]["iou@0.3"],
                                                            abs=1e-6)
    assert json.loads(fresh.read_text())["command"].endswith("--quick --no-reuse")
