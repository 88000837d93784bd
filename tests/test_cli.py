"""The command line end to end on a tiny dataset: make-data -> train -> evaluate -> reconstruct."""

import json
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import trimesh

from e2vlib.__main__ import main
from e2vlib.events import make_events
from e2vlib.io import save_events
from e2vlib.model import read_checkpoint

from .cli_run import run_main
from .conftest import REPO


def test_help_lists_the_subcommands():
    out = subprocess.run([sys.executable, "-m", "e2vlib", "--help"], capture_output=True,
                         text=True, check=True, cwd=REPO).stdout
    for command in ("make-data", "train", "evaluate", "reconstruct"):
        assert command in out


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    root = tmp_path_factory.mktemp("cli")
    data, out = root / "data", root / "run"
    assert main(["make-data", "--out", str(data), "--categories", "chair,table",
                 "--per-category", "3", "--resolution", "32", "--frame-size", "16"]) == 0
    assert main(["train", "--data", str(data), "--preset", "tiny", "--out", str(out),
                 "--epochs", "2", "--lr", "1e-3", "--device", "cpu"]) == 0
    return root, data, out


def test_train_writes_checkpoints_and_history(trained):
    _, _, out = trained
    assert (out / "best.pt").exists() and (out / "last.pt").exists()
    history = json.loads((out / "history.json").read_text())
    assert [h["epoch"] for h in history] == [1, 2]


def test_train_resume_continues(trained):
    _, data, out = trained
    assert main(["train", "--data", str(data), "--out", str(out), "--epochs", "3",
                 "--resume", "--device", "cpu"]) == 0
    assert [h["epoch"] for h in json.loads((out / "history.json").read_text())] == [1, 2, 3]


def test_train_passes_loss_precision_and_layout_to_fit(trained):
    _, data, _ = trained
    out = trained[0] / "focal_run"
    assert main(["train", "--data", str(data), "--out", str(out), "--epochs", "1",
                 "--loss", "focal", "--channels-last", "--device", "cpu"]) == 0
    last = read_checkpoint(out / "last.pt")
    assert (last["loss"], last["precision"], last["channels_last"]) == ("focal", "fp32", True)


def test_evaluate_writes_the_json_layout(trained, capsys):
    root, data, out = trained
    path = root / "test.json"
    assert main(["evaluate", "--checkpoint", str(out / "best.pt"), "--data", str(data),
                 "--split", "test", "--json", str(path), "--fscore-points", "256"]) == 0
    result = json.loads(path.read_text())
    keys = {"iou@0.2", "iou@0.3", "iou@0.4", "iou@0.5", "fscore@1%", "fscore@20%"}
    assert set(result["overall"]) == keys
    assert set(result["per_category"]) == {"chair", "table"}
    assert set(result["per_category"]["chair"]) == keys | {"n"}
    assert set(result["baseline_mean_shape"]) == keys
    assert "overall" in capsys.readouterr().out  # the printed table


@pytest.mark.slow  # two reconstructions end to end (mesh, then an events file)
def test_reconstruct_from_mesh_and_events(trained):
    root, _, out = trained
    mesh_path = root / "box.stl"
    trimesh.creation.box((0.6, 0.4, 0.8)).export(mesh_path)
    assert main(["reconstruct", "--checkpoint", str(out / "best.pt"), "--mesh", str(mesh_path),
                 "--out", str(root / "rec.npz"), "--png", str(root / "rec.png")]) == 0
    with np.load(root / "rec.npz", allow_pickle=False) as rec:
        assert rec["probabilities"].shape == (32, 32, 32)
        assert 0 <= rec["probabilities"].min() and rec["probabilities"].max() <= 1
        assert rec["voxels"].shape == (32, 32, 32) and rec["voxels"].any()
        assert rec["frames"].shape == (100, 16, 16)
    assert (root / "rec.png").stat().st_size > 1000

    rng = np.random.default_rng(0)
    t = np.sort(rng.integers(0, 500_000, 3000))
    events = make_events(rng.integers(0, 40, 3000), rng.integers(0, 30, 3000), t,
                         rng.integers(0, 2, 3000))
    save_events(root / "rec_events.h5", events, (40, 30))
    assert main(["reconstruct", "--checkpoint", str(out / "best.pt"), "--events",
                 str(root / "rec_events.h5"), "--out", str(root / "rec2.npz")]) == 0
    with np.load(root / "rec2.npz", allow_pickle=False) as rec:
        assert rec["probabilities"].shape == (32, 32, 32) and "voxels" not in rec
        # a 40 x 30 sensor holds one 16 x 16 square (factor 1): it is centre-cropped
        assert rec["frames"].shape == (100, 16, 16)


