"""The experiment runner: one record per run, resumable, protocols never mixed."""

import json

import numpy as np
import pytest
import torch

from e2vlib.data import BuildConfig, E2VDataset, build_dataset
from e2vlib.experiments import (
    STUDIES,
    best_threshold,
    command_line,
    compare,
    load_split,
    run_study,
    summarize,
)
from e2vlib.experiments.protocol import Protocol, canonical_protocol
from e2vlib.inputs import grey_input

RECORD_KEYS = {"config", "params", "seed", "metrics", "best_epoch", "train_seconds", "device",
               "commit"}


@pytest.fixture(scope="module")
def tiny_events_dataset(tmp_path_factory):
    """2 categories x 3 objects at 64 px with the raw events of every sample."""
    root = tmp_path_factory.mktemp("tiny_events")
    config = BuildConfig(categories=("chair", "table"), per_category=3, resolution=64,
                         frame_size=32, oversample=2, raw_events_per_category=3,
                         grey_video=True)
    build_dataset(root, config, progress=False)
    return root


TINY = {"categories": ("chair", "table"), "resolution": 64, "frame_size": 32, "oversample": 2}


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
    assert results["commands"] == [results["command"]]
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
    protocol = STUDIES["time"].protocol(quick=True).updated(
        {**_overrides(tiny_events_dataset), "n_frames": 10, "dt_us": 50_000,
         "representation": "count"})
    train = load_split(protocol, "train")
    assert tuple(train.frames.shape[1:]) == (10, 32, 32)
    assert train.config["n_frames"] == 10 and train.config["representation"] == "count"
    stored = load_split(protocol.updated({"representation": "binary", "n_frames": 100,
                                          "dt_us": 5000}), "train")
    computed = load_split(protocol.updated({"representation": "binary_paper",
                                            "n_frames": 100, "dt_us": 5000}), "train")
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


@pytest.mark.slow  # three trainings; make test keeps reuse in the data-scale test
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


# --- issue 13: inputs that are not events, noisy events, more training data ----------------


def test_grey_inputs_are_the_stored_grey_video_scaled_to_one(tiny_events_dataset):
    from e2vlib.data import E2VDataset, load_grey_video

    protocol = STUDIES["input"].protocol(quick=True).updated(_overrides(tiny_events_dataset))
    video = load_split(protocol.updated(STUDIES["input"].configs["grey_video"]), "test")
    single = load_split(protocol.updated(STUDIES["input"].configs["grey_single"]), "test")
    ids = E2VDataset(tiny_events_dataset, "test").ids
    grey = load_grey_video(tiny_events_dataset, ids[0]).astype(np.float32)  # (100, 32, 32)
    assert video.frames.shape == (2, 100, 32, 32) and video.frames.dtype == torch.float16
    np.testing.assert_allclose(video.frames[0].float().numpy(), grey / 255, atol=1e-3)
    assert single.frames.shape == (2, 1, 32, 32)
    np.testing.assert_allclose(single.frames[0, 0].float().numpy(), grey[0] / 255, atol=1e-3)
    # 2x2 block means at half the size
    half = grey_input(grey.astype(np.uint8), "grey_video", 16)
    expected = grey.reshape(100, 16, 2, 16, 2).mean(axis=(2, 4)) / 255
    np.testing.assert_allclose(half.astype(np.float32), expected, atol=1e-3)
    with pytest.raises(ValueError, match="must divide"):
        grey_input(grey.astype(np.uint8), "grey_video", 5)


def test_the_input_study_runs_a_grey_single_view_through_a_2d_encoder(tiny_events_dataset,
                                                                     tmp_path):
    path = run_study("input", ["grey_single"], seeds=[0], out=tmp_path, quick=True,
                     progress=False, base_overrides=_overrides(tiny_events_dataset))
    run = json.loads(path.read_text())["runs"][0]
    assert run["params"] == {"representation": "grey_single", "preset": "tiny2d",
                             "n_frames": 1}
    assert 0.0 <= run["metrics"]["iou@0.3"] <= 1.0 and run["n_train"] == 2


@pytest.fixture(scope="module")
def noisy_test_split(tiny_events_dataset):
    """The tiny dataset's test split simulated again with the ``high`` noise preset."""
    root = tiny_events_dataset.parent / "noise_high"
    config = BuildConfig(per_category=3, raw_events_per_category=3, noise="high",
                         splits=("test",), **TINY)
    build_dataset(root, config, progress=False)
    return root


