"""Predictions and the Pix2Vox evaluation protocol: :func:`predict`, :func:`evaluate`, and the
mean-shape baselines (:func:`category_mean_shapes`). The scores themselves are
:mod:`e2vlib.metrics`' (:func:`~e2vlib.metrics.score_split`).
"""

from __future__ import annotations

import numpy as np
import torch

from e2vlib.inputs.tensors import TensorSet, preload
from e2vlib.metrics import iou, score_split
from e2vlib.model import E2V
from e2vlib.paper import GRID_SIDE, IOU_THRESHOLD
from e2vlib.train.devices import model_device, resolve_device
from e2vlib.train.recipes import is_whole_number

VAL_BATCH = 16
"""Samples per forward pass when validating and predicting (no gradients: memory is small)."""


@torch.no_grad()
def predict(model: E2V, frames: torch.Tensor, device: str = "auto",
            batch_size: int = VAL_BATCH) -> torch.Tensor:
    """Occupancy probabilities for a stack of samples' frames.

    Parameters
    ----------
    model
        An :class:`~e2vlib.model.E2V`. It is run in eval mode on ``device`` and left as it
        was found: on its own device, in its own train/eval mode.
    frames
        ``(N, n_frames, H, W)`` (or ``(N, C, n_frames, H, W)`` for a model with
        ``in_channels=C``), any dtype (converted to float32 batch by batch).
    device
        Where to compute (:func:`resolve_device`; ``"auto"``: CUDA if available).
    batch_size
        Samples per forward pass (>= 1).

    Returns
    -------
    torch.Tensor
        ``(N, 32, 32, 32)`` float32 on the CPU, ``sigmoid(logits)``.

    Examples
    --------
    >>> from e2vlib.model import build_e2v
    >>> model = build_e2v("tiny", seed=0, input_shape=(8, 16, 16))
    >>> p = predict(model, torch.zeros(3, 8, 16, 16), device="cpu")
    >>> p.shape, p.dtype, bool(((p >= 0) & (p <= 1)).all())
    (torch.Size([3, 32, 32, 32]), torch.float32, True)
    """
    if not is_whole_number(batch_size) or batch_size < 1:
        raise ValueError(f"batch_size must be a whole number >= 1, got {batch_size!r}")
    frames = torch.as_tensor(frames)
    device = resolve_device(device)
    home, was_training = model_device(model), model.training
    out = []
    try:
        model.to(device).eval()
        for i in range(0, len(frames), batch_size):
            x = frames[i:i + batch_size].to(device, torch.float32)
            out.append(torch.sigmoid(model(x)).float().cpu())
    finally:
        model.train(was_training)
        if home is not None:
            model.to(home)
    return torch.cat(out) if out else torch.zeros(0, GRID_SIDE, GRID_SIDE, GRID_SIDE)


@torch.no_grad()
def validation_scores(model: E2V, data: TensorSet, device: torch.device, loss_fn) -> dict:
    """``{"loss": mean loss per sample, "iou": mean IoU at IOU_THRESHOLD}`` of ``model`` on
    ``data`` (in eval mode, batches of :data:`VAL_BATCH`; the mode is restored), as
    :func:`~e2vlib.train.fit` measures it after every epoch. ``model`` must be on ``device``.

    Examples
    --------
    >>> from e2vlib.losses import make_loss
    >>> from e2vlib.model import build_e2v
    >>> from e2vlib.train import init_output_prior
    >>> voxels = torch.zeros(2, 32, 32, 32, dtype=torch.bool); voxels[:, :16] = True
    >>> data = TensorSet(torch.zeros(2, 8, 16, 16, dtype=torch.uint8), voxels,
    ...                  ["chair", "lamp"], ["c0", "l0"])
    >>> model = build_e2v("tiny", seed=0, input_shape=(8, 16, 16))
    >>> init_output_prior(model, 0.5)   # p is about 0.5 everywhere: all occupied at 0.3
    >>> scores = validation_scores(model, data, torch.device("cpu"), make_loss("bce"))
    >>> round(scores["loss"], 2), scores["iou"]   # log 2 and half the grid
    (0.69, 0.5)
    """
    was_training = model.training
    model.eval()
    losses, ious = [], []
    for i in range(0, len(data), VAL_BATCH):
        x = data.frames[i:i + VAL_BATCH].to(device, torch.float32)
        y = data.voxels[i:i + VAL_BATCH].to(device, torch.float32)
        logits = model(x)
        losses.append(loss_fn(logits, y).item() * len(x))
        ious.append(iou(torch.sigmoid(logits), y, threshold=IOU_THRESHOLD))
    model.train(was_training)
    return {"loss": float(np.sum(losses) / len(data)),
            "iou": float(np.mean(np.concatenate(ious)))}


