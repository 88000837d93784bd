"""e2vlib.experiments.reconstruct: one object from a mesh or from events, as ``python -m e2vlib
reconstruct`` does it; known answers from data_small's shipped checkpoint and samples."""

import csv
import math

import numpy as np
import pytest
import torch

from e2vlib.data import load_sample
from e2vlib.events import make_events
from e2vlib.experiments.reconstruct import (
    InputError,
    Reconstruction,
    checkpoint_build_config,
    reconstruct,
)
from e2vlib.inputs import recording_input
from e2vlib.io import load_events, save_events
from e2vlib.metrics import iou
from e2vlib.model import build_e2v, load_checkpoint, read_checkpoint, save_checkpoint
from e2vlib.shapes import make_shape
from e2vlib.train import predict

from .conftest import REPO

SMALL = REPO / "data_small"
TINY = SMALL / "checkpoints" / "first_recipe.pt"


def _test_sample(sample_id: str) -> dict:
    with open(SMALL / "manifest.csv", newline="") as f:
        return next(row for row in csv.DictReader(f) if row["id"] == sample_id)


@pytest.fixture(scope="module")
def small_checkpoint(tmp_path_factory):
    """An untrained 10-frame model of 16 px, without a stored data config."""
    path = tmp_path_factory.mktemp("rec") / "small.pt"
    save_checkpoint(path, build_e2v("tiny", seed=0, input_shape=(10, 16, 16)))
    return path


def _events(n: int, side: int = 16):
    k = np.arange(n)
    return make_events(k % side, (k // side) % side, 1000 + 5000 * k, np.ones(n))


def test_a_data_small_test_mesh_gives_its_stored_sample_and_the_models_answer():
    """The shipped tiny.pt on chair_0010 (a test sample) rebuilt from its mesh and seed: the
    frames and voxels are the committed sample's, bit for bit, and the probabilities are the
    model's on those frames (IoU 0.648 against the chair's voxels)."""
    row = _test_sample("chair_0010")
    assert row["split"] == "test"
    seed = int(row["seed"])
    result = reconstruct(TINY, mesh=make_shape("chair", seed), seed=seed, device="cpu")
    frames, voxels = load_sample(SMALL / "samples" / "chair_0010.npz")
    np.testing.assert_array_equal(result.frames, frames)
    np.testing.assert_array_equal(result.voxels, voxels)
    expected = predict(load_checkpoint(TINY), torch.from_numpy(frames)[None], "cpu")[0].numpy()
    np.testing.assert_array_equal(result.probabilities, expected)
    assert result.probabilities.shape == (32, 32, 32)
    assert result.probabilities.dtype == np.float32
    assert result.iou() == pytest.approx(iou(expected, voxels)) == pytest.approx(0.648, abs=0.005)
    assert list(result.arrays()) == ["voxels", "probabilities", "frames"]


def test_events_from_a_file_or_an_array_give_the_same_answer():
    path = SMALL / "events" / "chair_0010.npz"
    from_file = reconstruct(TINY, events=path, device="cpu")
    events, sensor_size = load_events(path)
    from_array = reconstruct(read_checkpoint(TINY), events=events, sensor_size=sensor_size,
                             device="cpu")
    frames = recording_input(events, sensor_size, 64, n_frames=100, dt_us=5000)
    for result in (from_file, from_array):
        np.testing.assert_array_equal(result.frames, frames)
        assert result.voxels is None and result.iou() is None
        assert list(result.arrays()) == ["probabilities", "frames"]
    np.testing.assert_array_equal(from_file.probabilities, from_array.probabilities)
    # windows start at the first event (392 us), the dataset's at 0: nearly the same frames
    stored, _ = load_sample(SMALL / "samples" / "chair_0010.npz")
    assert (frames == stored).mean() > 0.99


def test_checkpoint_build_config_follows_the_checkpoints_data_config():
    config = checkpoint_build_config(read_checkpoint(TINY), load_checkpoint(TINY))
    assert (config.resolution, config.frame_size, config.oversample, config.n_frames,
            config.dt_us, config.windows) == (128, 64, 3, 100, 5000, "fixed")
    assert config.per_category == 1


def test_bad_input_is_named(small_checkpoint, tmp_path):
    with pytest.raises(ValueError, match="give a mesh"):
        reconstruct(small_checkpoint)
    with pytest.raises(ValueError, match="not both"):
        reconstruct(small_checkpoint, mesh="a.stl", events="b.npz")
    with pytest.raises(ValueError, match="needs its sensor_size"):
        reconstruct(small_checkpoint, events=_events(20))
    with pytest.raises(InputError, match=r"^events given: 3 event\(s\) cannot make the "
                                         r"model's input: its 10 frames of 5000 us"):
        reconstruct(small_checkpoint, events=_events(3), sensor_size=(16, 16))
    path = tmp_path / "few.npz"
    save_events(path, _events(3), (16, 16))
    with pytest.raises(InputError) as caught:
        reconstruct(small_checkpoint, events=path)
    assert caught.value.source == str(path) and "3 event(s)" in caught.value.reason
    with pytest.raises(InputError, match="smaller than frame_size 16"):
        reconstruct(small_checkpoint, events=_events(20, side=8), sensor_size=(8, 8))
    bad = save_checkpoint(tmp_path / "bad.pt", load_checkpoint(small_checkpoint),
                          data_config={"n_frames": 20, "frame_size": 16})
    with pytest.raises(ValueError, match=f"checkpoint {bad} is inconsistent: its model takes "
                                         "10 frames of 16 px"):
        reconstruct(bad, events=_events(20), sensor_size=(16, 16))


def test_nan_out_of_the_model_is_refused(small_checkpoint, monkeypatch):
    import e2vlib.train

    monkeypatch.setattr(e2vlib.train, "predict",
                        lambda model, frames, device: torch.full((1, 32, 32, 32), math.nan))
    with pytest.raises(FloatingPointError, match=f"NaN/inf .* check checkpoint "
                                                 f"{small_checkpoint}"):
        reconstruct(small_checkpoint, events=_events(20), sensor_size=(16, 16))


def test_reconstruction_counts_and_scores():
    p = np.zeros((32, 32, 32), np.float32)
    p[:2] = 0.9
    truth = np.zeros((32, 32, 32), bool)
    truth[:4] = True
    result = Reconstruction(p, np.zeros((10, 16, 16), np.uint8), truth)
    assert (result.occupied(), result.occupied(0.95), result.iou()) == (2048, 0, 0.5)