def test_noisy_events_are_read_for_the_noisy_test_split_only(tiny_events_dataset,
                                                             noisy_test_split):
    from e2vlib.io import load_events

    test_ids = E2VDataset(tiny_events_dataset, "test").ids
    # the same objects and seeds as the clean build; only the test split is built
    assert sorted(p.name for p in (noisy_test_split / "samples").iterdir()) == sorted(
        f"{i}.npz" for i in test_ids)
    protocol = STUDIES["noise"].protocol(quick=True).updated(
        {**_overrides(tiny_events_dataset),
         "noise_events": str(tiny_events_dataset.parent / "noise_{level}")})
    clean = load_split(protocol, "test")
    noisy = load_split(protocol.updated({"noise": "high"}), "test")
    assert clean.ids == noisy.ids
    np.testing.assert_array_equal(clean.voxels.numpy(), noisy.voxels.numpy())
    # 5 Hz of shot noise on 64 x 64 pixels over 0.5 s: about 10,000 more events per object
    sample = clean.ids[0]
    n_clean = len(load_events(tiny_events_dataset / "events" / f"{sample}.npz")[0])
    n_noisy = len(load_events(noisy_test_split / "events" / f"{sample}.npz")[0])
    assert n_noisy - n_clean > 5000
    assert noisy.frames.float().mean() > clean.frames.float().mean()
    with pytest.raises(ValueError, match="only the splits"):
        load_split(protocol.updated({"noise": "high"}), "train")
    with pytest.raises(FileNotFoundError, match="--noise low"):
        load_split(protocol.updated({"noise": "low"}), "test")


def test_the_noise_study_scores_one_model_at_every_test_noise_level(
        tiny_events_dataset, noisy_test_split, tmp_path):
    overrides = {**_overrides(tiny_events_dataset), "test_noise": ["clean", "high"],
                 "noise_events": str(tiny_events_dataset.parent / "noise_{level}")}
    path = run_study("noise", ["train_clean"], seeds=[0], out=tmp_path, quick=True,
                     progress=False, base_overrides=overrides)
    metrics = json.loads(path.read_text())["runs"][0]["metrics"]
    assert metrics["clean:iou@0.3"] == pytest.approx(metrics["iou@0.3"], abs=1e-9)
    assert {"high:iou@0.3", "high:fscore@1%", "high:iou@val_threshold"} <= set(metrics)
    assert summarize(path, "high:iou@0.3")[0]["n"] == 1


@pytest.fixture(scope="module")
def extra_objects(tiny_events_dataset):
    """Three more objects per category (another seed), as the data_scale study's extra data."""
    root = tiny_events_dataset.parent / "extra"
    build_dataset(root, BuildConfig(per_category=3, seed=1, **TINY), progress=False)
    return root


def test_train_scale_takes_the_first_objects_then_extra_ones_at_equal_steps(
        tiny_events_dataset, extra_objects):
    protocol = STUDIES["data_scale"].protocol(quick=True).updated(
        {**_overrides(tiny_events_dataset), "extra": str(extra_objects)})
    four = protocol.updated({"train_scale": 4})
    base = load_split(protocol, "train")
    assert protocol.train_counts() == {"chair": 1, "table": 1}
    bigger = load_split(four, "train")
    assert four.train_counts() == {"chair": 4, "table": 4}
    assert len(bigger) == 8 and bigger.ids[:2] == base.ids
    assert len(set(bigger.ids)) == 8 and bigger.categories.count("chair") == 4
    np.testing.assert_array_equal(bigger.frames[:2].numpy(), base.frames.numpy())
    assert load_split(protocol, "test").ids == load_split(four, "test").ids
    with pytest.raises(ValueError, match="too few objects"):
        load_split(protocol.updated({"train_scale": 6}), "train")  # 1 + 3 extra < 6 each
    assert [Protocol(train_scale=s, extra="x").run_epochs for s in (0.25, 0.5, 1, 2, 4)] == [
        48, 24, 12, 6, 3]


def test_data_scale_1x_is_the_base_run_and_is_reused(tiny_events_dataset, extra_objects,
                                                     tmp_path):
    overrides = _overrides(tiny_events_dataset)
    run_study("representation", ["binary"], seeds=[0], out=tmp_path, quick=True,
              progress=False, base_overrides=overrides)
    path = run_study("data_scale", ["1x", "2x"], seeds=[0], out=tmp_path, quick=True,
                     progress=False, base_overrides={**overrides, "extra": str(extra_objects)})
    one, two = json.loads(path.read_text())["runs"]
    assert one["reused_from"] == "representation/binary" and "reused_from" not in two
    assert one["n_train"] == 2 and one["steps"] == 1  # 2 objects, one batch of 16
    assert two["n_train"] == 4 and two["epochs"] == 1  # quick: 1 epoch / 2 rounds to 1
    assert canonical_protocol({"epochs": 3, "train_scale": 1, "extra": "x"}) == (
        canonical_protocol(Protocol(epochs=3)))


