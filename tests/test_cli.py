"""The command line end to end on a tiny dataset: make-data -> train -> evaluate -> reconstruct."""

import json
import subprocess
import sys

import numpy as np
import pytest
import trimesh

from e2vlib.__main__ import main
from e2vlib.events import make_events
from e2vlib.io import save_events

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
