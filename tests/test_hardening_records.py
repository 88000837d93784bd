"""Records and outputs against careless and hostile input (issue 39): bunched events refused,
each run counted once, results files merged under a lock by concurrent writers, outputs that
are never an input, a device or each other, records checked when read."""

from __future__ import annotations

import json
import math
import multiprocessing
import os
import stat
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from e2vlib.events import make_events
from e2vlib.experiments import STUDIES, reports, runner, summarize
from e2vlib.experiments.reconstruct import InputError, reconstruct
from e2vlib.files import atomic_path, stale_temp_files
from e2vlib.io import save_events
from e2vlib.model import build_e2v, save_checkpoint

from .conftest import REPO
from .test_cli import run

FORK = pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(),
                          reason="the concurrent writers are forked processes")


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    """An untrained tiny model taking 100 frames of 16 px."""
    path = tmp_path_factory.mktemp("model") / "tiny.pt"
    save_checkpoint(path, build_e2v("tiny", seed=0, input_shape=(100, 16, 16)))
    return path


def _bunched(kind: str) -> np.ndarray:
    """100 events of a recording whose windows (100 x 5 ms from the first event) stay empty."""
    k = np.arange(100)
    t = {"first_window": 1000 + 40 * k,  # all in the first 5 ms
         "one_ms": 1000 + 10 * k,  # a span of 1 ms
         "stray": np.where(k == 0, 0, 10_000_000 + 5000 * k),  # one event 10 s before the rest
         "ten_windows": 5000 * (k // 10)}[kind]  # exactly 100 events, in 10 windows
    return make_events(k % 16, (k // 16) % 16, t, np.ones(100))


# --- bunched events: frames with events counted, not events --------------------------------


@pytest.mark.parametrize("kind, filled", [("first_window", 1), ("one_ms", 1), ("stray", 1),
                                          ("ten_windows", 10)])
def test_reconstruct_refuses_events_that_leave_most_frames_empty(checkpoint, kind, filled):
    with pytest.raises(InputError, match=rf"^events given: only {filled} of the model's 100 "
                                         r"frames \(5000 us each, from the first event\) hold "
                                         r"events; at least 50 must"):
        reconstruct(checkpoint, events=_bunched(kind), sensor_size=(16, 16), device="cpu")


def test_the_command_line_refuses_bunched_events_and_writes_nothing(checkpoint, capsys,
                                                                    tmp_path):
    events, out = tmp_path / "bunched.npz", tmp_path / "r.npz"
    save_events(events, _bunched("stray"), (16, 16))
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", events,
                       "--out", out)
    assert code == 1 and f"--events {events}: only 1 of the model's 100 frames" in err
    assert "drop stray events" in err and not out.exists()


# --- each run counted once -----------------------------------------------------------------


def _run(config: str, seed, value: float = 0.5, **metrics) -> dict:
    return {"config": config, "params": {}, "seed": seed,
            "metrics": {"iou@0.3": value, "val_threshold": 0.3, **metrics},
            "train_seconds": 60.0, "cpu": "Test CPU"}


def test_a_duplicated_record_counts_once_and_is_named():
    results = {"study": "loss", "runs": [_run("bce", 0, 0.4), _run("bce", 1, 0.6),
                                         _run("bce", 1, 0.6), _run("bce", "0", 0.4)]}
    with pytest.warns(UserWarning, match=r"ignored 2 duplicate record\(s\): bce seed 1, bce "
                                         "seed 0"):
        rows = summarize(results)
    assert rows[0]["n"] == 2 and rows[0]["values"] == [0.4, 0.6]


@pytest.fixture
def study_file(tmp_path):
    """A representation results file of quick mode recording binary seed ``"0"`` (a string)."""
    protocol = STUDIES["representation"].protocol(True).updated({"data": str(tmp_path / "d")})
    path = tmp_path / "representation.json"
    path.write_text(json.dumps({"study": "representation", "protocol": protocol.to_dict(),
                                "runs": [_run("binary", "0")]}))
    return path, {"data": str(tmp_path / "d")}


def test_a_seed_recorded_as_text_is_done_and_not_trained_again(study_file, monkeypatch):
    path, overrides = study_file

    def never(*args, **kwargs):
        raise AssertionError("binary seed 0 is recorded: it must not train again")

    monkeypatch.setattr(runner, "run_one", never)
    runner.run_study("representation", ["binary"], seeds=[0], out=path.parent, quick=True,
                     progress=False, base_overrides=overrides, reuse=False)
    runs = json.loads(path.read_text())["runs"]
    assert [(r["config"], r["seed"]) for r in runs] == [("binary", 0)]


def test_geometry_summary_counts_each_known_object_once(tmp_path):
    from e2vlib.data import read_manifest
    from e2vlib.experiments.geometry_study import METHODS, summarize_geometry

    test = [r for r in read_manifest(REPO / "data_small") if r["split"] == "test"][:2]

    def record(sid: str, category: str, value: float) -> dict:
        return {"id": sid, "category": category,
                "scores": {m: {"iou@0.3": value} for m in METHODS}}

    runs = [record(test[0]["id"], test[0]["category"], 0.2),
            record(test[1]["id"], test[1]["category"], 0.4),
            record(test[1]["id"], test[1]["category"], 0.4),
            record("chair_9999", "chair", 1.0)]
    results = {"study": "geometry", "protocol": {"data": "data_small"}, "runs": runs}
    with pytest.warns(UserWarning) as caught:
        rows = summarize_geometry(results)
    said = " ".join(str(w.message) for w in caught)
    assert f"ignored 1 duplicate record(s): {test[1]['id']}" in said
    assert "chair_9999" in said and "not a test object of data_small" in said
    assert rows[0]["n"] == 2 and rows[0]["mean"] == pytest.approx(0.3)


# --- concurrent writers: every record survives ---------------------------------------------


def _study_writer(out: str, config: str, overrides: dict) -> None:
    """A forked `experiment representation` run whose training is a stub of 0.4 s."""
    def fake_run_one(protocol, seed, **kwargs):
        time.sleep(0.4)
        return {"seed": int(seed), "metrics": {"iou@0.3": 0.1 * (seed + 1)},
                "train_seconds": 0.4, "device": "cpu", "cpu": "Test CPU"}

    runner.run_one = fake_run_one
    runner.run_study("representation", [config], seeds=[0, 1], out=out, quick=True,
                     progress=False, base_overrides=overrides, reuse=False)


@FORK
def test_two_concurrent_studies_into_one_file_keep_every_record(tmp_path):
    context = multiprocessing.get_context("fork")
    overrides = {"data": str(tmp_path / "d")}
    writers = [context.Process(target=_study_writer, args=(str(tmp_path), config, overrides))
               for config in ("binary", "polarity")]
    for writer in writers:
        writer.start()
    for writer in writers:
        writer.join(60)
    assert [w.exitcode for w in writers] == [0, 0]
    runs = json.loads((tmp_path / "representation.json").read_text())["runs"]
    assert sorted((r["config"], r["seed"]) for r in runs) == [
        ("binary", 0), ("binary", 1), ("polarity", 0), ("polarity", 1)]


def _object_writer(path: str, method: str) -> None:
    """A forked geometry/real-mesh writer adding ``method`` to two objects, one at a time."""
    results = {"study": "geometry", "protocol": {"n_points": 1}, "runs": [],
               "checkpoints": {method: {"path": f"{method}.pt"}}}
    for sid in ("chair_0001", "table_0002"):
        time.sleep(0.2)
        results["runs"] = [*results["runs"], {"id": sid, "category": sid[:-5],
                                              "scores": {method: {"iou@0.3": 0.5}}}]
        results = runner.update_results(path, results, key=("id",))


@FORK
def test_concurrent_object_writers_merge_their_scores_per_object(tmp_path):
    path = tmp_path / "geometry.json"
    context = multiprocessing.get_context("fork")
    writers = [context.Process(target=_object_writer, args=(str(path), m))
               for m in ("best", "tiny")]
    for writer in writers:
        writer.start()
    for writer in writers:
        writer.join(60)
    assert [w.exitcode for w in writers] == [0, 0]
    results = json.loads(path.read_text())
    assert [sorted(r["scores"]) for r in results["runs"]] == [["best", "tiny"]] * 2
    assert sorted(results["checkpoints"]) == ["best", "tiny"]


def test_another_protocol_written_meanwhile_is_refused(tmp_path):
    path = tmp_path / "geometry.json"
    runner.update_results(path, {"protocol": {"n_points": 1}, "runs": []}, key=("id",))
    with pytest.raises(ValueError, match="holds runs of another protocol"):
        runner.update_results(path, {"protocol": {"n_points": 2}, "runs": []}, key=("id",))


# --- outputs: never each other, an input or a device; checked before the work ---------------


def _events(path: Path) -> Path:
    rng = np.random.default_rng(0)
    t = np.sort(rng.integers(0, 500_000, 2000))
    save_events(path, make_events(rng.integers(0, 16, 2000), rng.integers(0, 16, 2000), t,
                                  rng.integers(0, 2, 2000)), (16, 16))
    return path


def test_reconstruct_outputs_are_never_each_other_or_an_input(checkpoint, capsys, tmp_path):
    events = _events(tmp_path / "e.npz")
    before = events.read_bytes()
    out = tmp_path / "r.png"
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", events,
                       "--out", out, "--png", out)
    assert code == 2 and f"--out and --png are both {out}" in err and not out.exists()
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", events,
                       "--out", events, "--overwrite")
    assert code == 2 and f"--out {events} is the --events input" in err
    assert events.read_bytes() == before
    ckpt_bytes = checkpoint.read_bytes()
    code, _, err = run(capsys, "evaluate", "--checkpoint", checkpoint, "--data", tmp_path,
                       "--json", checkpoint)
    assert code == 2 and f"--json {checkpoint} is the --checkpoint input" in err
    assert checkpoint.read_bytes() == ckpt_bytes


def test_an_output_that_is_not_a_regular_file_is_never_replaced(checkpoint, capsys, tmp_path):
    events = _events(tmp_path / "e.npz")
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", events,
                       "--out", fifo, "--overwrite")
    assert code == 2 and f"--out {fifo} exists and is a FIFO (named pipe), not a regular" in err
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc takes no files")
def test_an_unwritable_output_is_refused_before_the_work(checkpoint, capsys, tmp_path,
                                                         monkeypatch):
    import e2vlib.experiments.reconstruct as module

    def work(*args, **kwargs):
        raise AssertionError("the output must be checked before the work")

    monkeypatch.setattr(module, "reconstruct", work)
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events",
                       _events(tmp_path / "e.npz"), "--out", "/proc/e2v/r.npz")
    assert code == 2 and "--out /proc/e2v/r.npz: cannot write into /proc" in err