def test_only_runs_of_the_same_cpu_model_are_copied(tmp_path):
    from e2vlib.experiments import find_same_run

    protocol = Protocol(epochs=5)
    runs = [{"config": "a", "params": {}, "seed": 0, "device": "cpu", "metrics": {}, "cpu": c}
            for c in ("AMD EPYC", None)]
    (tmp_path / "other.json").write_text(json.dumps(
        {"study": "other", "protocol": protocol.to_dict(), "runs": runs}))
    found = find_same_run(tmp_path, protocol, 0, "cpu", cpu="AMD EPYC")
    assert found["reused_from"] == "other/a" and found["cpu"] == "AMD EPYC"
    assert find_same_run(tmp_path, protocol, 0, "cpu", cpu="Intel Xeon") is None
    assert find_same_run(tmp_path, protocol, 1, "cpu", cpu="AMD EPYC") is None


# --- the render study (issue 15) ------------------------------------------------------------


def test_the_render_study_scores_each_model_on_both_kinds_of_render(tiny_events_dataset,
                                                                     tmp_path):
    plain = tmp_path / "plain"
    config = json.loads((tiny_events_dataset / "config.json").read_text())
    build_dataset(plain, BuildConfig.from_dict({**config, "anti_aliasing": "none",
                                                "grey_video": False}), progress=False)
    overrides = {**_overrides(tiny_events_dataset),
                 "test_data": {"ssaa": str(tiny_events_dataset), "none": str(plain)}}
    path = run_study("render", ["ssaa"], seeds=[0], out=tmp_path, quick=True, progress=False,
                     base_overrides=overrides)
    metrics = json.loads(path.read_text())["runs"][0]["metrics"]
    assert metrics["ssaa:iou@0.3"] == pytest.approx(metrics["iou@0.3"], abs=1e-9)
    assert {"none:iou@0.3", "none:fscore@1%"} <= set(metrics)
    assert 0 <= metrics["none:iou@0.3"] <= 1
    # the same objects and labels, other frames
    ssaa, none = (load_split(STUDIES["render"].protocol(quick=True).updated({"data": str(root)}),
                             "test") for root in (tiny_events_dataset, plain))
    assert ssaa.ids == none.ids
    np.testing.assert_array_equal(ssaa.voxels.numpy(), none.voxels.numpy())
    assert not torch.equal(ssaa.frames, none.frames)


def test_the_render_study_names_the_command_that_builds_its_data(monkeypatch, tmp_path):
    import e2vlib.experiments as experiments
    from e2vlib.__main__ import build_parser
    from e2vlib.cli.data_commands import build_config

    assert STUDIES["render"].configs["none"] == {"data": experiments.RENDER_CACHE}
    args = build_parser().parse_args(experiments.RENDER_COMMAND.split()[3:])
    assert args.out == experiments.RENDER_CACHE
    small = json.loads((experiments.REPO / "data_small" / "config.json").read_text())
    assert build_config(args) == BuildConfig.from_dict({**small, "anti_aliasing": "none"})
    missing = str(tmp_path / "not_built")
    monkeypatch.setitem(experiments.DATA_COMMANDS, missing, "python -m e2vlib make-data X")
    with pytest.raises(FileNotFoundError, match="make-data X"):
        load_split(STUDIES["render"].protocol(quick=True).updated({"data": missing}), "test")


def test_cache_commands_build_data_smalls_objects_with_the_stated_changes():
    import e2vlib.experiments as experiments
    from e2vlib.__main__ import build_parser
    from e2vlib.cli.data_commands import build_config

    small = json.loads((experiments.REPO / "data_small" / "config.json").read_text())
    assert BuildConfig(**experiments.SMALL_SETTINGS) == BuildConfig.from_dict(
        {**small, "raw_events_per_category": 1})
    expected = {
        experiments.EVENTS_COMMAND: {"raw_events_per_category": 64, "grey_video": True},
        experiments.NOISE_COMMANDS["medium"]: {"raw_events_per_category": 64,
                                                "noise": "medium"},
        experiments.NOISE_COMMANDS["high"]: {"raw_events_per_category": 64, "noise": "high",
                                              "splits": ["test"]},
        experiments.EXTRA_COMMAND: {"seed": 1, "per_category": 156},
    }
    for command, changes in expected.items():
        args = build_parser().parse_args(command.split()[3:])
        assert build_config(args) == BuildConfig.from_dict({**small, **changes}), command
        assert args.workers == experiments.BUILD_WORKERS