# --- errors: one line on stderr, exit 2 for bad arguments and 1 for failures (issue 14) ------


def run(capsys, *argv) -> tuple[int, str, str]:
    """Run the CLI in-process (:func:`tests.cli_run.run_main`)."""
    return run_main(main, capsys, *argv)


TRAIN = ("train", "--data", "nowhere", "--out", "nowhere_run")


@pytest.mark.parametrize("args, says", [
    (("--recipe", "bogus"), r"--recipe 'bogus' is not a training recipe; choose one of paper, "
                            r"tiny"),
    (("--batch-size", "-2"), r"argument --batch-size: must be a whole number >= 1, got -2"),
    (("--epochs", "0"), r"argument --epochs: must be a whole number >= 1, got 0"),
    (("--lr", "nan"), r"argument --lr: must be a finite number > 0, got nan"),
    (("--lr", "-0.001"), r"argument --lr: must be a finite number > 0, got -0.001"),
    (("--lr", "-1e-3"), r"argument --lr: expected one argument"),
    (("--device", "tpu"), r"--device 'tpu' is not a device; use one of auto, cpu, cuda, "
                          r"cuda:N"),
    (("--preset", "huge"), r"--preset 'huge' is not a model preset; choose one of .*paper, tiny"),
    (("--seed", "x"), r"argument --seed: expected a whole number >= 0, got 'x'"),
    (("--init", "a.pt", "--resume"), r"--init starts a new run .* leave out --resume"),
    (("--bogus-flag",), r"unrecognized arguments: --bogus-flag"),
    (("--loss", "dice"), r"argument --loss: invalid choice: 'dice'"),
    (("--precision", "fp16"), r"argument --precision: invalid choice: 'fp16'"),
])
def test_train_usage_errors_are_one_line_with_exit_2(capsys, tmp_path, monkeypatch, args, says):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *TRAIN, *args)
    assert code == 2
    assert re.search(says, err), err
    assert list(tmp_path.iterdir()) == []  # refused before anything was written


@pytest.mark.skipif(torch.cuda.is_available(), reason="needs a machine without CUDA")
def test_cuda_without_a_gpu_is_a_usage_error(capsys, tmp_path):
    code, _, err = run(capsys, "evaluate", "--checkpoint", tmp_path / "x.pt", "--data",
                       tmp_path, "--device", "cuda")
    assert code == 2 and "--device cuda" in err and "--device cpu" in err


MAKE = ("make-data", "--categories", "chair", "--per-category", "1", "--resolution", "16",
        "--frame-size", "8")


@pytest.mark.parametrize("args, says", [
    (("--frame-size", "0"), r"argument --frame-size: must be a whole number >= 1, got 0"),
    (("--workers", "0"), r"argument --workers: must be a whole number >= 1, got 0"),
    (("--oversample", "0"), r"argument --oversample: must be a whole number >= 1, got 0"),
    (("--per-category", "-1"), r"argument --per-category: must be a whole number >= 1"),
    (("--categories", ""), r"--categories '' names no category; give a comma-separated subset "
                           r"of airplane,"),
    (("--categories", " , "), r"names no category"),
    (("--categories", "chair,spaceship"), r"--categories: unknown \['spaceship'\]; choose "
                                          r"from airplane,"),
    (("--categories", "chair,chair"), r"names \['chair'\] more than once"),
    (("--frame-size", "5"), r"invalid dataset settings: frame_size 5 must divide resolution 16"),
    (("--shard", "3/2"), r"--shard: shard '3/2': need 0 <= i < n"),
    (("--preset", "huge"), r"argument --preset: invalid choice: 'huge'"),
])
def test_make_data_validates_everything_before_writing(capsys, tmp_path, args, says):
    out = tmp_path / "data"
    code, _, err = run(capsys, *MAKE, *args, "--out", out)
    assert code == 2
    assert re.search(says, err), err
    assert not out.exists()  # no config.json to block the corrected rerun


