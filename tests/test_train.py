import json
import os

import numpy as np
import pytest
import torch

from e2vlib.model import build_e2v, load_checkpoint
from e2vlib.train import (
    RECIPES,
    TensorSet,
    evaluate,
    fit,
    format_table,
    resolve_device,
    score_predictions,
)

SHAPE = (8, 16, 16)


def small_model(seed=0):
    return build_e2v("tiny", seed=seed, input_shape=SHAPE, decoder_widths=(8, 16),
                     bottleneck_features=32)


def toy_set(n=24, seed=0) -> TensorSet:
    """A learnable toy task: dense frames -> a big cube, sparse frames -> a small cube."""
    rng = np.random.default_rng(seed)
    big = rng.random(n) < 0.5
    frames = np.stack([(rng.random(SHAPE) < (0.6 if b else 0.05)) for b in big]).astype(np.uint8)
    voxels = np.zeros((n, 32, 32, 32), dtype=bool)
    voxels[big, 4:28, 4:28, 4:28] = True
    voxels[~big, 12:20, 12:20, 12:20] = True
    cats = ["table" if b else "chair" for b in big]
    return TensorSet(torch.from_numpy(frames), torch.from_numpy(voxels), cats,
                     [f"s{i}" for i in range(n)])


def test_paper_recipe_matches_the_paper():
    paper = RECIPES["paper"]
    assert (paper.lr, paper.batch_size, paper.epochs) == (1e-5, 5, 100)


def test_fit_learns_a_toy_task_and_writes_files(tmp_path):
    history = fit(small_model(), toy_set(), toy_set(8, seed=1), tmp_path, epochs=4,
                  lr=1e-2, batch_size=8, progress=False)
    assert [h["epoch"] for h in history] == list(range(1, 5))
    assert history[-1]["train_loss"] < 0.5 * history[0]["train_loss"]
    assert history[-1]["val_iou"] > history[0]["val_iou"] + 0.15
    assert json.loads((tmp_path / "history.json").read_text()) == history
    best = max(history, key=lambda h: h["val_iou"])
    assert torch.load(tmp_path / "best.pt", weights_only=True)["epoch"] == best["epoch"] - 1
    model = load_checkpoint(tmp_path / "last.pt")
    assert model.input_shape == SHAPE


def test_resume_is_exact(tmp_path):
    kwargs = dict(lr=5e-3, batch_size=8, progress=False, seed=3)
    straight = small_model()
    fit(straight, toy_set(), toy_set(8, 1), tmp_path / "a", epochs=2, **kwargs)
    first = small_model()
    fit(first, toy_set(), toy_set(8, 1), tmp_path / "b", epochs=1, **kwargs)
    resumed = small_model(seed=99)  # different init: everything must come from last.pt
    history = fit(resumed, toy_set(), toy_set(8, 1), tmp_path / "b", epochs=2, resume=True,
                  **kwargs)
    assert len(history) == 2
    for (name, a), b in zip(straight.state_dict().items(), resumed.state_dict().values(),
                            strict=True):
        assert torch.equal(a, b), name


def test_fit_rejects_mismatched_data_and_missing_cuda(tmp_path):
    with pytest.raises(ValueError, match="input_shape"):
        fit(build_e2v("tiny"), toy_set(), toy_set(4), tmp_path, epochs=1, progress=False)
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="cuda"):
            resolve_device("cuda")
    assert resolve_device("cpu") == torch.device("cpu")


def test_score_predictions_and_summary_by_hand():
    gt = torch.zeros(3, 32, 32, 32)
    gt[:, 8:16, 8:16, 8:16] = 1
    pred = gt.clone()
    pred[2] = 0  # an empty prediction for the third sample
    scores = score_predictions(pred, gt, fscore_points=512)
    np.testing.assert_allclose(scores["iou@0.3"], [1, 1, 0])
    np.testing.assert_allclose(scores["fscore@1%"], [1, 1, 0])


def test_evaluate_reports_protocol_and_baselines():
    data = toy_set(12, seed=5)
    result = evaluate(small_model(), data, train_data=toy_set(24), fscore_points=256,
                      progress=False)
    keys = {"iou@0.2", "iou@0.3", "iou@0.4", "iou@0.5", "fscore@1%", "fscore@20%"}
    assert set(result["overall"]) == keys
    assert set(result["per_category"]) == {"table", "chair"}
    assert sum(c["n"] for c in result["per_category"].values()) == 12
    per_sample = result["per_sample"]
    assert result["overall"]["iou@0.3"] == pytest.approx(
        np.mean([s["iou@0.3"] for s in per_sample]))
    chairs = [s["iou@0.3"] for s in per_sample if s["category"] == "chair"]
    assert result["per_category"]["chair"]["iou@0.3"] == pytest.approx(np.mean(chairs))
    # the category-mean oracle knows each toy category's single shape exactly
    assert result["baseline_category_mean"]["iou@0.3"] == pytest.approx(1.0)
    assert result["baseline_mean_shape"]["iou@0.5"] < 1.0
    assert "overall" in format_table(result) and "chair" in format_table(result)


def _ddp_worker(rank, world, init_file, out_dir):
    import torch.distributed as dist

    dist.init_process_group("gloo", init_method=f"file://{init_file}", rank=rank,
                            world_size=world)
    torch.set_num_threads(1)
    model = small_model()
    fit(model, toy_set(), toy_set(8, 1), out_dir, epochs=1, lr=1e-2, batch_size=8,
        progress=False)
    torch.save(model.state_dict(), os.path.join(out_dir, f"rank{rank}.pt"))
    dist.destroy_process_group()


def test_data_parallel_replicas_stay_equal(tmp_path):
    torch.multiprocessing.spawn(_ddp_worker, args=(2, str(tmp_path / "init"), str(tmp_path)),
                                nprocs=2, join=True)
    a = torch.load(tmp_path / "rank0.pt", weights_only=True)
    b = torch.load(tmp_path / "rank1.pt", weights_only=True)
    start = small_model().state_dict()
    changed = False
    for name in a:
        assert torch.equal(a[name], b[name]), f"replicas differ in {name}"
        changed |= not torch.equal(a[name], start[name])
    assert changed, "training did not change the weights"
    assert (tmp_path / "last.pt").exists()  # written by rank 0 only, no clash
