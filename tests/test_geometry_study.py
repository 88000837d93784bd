"""The geometry study: one record per test object, every method scored alike, resumable."""

import json

import numpy as np
import pytest

from e2vlib.data import BuildConfig, E2VDataset, build_dataset
from e2vlib.geometry_study import METHODS, run_geometry_study, summarize_geometry
from e2vlib.model import build_e2v, save_checkpoint


@pytest.fixture(scope="module")
def tiny_data(tmp_path_factory):
    """2 categories x 10 objects at 32 px, raw events of every sample, an untrained model."""
    root = tmp_path_factory.mktemp("geometry_data")
    config = BuildConfig(categories=("car", "sofa"), per_category=10, resolution=32,
                         frame_size=16, oversample=2, raw_events_per_category=10)
    build_dataset(root, config, progress=False)
    model = build_e2v("tiny", seed=0, input_shape=(100, 16, 16))
    save_checkpoint(root / "checkpoints" / "tiny.pt", model)
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