def test_make_data_out_is_a_file(capsys, tmp_path):
    (tmp_path / "data").write_text("not a folder")
    code, _, err = run(capsys, *MAKE, "--out", tmp_path / "data")
    assert code == 2 and "is a file; give a folder" in err


def test_debug_shows_the_traceback_before_or_after_the_subcommand(capsys):
    for argv in (["--debug", *TRAIN, "--recipe", "bogus"], [*TRAIN, "--recipe", "bogus",
                                                              "--debug"]):
        with pytest.raises(Exception, match="--recipe 'bogus'"):
            main(argv)


@pytest.mark.slow  # two real `python -m e2vlib` processes
def test_debug_in_a_real_process_prints_the_traceback(tmp_path):
    cmd = [sys.executable, "-m", "e2vlib", *TRAIN, "--recipe", "bogus"]
    plain = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path,
                           env={**os.environ, "PYTHONPATH": str(REPO)})
    assert plain.returncode == 2
    assert plain.stderr.strip().count("\n") == 0 and plain.stderr.startswith("error: ")
    debug = subprocess.run([*cmd, "--debug"], capture_output=True, text=True, cwd=tmp_path,
                           env={**os.environ, "PYTHONPATH": str(REPO)})
    assert debug.returncode == 1 and "Traceback (most recent call last)" in debug.stderr


def test_failures_exit_1_with_the_library_message(capsys, tmp_path):
    code, _, err = run(capsys, "train", "--data", tmp_path / "missing", "--out", tmp_path / "r",
                       "--device", "cpu")
    assert code == 1 and "missing does not exist" in err


def test_unexpected_exceptions_are_one_line_too(capsys, monkeypatch):
    import e2vlib.__main__ as cli

    def broken(args):
        raise KeyError("optimizer")

    monkeypatch.setattr(cli, "_figures", broken)
    code, _, err = run(capsys, "figures")
    assert code == 1
    assert "error: KeyError: 'optimizer' (unexpected; rerun with --debug" in err


def test_evaluate_json_is_a_directory_fails_at_once(capsys, tmp_path):
    folder = tmp_path / "results"
    folder.mkdir()
    # the checkpoint does not even exist: the output is checked before any work
    code, _, err = run(capsys, "evaluate", "--checkpoint", tmp_path / "none.pt", "--data",
                       tmp_path, "--json", folder)
    assert code == 2
    assert f"--json {folder} is a directory; give a file name, e.g. {folder}/results.json" in err
    assert list(folder.iterdir()) == []


def test_reconstruct_out_is_a_directory_fails_at_once(capsys, tmp_path):
    folder = tmp_path / "rec"
    folder.mkdir()
    code, _, err = run(capsys, "reconstruct", "--checkpoint", tmp_path / "none.pt", "--events",
                       tmp_path / "none.h5", "--out", folder)
    assert code == 2 and f"--out {folder} is a directory" in err
    assert list(folder.iterdir()) == []
    code, _, err = run(capsys, "reconstruct", "--checkpoint", tmp_path / "none.pt", "--events",
                       tmp_path / "none.h5", "--out", tmp_path / "r.npz", "--png", folder)
    assert code == 2 and "--png" in err and "is a directory" in err
    code, _, err = run(capsys, "reconstruct", "--checkpoint", tmp_path / "none.pt", "--events",
                       tmp_path / "none.h5", "--out", tmp_path / "r.npz", "--png",
                       tmp_path / "r.gif")
    assert code == 2 and "unknown picture type '.gif'" in err