def evaluate(
    model: E2V,
    data,
    train_data=None,
    device: str = "auto",
    fscore_points: int = 8192,
    progress: bool = True,
) -> dict:
    """Evaluate ``model`` on ``data`` with the Pix2Vox protocol; return a JSON-ready dict.

    ``{"overall": {metric: mean over samples}, "per_category": {category: {metric: mean
    over its samples, "n": count}}, "per_sample": [...], "baseline_mean_shape": {...},
    "baseline_category_mean": {...}}`` with metrics ``iou@0.2 .. iou@0.5``,
    ``fscore@1%`` and ``fscore@20%``. The baselines (needing ``train_data``) predict the
    training set's mean voxel grid, and per category the category's mean (an oracle that
    knows the category). Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> from e2vlib.model import build_e2v
    >>> from e2vlib.train import init_output_prior
    >>> voxels = torch.zeros(2, 32, 32, 32, dtype=torch.bool); voxels[:, :16] = True
    >>> data = TensorSet(torch.zeros(2, 8, 16, 16, dtype=torch.uint8), voxels,
    ...                  ["chair", "lamp"], ["c0", "l0"])
    >>> model = build_e2v("tiny", seed=0, input_shape=(8, 16, 16))
    >>> init_output_prior(model, 0.5)   # p is about 0.5 everywhere: all occupied at 0.3
    >>> result = evaluate(model, data, device="cpu", fscore_points=512, progress=False)
    >>> result["overall"]["iou@0.3"], sorted(result["per_category"])   # half the grid is right
    (0.5, ['chair', 'lamp'])
    """
    test = preload(data, progress=progress)
    probabilities = predict(model, test.frames, device)
    scored = score_split(probabilities, test.voxels, test.categories, fscore_points)
    scores = scored["scores"]
    result = {
        "overall": scored["overall"],
        "per_category": scored["per_category"],
        "per_sample": [
            {"id": sid, "category": cat, **{k: float(v[i]) for k, v in scores.items()}}
            for i, (sid, cat) in enumerate(zip(test.ids, test.categories, strict=True))
        ],
    }
    if train_data is not None:
        train = preload(train_data)
        mean_shape = train.voxels.float().mean(0)
        result["baseline_mean_shape"] = score_split(
            mean_shape.expand(len(test), -1, -1, -1), test.voxels, test.categories,
            fscore_points)["overall"]
        oracle = category_mean_shapes(train)
        guess = torch.stack([oracle.get(c, mean_shape) for c in test.categories])
        result["baseline_category_mean"] = score_split(
            guess, test.voxels, test.categories, fscore_points)["overall"]
    return result


def category_mean_shapes(data: TensorSet) -> dict[str, torch.Tensor]:
    """Mean voxel grid (occupancy frequency, ``(32, 32, 32)``) of each category.

    Examples
    --------
    >>> voxels = torch.zeros(3, 32, 32, 32, dtype=torch.bool); voxels[0] = voxels[2] = True
    >>> data = TensorSet(torch.zeros(3, 4, 8, 8, dtype=torch.uint8), voxels,
    ...                  ["chair", "chair", "lamp"], ["c0", "c1", "l0"])
    >>> means = category_mean_shapes(data)
    >>> float(means["chair"].mean()), float(means["lamp"].mean()), tuple(means["chair"].shape)
    (0.5, 1.0, (32, 32, 32))
    """
    cats = np.asarray(data.categories)
    return {c: data.voxels[torch.from_numpy(cats == c)].float().mean(0)
            for c in dict.fromkeys(data.categories)}


