"""The dataset explorer's plain functions, on a small hand-made dataset."""

import json
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402

from e2vlib.data import E2VDataset, save_sample  # noqa: E402
from e2vlib.events import make_events  # noqa: E402
from e2vlib.experiments import explore  # noqa: E402
from e2vlib.frames import accumulate  # noqa: E402
from e2vlib.io import save_events  # noqa: E402

SENSOR = (16, 16)


def _dot_events() -> np.ndarray:
    """One event per ms for 0.5 s at row 5, moving one pixel right every 31.25 ms."""
    t = np.arange(0, 500_000, 1000)
    return make_events(x=t // 31_250, y=np.full(len(t), 5), t=t, p=np.where(t % 2000, 1, -1))


def _label(k: int) -> np.ndarray:
    grid = np.zeros((32, 32, 32), dtype=bool)
    grid[8:24, 8:24, 8:8 + 4 * (k + 1)] = True  # 256 * 4 (k + 1) voxels
    return grid


@pytest.fixture
def dataset(tmp_path):
    """Test split: car x 3 (car_0001 keeps raw events), lamp x 2; one train sample."""
    rows = [("car_0000", "car", "test"), ("car_0001", "car", "test"), ("car_0002", "car", "test"),
            ("lamp_0000", "lamp", "test"), ("lamp_0001", "lamp", "test"),
            ("lamp_0002", "lamp", "train")]
    rng = np.random.default_rng(0)
    (tmp_path / "samples").mkdir()
    lines = ["id,category,split,seed,n_events"]
    for k, (sample_id, category, split) in enumerate(rows):
        frames = (rng.random((100, 8, 8)) < 0.1).astype(np.uint8)
        save_sample(tmp_path / "samples" / f"{sample_id}.npz", frames, _label(k % 3), 500)
        lines.append(f"{sample_id},{category},{split},{k},500")
    (tmp_path / "manifest.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "config.json").write_text(json.dumps({"frame_size": 8, "resolution": 16}))
    save_events(tmp_path / "events" / "car_0001.npz", _dot_events(), SENSOR)
    return E2VDataset(tmp_path, "test")


def test_category_indices_and_raw_events(dataset):
    assert dataset.category_indices() == {"car": [0, 1, 2], "lamp": [3, 4]}
    found = [dataset.raw_events_path(i) for i in range(len(dataset))]
    assert [p is not None for p in found] == [False, True, False, False, False]
    assert found[1].name == "car_0001.npz"
    assert dataset.ids == ["car_0000", "car_0001", "car_0002", "lamp_0000", "lamp_0001"]
    assert [dataset[i]["id"] for i in range(len(dataset))] == dataset.ids
    with pytest.raises(IndexError, match="0..4"):
        dataset.raw_events_path(5)
    lamps = E2VDataset(dataset.root, "test", categories=["lamp"])
    assert lamps.ids == ["lamp_0000", "lamp_0001"] and lamps.category_indices() == {
        "lamp": [0, 1]}
    assert lamps.raw_events_path(0) is None


def test_view_with_raw_events_reaccumulates_at_dt(dataset):
    events = _dot_events()
    for dt_ms, n_expected in ((5.0, 100), (10.0, 50), (7.0, math.ceil(500 / 7)), (50.0, 10)):
        view = explore.explorer_view(dataset, None, "car", 1, dt_ms=dt_ms, figure=False)
        assert view["has_events"] and view["n_events"] == 500
        assert view["n_frames"] == n_expected and view["dt_ms"] == dt_ms
        all_frames = accumulate(events, SENSOR, dt_us=round(dt_ms * 1000), t0_us=0,
                                n_frames=n_expected)
        picks = np.linspace(0, n_expected - 1, 8).round().astype(int)
        assert np.array_equal(view["frames"], all_frames[picks])
        assert view["frames"].shape == (8, 16, 16)
    # by hand: the first 5 ms all fall on pixel (x=0, y=5); the first 50 ms on x = 0 and 1
    first_5 = explore.explorer_view(dataset, None, "car", 1, dt_ms=5, figure=False)["frames"][0]
    assert first_5.sum() == 1 and first_5[5, 0] == 1
    first_50 = explore.explorer_view(dataset, None, "car", 1, dt_ms=50, figure=False)["frames"][0]
    assert np.flatnonzero(first_50[5]).tolist() == [0, 1] and first_50.sum() == 2


def test_view_without_raw_events_shows_stored_frames(dataset):
    view = explore.explorer_view(dataset, None, "lamp", 1, dt_ms=20, figure=False)
    stored, label = dataset.arrays(4)
    assert not view["has_events"] and view["n_events"] is None
    assert view["dt_ms"] == 5.0 and view["n_frames"] == 100  # dt is ignored without events
    assert "no raw events" in view["message"]
    picks = np.linspace(0, 99, 8).round().astype(int)
    assert np.array_equal(view["frames"], stored[picks])
    assert view["id"] == "lamp_0001" and view["dataset_index"] == 4
    assert view["n_true"] == int(label.sum()) == 256 * 8


def test_iou_follows_the_threshold(dataset):
    label = dataset.arrays(0)[1]
    probs = np.where(label, np.float32(0.6), np.float32(0.1))
    probs[8:24, 8:24, 8] = 0.2  # one layer of 256 voxels weak: missed at 0.3, found at 0.15
    predictions = {0: probs}
    views = {t: explore.explorer_view(dataset, predictions, "car", 0, threshold=t, figure=False)
             for t in (0.05, 0.15, 0.3, 0.7)}
    n = int(label.sum())  # 1024
    assert views[0.15]["iou"] == 1.0 and views[0.15]["n_pred"] == n
    assert np.isclose(views[0.3]["iou"], (n - 256) / n) and views[0.3]["n_pred"] == n - 256
    assert views[0.7]["iou"] == 0.0 and views[0.7]["n_pred"] == 0
    assert np.isclose(views[0.05]["iou"], n / 32**3)  # everything predicted
    assert explore.explorer_view(dataset, None, "car", 0, figure=False)["iou"] is None


def test_bad_choices_are_named(dataset):
    with pytest.raises(ValueError, match="category 'sofa'"):
        explore.explorer_view(dataset, None, "sofa", 0)
    with pytest.raises(ValueError, match="lamp has 2 samples"):
        explore.explorer_view(dataset, None, "lamp", 2)
    with pytest.raises(ValueError, match="threshold"):
        explore.explorer_view(dataset, None, "lamp", 0, threshold=1.0)
    with pytest.raises(ValueError, match="dt_ms"):
        explore.explorer_view(dataset, None, "car", 1, dt_ms=0)


def test_figure_panels(dataset):
    label = dataset.arrays(1)[1]
    view = explore.explorer_view(dataset, {1: label * np.float32(0.9)}, "car", 1, threshold=0.3)
    titles = [ax.get_title() for ax in view["figure"].get_axes()]
    assert "500 events in space-time" in titles
    assert f"label: {int(label.sum())} voxels" in titles
    assert any("IoU 1.00" in t for t in titles)
    assert sum(t.endswith(" ms") for t in titles) == 8  # the frame strip
    no_model = explore.explorer_view(dataset, None, "lamp", 0)
    texts = [t.get_text() for ax in no_model["figure"].get_axes() for t in ax.texts]
    assert "no model given" in texts and any("no raw events" in t for t in texts)
    plt.close("all")


class _ConstantModel(torch.nn.Module):
    """Logits 0 everywhere (probability 0.5); counts its calls."""

    def __init__(self):
        super().__init__()
        self.calls = 0

    def forward(self, x):
        self.calls += 1
        return torch.zeros(len(x), 32, 32, 32)


def test_prediction_cache_runs_the_model_once_per_sample(dataset):
    model = _ConstantModel()
    cache = explore.PredictionCache(model, dataset)
    assert len(cache) == 5
    first = cache[2]
    again = cache[2]
    assert model.calls == 1 and first is again
    assert first.shape == (32, 32, 32) and first.dtype == np.float32 and np.all(first == 0.5)
    cache[3]
    assert model.calls == 2
    with pytest.raises(KeyError):
        cache[5]


def test_dataset_explorer_wires_the_widgets(dataset):
    widgets = pytest.importorskip("ipywidgets")
    box = explore.dataset_explorer(dataset, model=_ConstantModel())
    controls = [w for row in box.children[:2] for w in row.children]
    category = next(w for w in controls if isinstance(w, widgets.Dropdown))
    index = next(w for w in controls if isinstance(w, widgets.IntSlider))
    assert list(category.options) == ["car", "lamp"] and index.max == 2
    category.value = "lamp"
    assert index.max == 1 and index.value == 0
    assert isinstance(box.children[-1], widgets.Output)
    plt.close("all")


def test_dataset_explorer_draws_its_state_as_a_picture(dataset):
    """The picture that a notebook run without a widget frontend still shows."""
    pytest.importorskip("ipywidgets")
    box = explore.dataset_explorer(dataset)  # no model
    assert box.values == {"category": "car", "index": 0, "threshold": 0.3, "dt_ms": 5.0}
    assert box.text.startswith("car_0000: no raw events") and box.text.endswith("no model")
    assert box.png.startswith(b"\x89PNG")
    first = box.png
    box.controls["index"].value = 1  # car_0001 kept its 500 raw events
    assert box.text.startswith("car_0001: 500 raw events") and box.png != first
    box.controls["category"].value = "lamp"  # index goes back to 0 first: one redraw
    assert box.values["index"] == 0 and box.text.startswith("lamp_0000")
    assert plt.get_fignums() == []  # the figures drawn are closed