def test_outputs_in_unwritable_places_fail_at_once(capsys, tmp_path, monkeypatch):
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    code, _, err = run(capsys, "evaluate", "--checkpoint", tmp_path / "none.pt", "--data",
                       tmp_path, "--json", blocker / "sub" / "r.json")
    assert code == 2 and f"{blocker} is a file, not a folder" in err
    code, _, err = run(capsys, "train", "--data", tmp_path, "--out", blocker / "run")
    assert code == 2 and "is a file, not a folder" in err
    # a folder without write permission (simulated: the tests may run as root)
    locked = tmp_path / "locked"
    locked.mkdir()
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if Path(p) == locked
                        else real_access(p, mode))
    code, _, err = run(capsys, "evaluate", "--checkpoint", tmp_path / "none.pt", "--data",
                       tmp_path, "--json", locked / "deep" / "r.json")
    assert code == 2
    assert f"cannot write into {locked} (permission denied or read-only)" in err


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0,
                    reason="root may write into read-only folders")
def test_read_only_folder_for_real(capsys, tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        code, _, err = run(capsys, "reconstruct", "--checkpoint", tmp_path / "none.pt",
                           "--events", tmp_path / "none.h5", "--out", locked / "r.npz")
    finally:
        locked.chmod(0o700)
    assert code == 2 and "cannot write into" in err


def test_other_usage_errors(capsys, tmp_path):
    code, _, err = run(capsys, "evaluate", "--checkpoint", "x.pt", "--data", tmp_path,
                       "--fscore-points", "0")
    assert code == 2 and "--fscore-points: must be a whole number >= 1, got 0" in err
    code, _, err = run(capsys, "evaluate", "--checkpoint", "x.pt", "--data", tmp_path,
                       "--split", "dev")
    assert code == 2 and "invalid choice: 'dev'" in err and "evaluate --help" in err
    code, _, err = run(capsys, "reconstruct", "--checkpoint", "x.pt", "--out", tmp_path / "r.npz")
    assert code == 2 and "one of the arguments --mesh --events is required" in err
    code, _, err = run(capsys, "reconstruct", "--checkpoint", "x.pt", "--events",
                       tmp_path / "none.h5", "--out", tmp_path / "r.npz")
    assert code == 2 and "--events" in err and "no such file" in err
    assert run(capsys, "--help")[0] == 0


# --- checkpoints and datasets that do not belong together ----------------------------------


def _copy_dataset(src, dst, **changes):
    """A copy of a dataset whose config.json claims other settings (frames unchanged)."""
    shutil.copytree(src, dst)
    config = json.loads((dst / "config.json").read_text())
    config.update(changes)
    (dst / "config.json").write_text(json.dumps(config))
    return dst


def test_evaluate_refuses_data_with_other_frames(trained, capsys, tmp_path):
    _, data, out = trained
    other = _copy_dataset(data, tmp_path / "fast", dt_us=2500)
    json_path = tmp_path / "r.json"
    code, _, err = run(capsys, "evaluate", "--checkpoint", out / "best.pt", "--data", other,
                       "--json", json_path, "--fscore-points", "16")
    assert code == 1
    assert f"dt_us is 5000 in checkpoint {out / 'best.pt'} but 2500 in dataset {other}" in err
    assert not json_path.exists()
    other = _copy_dataset(data, tmp_path / "paper_windows", windows="paper")
    code, _, err = run(capsys, "evaluate", "--checkpoint", out / "best.pt", "--data", other)
    assert code == 1 and "windows is 'fixed' in checkpoint" in err and "'paper' in dataset" in err


def test_reconstruct_refuses_an_inconsistent_checkpoint(trained, capsys, tmp_path):
    from e2vlib.model import load_checkpoint, save_checkpoint

    root, data, out = trained
    model = load_checkpoint(out / "best.pt")
    config = json.loads((data / "config.json").read_text())
    bad = save_checkpoint(tmp_path / "bad.pt", model, data_config={**config, "frame_size": 32})
    mesh_path = tmp_path / "box.stl"
    trimesh.creation.box((0.6, 0.4, 0.8)).export(mesh_path)
    code, _, err = run(capsys, "reconstruct", "--checkpoint", bad, "--mesh", mesh_path, "--out",
                       tmp_path / "r.npz")
    assert code == 1 and "is inconsistent: its model takes 100 frames of 16 px" in err
    assert "makes 100 frames of 32 px" in err and not (tmp_path / "r.npz").exists()


def test_reconstruct_refuses_nan_output(trained, capsys, tmp_path, monkeypatch):
    import e2vlib.train

    _, _, out = trained
    rng = np.random.default_rng(1)  # events of its own: the test must not need another's
    events = make_events(rng.integers(0, 40, 500), rng.integers(0, 30, 500),
                         np.sort(rng.integers(0, 500_000, 500)), rng.integers(0, 2, 500))
    save_events(tmp_path / "events.h5", events, (40, 30))
    monkeypatch.setattr(e2vlib.train, "predict",
                        lambda model, frames, device: torch.full((1, 32, 32, 32), math.nan))
    code, _, err = run(capsys, "reconstruct", "--checkpoint", out / "best.pt", "--events",
                       tmp_path / "events.h5", "--out", tmp_path / "r.npz")
    assert code == 1 and "NaN/inf" in err and not (tmp_path / "r.npz").exists()


def test_reconstruct_from_events_with_times_beyond_int64_is_one_line(trained, capsys, tmp_path):
    _, _, out = trained
    events = tmp_path / "far.txt"
    events.write_text("40 30\n0.5 1 1 1\n9223372036854.775808 2 2 0\n")
    code, _, err = run(capsys, "reconstruct", "--checkpoint", out / "best.pt", "--events",
                       events, "--out", tmp_path / "r.npz")
    assert code == 1 and "far.txt: t: 1 values outside the int64 microsecond range" in err


def test_resume_from_a_slim_checkpoint_says_it_holds_weights_only(trained, capsys, tmp_path):
    _, data, _ = trained
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    shutil.copy(REPO / "data_small" / "checkpoints" / "first_recipe.pt", run_dir / "last.pt")
    code, _, err = run(capsys, "train", "--data", data, "--out", run_dir, "--resume",
                       "--device", "cpu")
    assert code == 1
    assert f"cannot resume from {run_dir / 'last.pt'}: it holds the weights only" in err
    assert "optimizer" in err and f"--init {run_dir / 'last.pt'}" in err
    assert "KeyError" not in err


def test_resume_with_another_preset_is_refused_naming_both(trained, capsys):
    _, data, out = trained
    before = (out / "history.json").read_text()
    code, _, err = run(capsys, "train", "--data", data, "--out", out, "--resume", "--preset",
                       "tiny2d", "--device", "cpu")
    assert code == 1
    assert f"--preset tiny2d differs from the model in {out / 'last.pt'}, which holds preset " \
           "tiny (different encoder)" in err
    assert (out / "history.json").read_text() == before


def test_resume_without_last_pt_and_with_nothing_left_to_do(trained, capsys, tmp_path):
    _, data, out = trained
    code, _, err = run(capsys, "train", "--data", data, "--out", tmp_path / "new", "--resume")
    assert code == 2 and "last.pt does not exist, so there is nothing to resume" in err
    done = len(json.loads((out / "history.json").read_text()))
    code, printed, _ = run(capsys, "train", "--data", data, "--out", out, "--resume",
                           "--epochs", str(done), "--device", "cpu")
    assert code == 0 and f"nothing to do: {out / 'last.pt'} already holds {done} epochs" in printed


def test_init_starts_a_new_run_from_a_checkpoint(trained, capsys, tmp_path):
    from e2vlib.model import read_checkpoint

    _, data, out = trained
    new = tmp_path / "finetune"
    code, _, _ = run(capsys, "train", "--data", data, "--out", new, "--init", out / "best.pt",
                     "--epochs", "1", "--device", "cpu")
    assert code == 0
    assert [h["epoch"] for h in json.loads((new / "history.json").read_text())] == [1]
    assert read_checkpoint(new / "last.pt")["config"] == read_checkpoint(out / "best.pt")["config"]
    other = _copy_dataset(data, tmp_path / "fast", dt_us=2500)
    code, _, err = run(capsys, "train", "--data", other, "--out", tmp_path / "x", "--init",
                       out / "best.pt", "--epochs", "1", "--device", "cpu")
    assert code == 1 and "dt_us is 5000 in checkpoint" in err and not (tmp_path / "x").exists()


def test_corrected_rerun_after_a_refused_make_data_builds(capsys, tmp_path):
    out = tmp_path / "data"
    assert run(capsys, *MAKE, "--oversample", "0", "--out", out)[0] == 2
    code, printed, _ = run(capsys, *MAKE, "--oversample", "1", "--out", out)
    assert code == 0 and "manifest" in printed
    assert json.loads((out / "config.json").read_text())["oversample"] == 1


# --- grey video and sharded builds (issues 13, 15) ------------------------------------------


def test_make_data_command_spells_out_the_config_it_came_from():
    from e2vlib.__main__ import build_parser
    from e2vlib.cli.data_commands import build_config
    from e2vlib.data import BuildConfig, make_data_command

    for config in (BuildConfig(categories=("table", "chair"), per_category=3, resolution=32,
                               frame_size=16, oversample=2, contrast=0.15, seed=4,
                               windows="paper", n_frames=50, dt_us=10_000, grey_video=True),
                   BuildConfig(categories=("lamp",), per_category=3, noise="high",
                               splits=("val", "test"), anti_aliasing="none"),
                   BuildConfig.from_dict(json.loads((REPO / "data_small" / "config.json")
                                                    .read_text()))):
        command = make_data_command(config, "out_dir", "1/4").split()
        assert command[:4] == ["python", "-m", "e2vlib", "make-data"]
        args = build_parser().parse_args(command[3:])
        assert build_config(args) == config and (args.out, args.shard) == ("out_dir", "1/4")


@pytest.mark.parametrize("args, says", [
    (("--contrast", "0"), r"argument --contrast: must be a finite number > 0, got 0"),
    (("--grey-video", "yes"), r"unrecognized arguments: yes"),
    (("--noise", "loud"), r"argument --noise: invalid choice: 'loud'"),
    (("--anti-aliasing", "fxaa"), r"argument --anti-aliasing: invalid choice: 'fxaa'"),
    (("--splits", "holdout"), r"argument --splits: invalid choice: 'holdout'"),
    (("--splits", "test", "test"), r"splits must be some of train, val, test \(each once\)"),
])
def test_make_data_new_options_are_checked_before_writing(capsys, tmp_path, args, says):
    out = tmp_path / "data"
    code, _, err = run(capsys, *MAKE, *args, "--out", out)
    assert code == 2 and re.search(says, err), err
    assert not out.exists()


def test_make_data_splits_builds_only_those_samples_of_the_full_plan(capsys, tmp_path):
    from e2vlib.data import BuildConfig, plan_samples, read_manifest

    out = tmp_path / "noisy"
    code, _, _ = run(capsys, *MAKE, "--per-category", "3", "--noise", "low", "--splits", "test",
                     "--out", out)  # 3 objects: one each for train, val and test
    assert code == 0
    stored = json.loads((out / "config.json").read_text())
    assert stored["noise"] == "low" and stored["splits"] == ["test"]
    planned = plan_samples(BuildConfig.from_dict(stored))
    assert {r["id"] for r in read_manifest(out)} == {s.id for s in planned if s.split == "test"}
    assert [s.split for s in planned].count("test") == 1 and len(planned) == 3
    assert [p.name for p in (out / "samples").iterdir()] == [
        f"{s.id}.npz" for s in planned if s.split == "test"]


def test_merge_data_usage_errors(capsys, tmp_path):
    code, _, err = run(capsys, "merge-data", "--out", tmp_path / "m", tmp_path / "nope")
    assert code == 2 and f"shard folder {tmp_path / 'nope'}: no such folder" in err
    code, _, err = run(capsys, "merge-data", "--out", tmp_path / "m")
    assert code == 2 and "holds no dataset to verify; list the shard folders" in err
    (tmp_path / "file").write_text("x")
    code, _, err = run(capsys, "merge-data", "--out", tmp_path / "file", tmp_path)
    assert code == 2 and "is a file; give a folder" in err
    code, _, err = run(capsys, "merge-data", "--out", tmp_path / "m", tmp_path)
    assert code == 1 and "is not a dataset folder (no config.json)" in err
    assert not (tmp_path / "m").exists()


# --- one home for each fact (issue 24) -------------------------------------------------------


def test_the_choices_are_the_librarys_own_tuples():
    from e2vlib.__main__ import build_parser
    from e2vlib.data import SPLITS
    from e2vlib.frames import WINDOWS
    from e2vlib.losses import LOSSES
    from e2vlib.model import PRESETS
    from e2vlib.noise import NOISE_LEVELS
    from e2vlib.render import ANTI_ALIASING
    from e2vlib.scale.options import PRECISIONS
    from e2vlib.train import RECIPES

    commands = next(a for a in build_parser()._actions if a.dest == "command").choices

    def option(command: str, dest: str):
        return next(a for a in commands[command]._actions if a.dest == dest)

    assert tuple(option("make-data", "windows").choices) == WINDOWS
    assert tuple(option("make-data", "noise").choices) == tuple(NOISE_LEVELS)
    assert tuple(option("make-data", "splits").choices) == SPLITS
    assert option("make-data", "splits").default == list(SPLITS)
    assert tuple(option("make-data", "anti_aliasing").choices) == ANTI_ALIASING
    assert tuple(option("train", "loss").choices) == tuple(LOSSES)
    assert tuple(option("train", "precision").choices) == PRECISIONS
    assert tuple(option("evaluate", "split").choices) == SPLITS
    for name in PRESETS:
        assert name in option("train", "preset").help
    for name in RECIPES:
        assert name in option("train", "recipe").help
    from e2vlib.experiments import STUDIES

    for name in (*STUDIES, "geometry"):
        assert name in option("experiment", "study").help


def test_reconstruct_writes_what_the_library_returns(trained, tmp_path):
    from e2vlib.experiments.reconstruct import reconstruct

    _, _, out = trained
    mesh_path = tmp_path / "box.stl"
    trimesh.creation.box((0.6, 0.4, 0.8)).export(mesh_path)
    assert main(["reconstruct", "--checkpoint", str(out / "best.pt"), "--mesh", str(mesh_path),
                 "--out", str(tmp_path / "r.npz"), "--device", "cpu"]) == 0
    result = reconstruct(out / "best.pt", mesh=mesh_path, device="cpu")
    with np.load(tmp_path / "r.npz", allow_pickle=False) as written:
        assert sorted(written) == sorted(result.arrays())
        for key, value in result.arrays().items():
            np.testing.assert_array_equal(written[key], value)


@pytest.mark.parametrize("args, says", [
    (("loss", "--checkpoint", "best=x.pt"), r"--checkpoint is for the geometry study; .* "
                                            r"--keep-checkpoints DIR"),
    (("geometry", "--checkpoint", "best"), r"--checkpoint must look like NAME=PATH, got 'best'"),
    (("geometry", "--checkpoint", "best=nowhere.pt"), r"--checkpoint best=nowhere.pt: no file "
                                                      r"nowhere.pt"),
])
def test_experiment_checkpoint_flags_are_checked_before_any_work(capsys, tmp_path, monkeypatch,
                                                                  args, says):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "experiment", *args)
    assert code == 2
    assert re.search(says, err), err
    assert list(tmp_path.iterdir()) == []
