"""The command line against careless and hostile input (issue 26): no answer from too few
events, no silent overwrite, every size bounded before the work, folders kept apart."""

from __future__ import annotations

import shutil
import time

import numpy as np
import pytest

from e2vlib.data import BuildConfig, build_dataset, save_sample
from e2vlib.events import EventError, make_events
from e2vlib.inputs import recording_input
from e2vlib.io import save_events
from e2vlib.model import build_e2v, save_checkpoint

from .test_cli import run

TINY = BuildConfig(categories=("chair", "table"), per_category=3, resolution=32, frame_size=16,
                   seed=7)


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    """An untrained tiny model taking 100 frames of 16 px."""
    path = tmp_path_factory.mktemp("model") / "tiny.pt"
    save_checkpoint(path, build_e2v("tiny", seed=0, input_shape=(100, 16, 16)))
    return path


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("cli_hardening") / "data"
    build_dataset(root, TINY, progress=False)
    return root


def _events(path, n: int):
    rng = np.random.default_rng(n)
    t = np.sort(rng.integers(0, 500_000, n))
    save_events(path, make_events(rng.integers(0, 32, n), rng.integers(0, 32, n), t,
                                  rng.integers(0, 2, n)), (32, 32))
    return path


# --- too few events: refused by name, nothing written -----------------------------------------


@pytest.mark.parametrize("n", [0, 1, 99])
def test_reconstruct_refuses_too_few_events_and_says_how_many(checkpoint, capsys, tmp_path, n):
    events = _events(tmp_path / "few.npz", n)
    out = tmp_path / "r.npz"
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", events,
                       "--out", out)
    assert code == 1
    assert (f"--events {events}: {n} event(s) cannot make the model's input: its 100 frames "
            "of 5000 us need at least 100 events (one per frame") in err
    assert not out.exists()


def test_reconstruct_with_enough_events_writes_its_output(checkpoint, capsys, tmp_path):
    out = tmp_path / "r.npz"
    code, stdout, _ = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events",
                          _events(tmp_path / "ok.npz", 100), "--out", out)
    assert code == 0 and f"wrote {out}" in stdout
    with np.load(out) as result:
        assert result["probabilities"].shape == (32, 32, 32)
        assert result["frames"].shape == (100, 16, 16) and result["frames"].sum() > 0


def test_events_to_model_input_needs_one_event_per_frame():
    events = make_events(np.arange(10), np.zeros(10), np.arange(10) * 1000, np.ones(10))
    with pytest.raises(EventError, match="10 event\\(s\\) cannot make the model's input: its "
                                         "11 frames of 1000 us need at least 11 events"):
        recording_input(events, (16, 16), 8, n_frames=11, dt_us=1000)
    frames = recording_input(events, (16, 16), 8, n_frames=10, dt_us=1000)
    assert frames.shape == (10, 8, 8) and frames.sum() == 10  # one event in each frame


def test_reconstruct_never_overwrites_unless_asked(checkpoint, capsys, tmp_path):
    events = _events(tmp_path / "ok.npz", 200)
    out, png = tmp_path / "r.npz", tmp_path / "r.png"
    out.write_bytes(b"an earlier result")
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", events,
                       "--out", out)
    assert code == 2 and f"--out {out} exists; pass --overwrite to replace it" in err
    assert out.read_bytes() == b"an earlier result"
    # too few events with --overwrite: refused, and the earlier result is kept
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events",
                       _events(tmp_path / "one.npz", 1), "--out", out, "--overwrite")
    assert code == 1 and out.read_bytes() == b"an earlier result"
    png.write_bytes(b"an earlier picture")
    code, _, err = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", events,
                       "--out", tmp_path / "new.npz", "--png", png)
    assert code == 2 and f"--png {png} exists" in err and not (tmp_path / "new.npz").exists()
    code, _, _ = run(capsys, "reconstruct", "--checkpoint", checkpoint, "--events", events,
                     "--out", out, "--overwrite")
    assert code == 0
    with np.load(out) as result:
        assert result["probabilities"].shape == (32, 32, 32)


# --- sizes bounded before the work ---------------------------------------------------------


def test_make_data_bounds_per_category_at_once(capsys, tmp_path):
    start = time.monotonic()
    code, _, err = run(capsys, "make-data", "--out", tmp_path / "d", "--per-category",
                       "1000000000")
    assert code == 2 and "per_category 1000000000 is more than 10000" in err
    assert time.monotonic() - start < 5 and not (tmp_path / "d").exists()
    with pytest.raises(ValueError, match="resolution 8192 is more than 4096 px"):
        BuildConfig(categories=("chair",), per_category=1, resolution=8192, frame_size=64)


