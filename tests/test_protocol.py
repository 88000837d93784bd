"""The typed study protocol: its fields, what follows from them, and the committed records."""

import json
import shutil
from pathlib import Path

import pytest

from e2vlib.experiments import runner
from e2vlib.experiments.protocol import Protocol, canonical_protocol
from e2vlib.experiments.runner import find_same_run, run_study
from e2vlib.experiments.studies import QUICK, STUDIES, Study

from .conftest import REPO

RESULTS = REPO / "experiments" / "results"


def _recorded(study: str) -> dict:
    return json.loads((RESULTS / f"{study}.json").read_text())


# --- the committed records -------------------------------------------------------------------


@pytest.mark.parametrize("study", list(STUDIES))
def test_every_committed_protocol_reads_back_to_the_same_record(study):
    recorded = _recorded(study)["protocol"]
    protocol = Protocol.from_dict(recorded)
    assert protocol == STUDIES[study].protocol()
    # the same keys in the same order: a new record has the shape of the committed one
    assert json.dumps(protocol.to_dict()) == json.dumps(recorded)
    assert json.dumps(STUDIES[study].protocol().to_dict()) == json.dumps(recorded)


@pytest.mark.parametrize("study", list(STUDIES))
def test_every_committed_run_is_its_config_of_today(study):
    spec, results = STUDIES[study], _recorded(study)
    recorded = Protocol.from_dict(results["protocol"])
    assert results["runs"]
    for run in results["runs"]:
        assert run["params"] == spec.configs[run["config"]]
        now = spec.protocol().updated(spec.configs[run["config"]])
        assert canonical_protocol(recorded.updated(run["params"])) == canonical_protocol(now)
        assert run.get("epochs", now.run_epochs) == now.run_epochs  # early records: none


def test_every_copied_run_is_the_same_training_run_as_its_origin():
    copied = 0
    for study in STUDIES:
        path = RESULTS / f"{study}.json"
        results = _recorded(study)
        for run in results["runs"]:
            if "reused_from" not in run:
                continue
            copied += 1
            origin_study, origin_config = run["reused_from"].split("/")
            origin = _recorded(origin_study)
            twin = next(r for r in origin["runs"]
                        if r["config"] == origin_config and r["seed"] == run["seed"])
            assert twin["metrics"] == run["metrics"]
            assert canonical_protocol(
                Protocol.from_dict(results["protocol"]).updated(run["params"])
            ) == canonical_protocol(
                Protocol.from_dict(origin["protocol"]).updated(twin["params"]))
            if run.get("cpu"):  # records that name no CPU are never copied again
                found = find_same_run(RESULTS, Protocol.from_dict(results["protocol"]).updated(
                    run["params"]), run["seed"], run["device"], exclude=path, cpu=run["cpu"])
                assert found is not None and found["metrics"] == run["metrics"], run
    assert copied == 17  # time, loss and input 3 each, data_scale 3, capstone 3, norm_even 2


def test_every_committed_run_is_skipped_when_the_study_runs_again(tmp_path, monkeypatch):
    """Resumability: every recorded (config, seed) of every study is found recorded."""
    def must_not_train(*args, **kwargs):
        raise AssertionError("a recorded run was trained again")

    monkeypatch.setattr(runner, "run_one", must_not_train)
    for study in STUDIES:
        shutil.copy(RESULTS / f"{study}.json", tmp_path)
        before = _recorded(study)["runs"]
        seeds: dict[str, list[int]] = {}
        for run in before:
            seeds.setdefault(run["config"], []).append(run["seed"])
        for config, config_seeds in seeds.items():
            run_study(study, [config], config_seeds, out=tmp_path, progress=False)
        after = json.loads((tmp_path / f"{study}.json").read_text())
        assert after["runs"] == before and after["protocol"] == _recorded(study)["protocol"]


# --- the protocol itself ------------------------------------------------------------------