def test_a_results_path_that_is_a_folder_is_refused_before_training(tmp_path, monkeypatch):
    (tmp_path / "loss.json").mkdir()
    monkeypatch.setattr(runner, "run_one", lambda *a, **k: pytest.fail("trained first"))
    with pytest.raises(ValueError, match=r"loss.json is a directory, not a results file"):
        runner.run_study("loss", ["bce"], seeds=[0], out=tmp_path, quick=True, progress=False,
                         reuse=False)


def test_a_249_character_name_is_written_through_a_short_temporary_name(tmp_path):
    target = tmp_path / ("r" * 245 + ".npz")
    with atomic_path(target) as tmp:
        assert len(tmp.name) < 100
        tmp.write_bytes(b"partial")
        assert stale_temp_files(target) == []  # this process still runs
    assert target.read_bytes() == b"partial"
    left = tmp_path / tmp.name.replace(f".{os.getpid()}.", ".999999999.")
    left.write_bytes(b"left by a killed run")
    assert stale_temp_files(target) == [left]


# --- results files checked on read ---------------------------------------------------------


@pytest.mark.parametrize("change, says", [
    (lambda r: r["metrics"].pop("iou@0.3"), "metrics.iou@0.3 is missing"),
    (lambda r: r["metrics"].update({"iou@0.3": math.nan}), "metrics.iou@0.3 is nan"),
    (lambda r: r["metrics"].update({"iou@0.3": 7.5}), "metrics.iou@0.3 is 7.5, outside [0, 1]"),
    (lambda r: r["metrics"].update({"val_threshold": math.nan}), "metrics.val_threshold is nan"),
    (lambda r: r.update(config="mse"), "config 'mse' is not a config of study 'loss'"),
    (lambda r: r.update(seed="zero"), "seed 'zero' is not a whole number"),
    (lambda r: r.pop("metrics"), "metrics is missing"),
])
def test_a_bad_record_is_refused_naming_file_run_and_key(tmp_path, change, says):
    runs = [_run("bce", 0), _run("bce", 1)]
    change(runs[1])
    path = tmp_path / "loss.json"
    path.write_text(json.dumps({"study": "loss", "runs": runs}))
    with pytest.raises(ValueError, match=rf"^{path}: run 2 \(.*\): " + says.replace(
            "[", r"\[").replace("(", r"\(")):
        reports.load_results("loss", tmp_path)