def test_make_data_prints_the_plan_before_the_work(capsys, tmp_path):
    out = tmp_path / "d"
    code, stdout, _ = run(capsys, "make-data", "--out", out, "--categories", "chair",
                          "--per-category", "1", "--resolution", "16", "--frame-size", "8",
                          "--n-frames", "10")
    assert code == 0
    lines = stdout.splitlines()
    assert lines[0] == ("plan: 1 samples (1 categories x 1 objects; splits train, val, test): "
                        "0 already built, 1 to build")
    assert lines[-1] == f"manifest: {out / 'manifest.csv'}"
    code, stdout, _ = run(capsys, "make-data", "--out", out, "--categories", "chair",
                          "--per-category", "1", "--resolution", "16", "--frame-size", "8",
                          "--n-frames", "10")
    assert code == 0 and "1 already built, 0 to build" in stdout.splitlines()[0]


def test_evaluate_bounds_the_fscore_points(capsys, tmp_path):
    code, _, err = run(capsys, "evaluate", "--checkpoint", tmp_path / "x.pt", "--data", tmp_path,
                       "--fscore-points", "1000000000000")
    assert code == 2 and ("--fscore-points: must be a whole number from 1 to 1048576, got "
                          "1000000000000") in err


# --- folder rules -------------------------------------------------------------------------------


def test_make_data_refuses_a_folder_of_unrelated_files(capsys, tmp_path):
    folder = tmp_path / "home"
    folder.mkdir()
    (folder / "thesis.tex").write_text("\\documentclass{article}")
    code, stdout, err = run(capsys, "make-data", "--out", folder, "--categories", "chair",
                            "--per-category", "1", "--resolution", "16", "--frame-size", "8")
    assert code == 1 and "exists and is not a dataset (no config.json; it holds thesis.tex)" in err
    assert stdout == "" and [p.name for p in folder.iterdir()] == ["thesis.tex"]


def test_train_refuses_an_out_inside_the_dataset(dataset, capsys):
    for out in (dataset / "run", dataset, dataset / "samples" / "x"):
        code, _, err = run(capsys, "train", "--data", dataset, "--out", out, "--device", "cpu")
        assert code == 2 and f"--out {out} is inside the dataset folder {dataset}" in err
    assert not (dataset / "run").exists() and not (dataset / "samples" / "x").exists()


# --- verify-data ---------------------------------------------------------------------------


def test_verify_data_reports_every_bad_sample_and_exits_1(dataset, capsys, tmp_path):
    code, stdout, _ = run(capsys, "verify-data", "--data", dataset)
    assert code == 0
    assert stdout.strip() == (f"verified {dataset}: all 6 samples load as config.json says and "
                              "match the manifest's sha256")
    copy = shutil.copytree(dataset, tmp_path / "copy")
    (copy / "samples" / "chair_0000.npz").unlink()
    save_sample(copy / "samples" / "table_0001.npz", np.zeros((100, 16, 16), np.uint8),
                np.zeros((32, 32, 32), bool), 0)
    code, stdout, err = run(capsys, "verify-data", "--data", copy)
    assert code == 1 and f"2 of 6 samples of {copy} are bad (listed above)" in err
    bad = [line for line in stdout.splitlines() if line.startswith("bad: ")]
    assert len(bad) == 2
    assert "sample 'chair_0000'" in bad[0] and "missing on disk" in bad[0]
    assert "table_0001.npz does not match the sha256" in bad[1]


def test_verify_data_on_an_older_manifest_says_what_it_could_not_check(dataset, capsys,
                                                                      tmp_path):
    copy = shutil.copytree(dataset, tmp_path / "copy")
    lines = (copy / "manifest.csv").read_text().splitlines()
    (copy / "manifest.csv").write_text("\n".join(line.rsplit(",", 1)[0] for line in lines))
    code, stdout, _ = run(capsys, "verify-data", "--data", copy)
    assert code == 0
    assert stdout.startswith(f"checked {copy}: all 6 samples load as config.json says; the "
                             "manifest records no sha256 for 6 of them")
    assert f"record them with `python -m e2vlib make-data --out {copy} --categories" in stdout


def test_verify_data_on_a_broken_manifest_is_one_line(dataset, capsys, tmp_path):
    copy = shutil.copytree(dataset, tmp_path / "copy")
    (copy / "manifest.csv").write_bytes(b"\x89PNG\r\n\x1a\n")
    code, _, err = run(capsys, "verify-data", "--data", copy)
    assert code == 1 and "manifest.csv is not a text manifest" in err


def test_a_workers_refusal_prints_as_one_plain_line_and_a_bug_stays_unexpected():
    import pickle

    from e2vlib.data.build import JobError, run_jobs
    from e2vlib.experiments.errors import one_line

    with pytest.raises(JobError) as refused:
        run_jobs(int, ["1", "x"], 1, "parsing", "number", False, names=["one", "ex"])
    back = pickle.loads(pickle.dumps(refused.value))  # as it returns from a worker process
    assert back.expected and one_line(back) == (
        "ex failed: ValueError: invalid literal for int() with base 10: 'x'")

    def bug(_):
        raise KeyError("optimizer")

    with pytest.raises(JobError) as crashed:
        run_jobs(bug, ["a"], 1, "running", "job", False)
    assert not crashed.value.expected and "(unexpected;" in one_line(crashed.value)