def test_unknown_keys_and_bad_values_are_named():
    with pytest.raises(ValueError, match=r"unknown protocol keys \['frame_sise'\]; a protocol "
                                         r"has data, events,"):
        Protocol.from_dict({"frame_sise": 32})
    with pytest.raises(ValueError, match="unknown protocol keys"):
        Protocol().updated({"noize": "high"})
    with pytest.raises(ValueError, match="unknown protocol keys"):
        run_study("loss", ["bce"], base_overrides={"dataset": "x"})
    with pytest.raises(ValueError, match="frame_size must be a positive integer, got 0"):
        Protocol(frame_size=0)
    with pytest.raises(ValueError, match="train_scale 2 needs more objects: set extra"):
        Protocol(train_scale=2)
    with pytest.raises(ValueError, match="noise 'high' needs noise_events"):
        Protocol(noise="high")
    with pytest.raises(ValueError, match="study 'toy', config 'bad': unknown protocol keys"):
        Study("toy", "?", {"bad": {"epoch": 3}})


def test_a_results_file_of_another_kind_is_refused_by_name(tmp_path):
    (tmp_path / "loss.json").write_text(json.dumps(
        {"study": "loss", "protocol": {"n_points": 1}, "runs": []}))
    with pytest.raises(ValueError, match="holds runs of another protocol"):
        run_study("loss", ["bce"], out=tmp_path, progress=False)


def test_a_record_round_trips_with_every_optional_setting():
    values = {"data": "d", "events": "e", "representation": "count", "n_frames": 10,
              "dt_us": 50_000, "frame_size": 32, "preset": "tiny", "loss": "focal",
              "recipe": "tiny", "epochs": 1, "threads": 1, "noise": "medium",
              "noise_events": "n_{level}", "test_noise": ["clean", "high"], "train_scale": 2,
              "extra": "x", "test_data": {"ssaa": "d", "none": "r"}, "per_category": 2}
    protocol = Protocol.from_dict(values)
    assert protocol.to_dict() == values and list(protocol.to_dict()) == list(values)
    assert protocol.test_noise == ("clean", "high") and hash(protocol)
    assert Protocol().to_dict() == {k: v for k, v in Protocol().to_dict().items()
                                    if v is not None}
    assert set(Protocol().to_dict()) == {"data", "events", "representation", "n_frames",
                                         "dt_us", "frame_size", "preset", "loss", "recipe",
                                         "epochs", "threads"}


def test_what_follows_from_the_settings():
    base = Protocol()
    assert base.events_root == Path("cache/events_small") and base.noise_level == "clean"
    noisy = base.updated({"noise": "high", "noise_events": "cache/noise_{level}"})
    assert noisy.events_root == Path("cache/noise_high")
    stored = {"n_frames": 100, "dt_us": 5000, "windows": "fixed", "frame_size": 64}
    assert not base.needs_events(stored)  # stored binary frames, as they are
    assert not base.updated({"frame_size": 32}).needs_events(stored)  # max-pooled
    assert base.updated({"frame_size": 48}).needs_events(stored)  # 64 / 48: not whole
    assert base.updated({"representation": "count"}).needs_events(stored)
    assert noisy.needs_events(stored) and not noisy.needs_events({**stored, "noise": "high"})
    scaled = base.updated({"train_scale": 2, "extra": "x"})
    assert scaled.input_key("test") == base.input_key("test")  # the same test split
    assert scaled.input_key("train") != base.input_key("train")
    assert base.input_key("train") != base.input_key("val")
    quick = STUDIES["time"].protocol(quick=True)
    assert (quick.epochs, quick.per_category, quick.frame_size) == (
        QUICK["epochs"], QUICK["per_category"], QUICK["frame_size"])


def test_neutral_settings_make_the_same_training_run():
    base = STUDIES["representation"].protocol()
    assert base.updated({"train_scale": 1, "extra": "e"}).canonical() == base
    assert STUDIES["data_scale"].protocol().updated({"train_scale": 1}).canonical() == base
    assert STUDIES["noise"].protocol().canonical() == base  # clean: only more test scores
    assert STUDIES["noise"].protocol().updated({"noise": "medium"}).canonical() != base
    assert STUDIES["render"].protocol().canonical() != base  # scored on renders too
    assert canonical_protocol(base) == canonical_protocol(base.to_dict()) == base.to_dict()