def test_the_stability_norm_even_and_capstone_studies_share_their_128px_runs():
    stability, capstone = STUDIES["stability_norm_even"], STUDIES["capstone"]
    for study in (stability, capstone):
        assert study.protocol().recipe == "tiny_step_even"
    same = [canonical_protocol(s.protocol().updated(s.configs["128px"]))
            for s in (stability, capstone)]
    assert same[0] == same[1] and same[0]["frame_size"] == 128
    assert same[0]["preset"] == "tiny_norm"
    # the first stability study keeps the recipe its records were made with
    assert STUDIES["stability"].protocol().recipe == "tiny_step"
    # the base recipe of every earlier study is untouched: its records stay comparable
    assert STUDIES["time"].protocol().recipe == "tiny"
    assert capstone.configs["bce_dice"] == {"loss": "bce_dice"}
    assert capstone.protocol().updated(capstone.configs["30_epochs"]).run_epochs == 30


def test_a_run_below_the_collapse_line_is_called_collapsed():
    from e2vlib.experiments import COLLAPSE_IOU, is_collapsed

    assert is_collapsed({"metrics": {"iou@0.3": 0.062}})  # time/128px seed 1, recipe tiny
    assert not is_collapsed({"metrics": {"iou@0.3": 0.329}})  # the weakest run that learned
    # of every recorded run of the earlier studies, exactly the two known ones collapsed
    from e2vlib.experiments import load_results

    collapsed = sorted(f"{study}/{run['config']}/{run['seed']}"
                       for study in ("representation", "time", "encoder", "loss", "input",
                                     "noise", "data_scale", "render")
                       for run in load_results(study)["runs"] if is_collapsed(run))
    assert collapsed == ["encoder/cnn_gru/1", "time/128px/1"]
    assert COLLAPSE_IOU > 0.126  # a grid that ignores the input (the mean shape) is below it


def test_kept_checkpoints_are_the_recorded_models(tiny_events_dataset, tmp_path):
    """--keep-checkpoints keeps each run's best model; scored again, it gives the record's
    test IoU@0.3, and the command that reproduces the study names the folder."""
    from e2vlib.experiments.loader import load_split
    from e2vlib.metrics import score_split
    from e2vlib.model import load_checkpoint
    from e2vlib.train import predict

    overrides = _overrides(tiny_events_dataset)
    kept = tmp_path / "kept"
    path = run_study("loss", ["bce"], seeds=[3], out=tmp_path, quick=True, progress=False,
                     base_overrides=overrides, checkpoints=kept)
    results = json.loads(path.read_text())
    run = results["runs"][0]
    assert run["checkpoint"] == (kept / "loss" / "bce_seed3.pt").as_posix()
    assert results["command"].endswith(f"--seeds 3 --quick --keep-checkpoints {kept}")
    assert [p.name for p in (kept / "loss").iterdir()] == ["bce_seed3.pt"]  # no temp left
    test = load_split(Protocol.from_dict(results["protocol"]).updated(run["params"]), "test",
                      False)
    probabilities = predict(load_checkpoint(run["checkpoint"]), test.frames, "cpu")
    again = score_split(probabilities, test.voxels, test.categories)["overall"]["iou@0.3"]
    assert abs(again - run["metrics"]["iou@0.3"]) < 1e-9
    # shipped: the same weights, the run's threshold and where it came from; no optimizer
    from e2vlib.experiments.shipping import ship_checkpoint
    from e2vlib.model import read_checkpoint

    shipped = ship_checkpoint("loss", "bce", 3, tmp_path / "best.pt", results_root=tmp_path)
    state = read_checkpoint(shipped)
    assert state["val_threshold"] == run["metrics"]["val_threshold"]
    assert state["provenance"]["test_iou@0.3"] == run["metrics"]["iou@0.3"]
    assert state["provenance"]["command"].startswith("python -m e2vlib experiment loss "
                                                     "--configs bce --seeds 3")
    assert state["data_config"]["frame_size"] == results["protocol"]["frame_size"]
    assert "optimizer" not in state and "torch_rng" not in state
    again = predict(load_checkpoint(shipped), test.frames, "cpu")
    assert torch.equal(again, probabilities)
    with pytest.raises(ValueError, match="seed 4 is not recorded"):
        ship_checkpoint("loss", "bce", 4, tmp_path / "x.pt", results_root=tmp_path)
    (kept / "loss" / "bce_seed3.pt").unlink()
    with pytest.raises(ValueError, match="kept no checkpoint"):
        ship_checkpoint("loss", "bce", 3, tmp_path / "x.pt", results_root=tmp_path)