def test_experiment_names_a_bad_record_in_one_line_instead_of_showing_it(capsys, tmp_path):
    protocol = STUDIES["loss"].protocol(True).to_dict()
    path = tmp_path / "loss.json"
    path.write_text(json.dumps({"study": "loss", "protocol": protocol,
                                "runs": [_run("bce", 0, 0.4), _run("bce", 1, 7.5)]}))
    code, stdout, err = run(capsys, "experiment", "loss", "--configs", "bce", "--seeds", "0",
                            "1", "--quick", "--out", tmp_path, "--device", "cpu")
    assert code == 1 and stdout == ""
    assert (f"{path}: run 2 (bce seed 1): metrics.iou@0.3 is 7.5, outside [0, 1]; correct or "
            "remove that run") in err


def test_a_nan_threshold_is_never_shipped(tmp_path):
    from e2vlib.experiments.shipping import ship_checkpoint

    kept = save_checkpoint(tmp_path / "kept.pt", build_e2v("tiny", seed=0,
                                                          input_shape=(10, 16, 16)))
    run_record = {**_run("bce", 0), "checkpoint": str(kept), "torch": "2", "commit": "abc"}
    run_record["metrics"].update({"val_threshold": math.nan, "iou@val_threshold": 0.5})
    (tmp_path / "loss.json").write_text(json.dumps({"study": "loss", "runs": [run_record]}))
    with pytest.raises(ValueError, match="run 1 .*metrics.val_threshold is nan"):
        ship_checkpoint("loss", "bce", 0, tmp_path / "shipped.pt", results_root=tmp_path)
    assert not (tmp_path / "shipped.pt").exists()


def test_every_committed_record_passes_the_checks():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no duplicates either
        for study in [*STUDIES, "geometry", "real_meshes"]:
            if (reports.RESULTS_DIR / f"{study}.json").exists():
                reports.load_results(study)


# --- the book chooses its kernels' plotting backend ---------------------------------------


def test_the_book_sets_the_inline_backend_over_the_shells(capsys):
    """book/conf.py's kernel_environment, run on its own (the whole conf.py writes pages)."""
    import ast

    tree = ast.parse((REPO / "book" / "conf.py").read_text())
    wanted = [node for node in tree.body
              if isinstance(node, ast.FunctionDef) and node.name == "kernel_environment"
              or isinstance(node, ast.Assign) and ast.unparse(node).startswith("INLINE_")]
    namespace: dict = {"os": os, "sys": sys}
    exec(compile(ast.Module(body=wanted, type_ignores=[]), "conf.py", "exec"), namespace)
    environ = {"MPLBACKEND": "Agg"}
    namespace["kernel_environment"](environ)
    assert environ == {"MPLBACKEND": "module://matplotlib_inline.backend_inline",
                       "PYVISTA_JUPYTER_BACKEND": "static"}
    assert "MPLBACKEND=Agg of the shell replaced" in capsys.readouterr().err
