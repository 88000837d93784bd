"""The geometry study: one record per test object, every method scored alike, resumable."""

import json

import numpy as np
import pytest

from e2vlib.data import BuildConfig, E2VDataset, build_dataset
from e2vlib.experiments.geometry_study import METHODS, run_geometry_study, summarize_geometry
from e2vlib.model import build_e2v, save_checkpoint


@pytest.fixture(scope="module")
def tiny_data(tmp_path_factory):
    """2 categories x 10 objects at 32 px, raw events of every sample, an untrained model."""
    root = tmp_path_factory.mktemp("geometry_data")
    config = BuildConfig(categories=("car", "sofa"), per_category=10, resolution=32,
                         frame_size=16, oversample=2, raw_events_per_category=10)
    build_dataset(root, config, progress=False)
    model = build_e2v("tiny", seed=0, input_shape=(100, 16, 16))
    save_checkpoint(root / "checkpoints" / "first_recipe.pt", model)
    return root


def test_every_test_object_gets_every_method_and_a_rerun_resumes(tiny_data, tmp_path):
    path = run_geometry_study(tmp_path, data=tiny_data, events=tiny_data, n_points=256,
                              progress=False)
    results = json.loads(path.read_text())
    test_ids = E2VDataset(tiny_data, "test").ids
    assert sorted(r["id"] for r in results["runs"]) == sorted(test_ids)
    for run in results["runs"]:
        assert set(run["scores"]) == set(METHODS)
        for scores in run["scores"].values():
            assert {"iou@0.3", "fscore@1%"} <= set(scores)
            assert 0.0 <= scores["iou@0.3"] <= 1.0
        # a hull of exact silhouettes contains the object: it is far better than nothing
        assert run["scores"]["visual_hull"]["iou@0.3"] > 0.3
    before = path.read_text()
    run_geometry_study(tmp_path, data=tiny_data, events=tiny_data, n_points=256,
                       progress=False)
    assert json.loads(path.read_text())["runs"] == json.loads(before)["runs"]
    rows = summarize_geometry(path)
    assert [r["method"] for r in rows] == list(METHODS)
    hull = [r["scores"]["visual_hull"]["iou@0.3"] for r in results["runs"]]
    assert rows[0]["n"] == len(hull) and rows[0]["mean"] == pytest.approx(np.mean(hull))


def test_another_protocol_and_missing_events_are_refused(tiny_data, tmp_path):
    (tmp_path / "geometry.json").write_text(json.dumps(
        {"study": "geometry", "protocol": {"n_points": 1}, "runs": []}))
    with pytest.raises(ValueError, match="another protocol"):
        run_geometry_study(tmp_path, data=tiny_data, events=tiny_data, progress=False)
    with pytest.raises(FileNotFoundError, match="events cache must hold the raw events"):
        run_geometry_study(tmp_path / "other", data=tiny_data, events=tmp_path / "none",
                           progress=False)


def test_added_checkpoints_score_like_learned_and_keep_the_carving(tiny_data, tmp_path):
    """A second name for the same weights scores exactly what ``learned`` scored; the oracle
    of a category is its mean training label; carving is not redone; clashes are refused."""
    import shutil

    from e2vlib.experiments.geometry_study import add_checkpoints
    from e2vlib.geometry import score_occupancy
    from e2vlib.inputs import preload
    from e2vlib.train import category_mean_shapes

    path = run_geometry_study(tmp_path, data=tiny_data, events=tiny_data, n_points=256,
                              progress=False)
    runs = json.loads(path.read_text())["runs"]
    hull_before = {r["id"]: r["scores"]["visual_hull"] for r in runs}
    same = tmp_path / "same.pt"
    shutil.copyfile(tiny_data / "checkpoints" / "first_recipe.pt", same)
    add_checkpoints(path, {"again": str(same)}, data=tiny_data, n_points=256)
    results = json.loads(path.read_text())
    oracle = category_mean_shapes(preload(E2VDataset(tiny_data, "train"), progress=False))
    test = E2VDataset(tiny_data, "test")
    for run in results["runs"]:
        scores = run["scores"]
        assert scores["again"]["iou@0.3"] == scores["learned"]["iou@0.3"]
        assert scores["visual_hull"] == hull_before[run["id"]]
        label = test[test.ids.index(run["id"])]["voxels"].numpy().astype(bool)
        expected = score_occupancy(oracle[run["category"]].numpy(), label, 256)["iou@0.3"]
        assert scores["category_oracle"]["iou@0.3"] == pytest.approx(expected)
    assert results["checkpoints"]["again"]["path"] == str(same)
    assert len(results["checkpoints"]["again"]["weights_sha256"]) == 64
    rows = summarize_geometry(path)
    assert [r["method"] for r in rows] == [*METHODS, "again", "category_oracle"]
    with pytest.raises(ValueError, match="already scores a checkpoint named 'again'"):
        add_checkpoints(path, {"again": str(tmp_path / "other.pt")}, data=tiny_data)
    with pytest.raises(ValueError, match="method names"):
        add_checkpoints(path, {"visual_hull": str(same)}, data=tiny_data)
