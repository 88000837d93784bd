"""Training and evaluation of E2V: AdamW + binary cross entropy, as in the paper.

:func:`fit` trains with progress bars, keeps a per-epoch history, writes ``last.pt`` and
``best.pt`` (by validation IoU@0.3) atomically every epoch, resumes exactly from
``last.pt``, and runs data-parallel when launched with ``torchrun``.
:func:`evaluate` reports the Pix2Vox protocol: IoU at 0.2/0.3/0.4/0.5 and F-scores,
overall (mean over samples) and per category, with mean-shape baselines.

Introduced in notebooks/06_training.ipynb and notebooks/07_evaluation.ipynb.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch
import torch.distributed as dist
from torch import nn

from e2vlib.files import atomic_path
from e2vlib.metrics import IOU_THRESHOLDS, fscores, iou
from e2vlib.model import E2V, read_checkpoint, save_checkpoint

FSCORE_DISTANCES = {"fscore@1%": 0.01, "fscore@20%": 0.2}
METRIC_KEYS = tuple(f"iou@{t}" for t in IOU_THRESHOLDS) + tuple(FSCORE_DISTANCES)


@dataclass(frozen=True)
class Recipe:
    """Optimizer and schedule: AdamW(lr, weight_decay), ``epochs`` of ``batch_size``."""

    lr: float
    batch_size: int
    epochs: int
    weight_decay: float = 0.01
    cosine: bool = False  # cosine decay of lr to 5% over the epochs


RECIPES = {
    # The paper (Sec. IV): AdamW, learning rate 1e-5, batch size 5, 100 epochs.
    "paper": Recipe(lr=1e-5, batch_size=5, epochs=100),
    # Tuned for the tiny preset on data_small on a 2-core CPU (see bench/RESULTS.md).
    "tiny": Recipe(lr=2e-3, batch_size=16, epochs=30, weight_decay=1e-4, cosine=True),
}


def resolve_device(device: str | torch.device = "auto") -> torch.device:
    """``"auto"`` -> CUDA if available, else CPU; ``"cpu"``/``"cuda"``/``"cuda:1"`` as given.

    Asking for CUDA on a machine without it raises a ValueError saying so.
    """
    if str(device) == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    device = torch.device(device)
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError("device 'cuda' requested but torch.cuda.is_available() is False; "
                         "use --device cpu or install a CUDA build of torch (README: GPU)")
    return device


@dataclass
class TensorSet:
    """A dataset held in memory: frames uint8 ``(N, D, H, W)``, voxels bool ``(N, 32, 32, 32)``."""

    frames: torch.Tensor
    voxels: torch.Tensor
    categories: list[str]
    ids: list[str]

    def __len__(self) -> int:
        return len(self.ids)


def preload(dataset, progress: bool = False) -> TensorSet:
    """Load every item of an :class:`~e2vlib.data.E2VDataset` (or a :class:`TensorSet`) once.

    Frames stay uint8 (4x smaller than float); batches are converted on the fly.
    """
    if isinstance(dataset, TensorSet):
        return dataset
    from tqdm.auto import tqdm

    frames, voxels = [], []
    for index in tqdm(range(len(dataset)), desc="loading", disable=not progress, leave=False):
        f, v = dataset.arrays(index)
        frames.append(torch.from_numpy(np.ascontiguousarray(f, dtype=np.uint8)))
        voxels.append(torch.from_numpy(np.ascontiguousarray(v, dtype=bool)))
    return TensorSet(torch.stack(frames), torch.stack(voxels), list(dataset.categories),
                     [item[0] for item in dataset.items])


def _distributed() -> tuple[int, int]:
    """``(rank, world_size)``; ``(0, 1)`` when not running under torch.distributed."""
    if dist.is_available() and dist.is_initialized():
        return dist.get_rank(), dist.get_world_size()
    return 0, 1


def init_distributed_from_env() -> bool:
    """Join the process group that ``torchrun`` describes in the environment, if any.

    Uses NCCL when CUDA is available, else gloo (CPU). Returns True if distributed.
    """
    if int(os.environ.get("WORLD_SIZE", "1")) <= 1 or dist.is_initialized():
        return dist.is_initialized()
    backend = "nccl" if torch.cuda.is_available() else "gloo"
    dist.init_process_group(backend=backend)
    if backend == "nccl":
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", "0")))
    return True


def _epoch_order(n: int, seed: int, epoch: int) -> torch.Tensor:
    """The shuffled sample order of one epoch: a function of (seed, epoch) only."""
    return torch.randperm(n, generator=torch.Generator().manual_seed(seed * 100_003 + epoch))


def _lr_at(recipe: Recipe, epoch: int, epochs: int) -> float:
    if not recipe.cosine or epochs <= 1:
        return recipe.lr
    floor = 0.05 * recipe.lr
    return float(floor + 0.5 * (recipe.lr - floor) * (1 + np.cos(np.pi * epoch / (epochs - 1))))


def fit(
    model: E2V,
    train_data,
    val_data,
    out_dir: str | os.PathLike,
    recipe: str | Recipe = "tiny",
    epochs: int | None = None,
    device: str = "auto",
    seed: int = 0,
    resume: bool = False,
    progress: bool = True,
    on_epoch: Callable[[list[dict]], None] | None = None,
    metadata: dict | None = None,
    **recipe_overrides,
) -> list[dict]:
    """Train ``model`` with AdamW and binary cross entropy on logits; return the history.

    ``train_data``/``val_data``: :class:`~e2vlib.data.E2VDataset` or :class:`TensorSet`.
    ``recipe``: ``"tiny"``, ``"paper"`` or a :class:`Recipe`; ``epochs`` and
    ``recipe_overrides`` (``lr=``, ``batch_size=``, ...) change it. Every epoch writes
    ``out_dir/last.pt`` (model, optimizer, epoch, RNG state, history) and, when the
    validation IoU@0.3 improves, ``out_dir/best.pt``; ``out_dir/history.json`` holds
    the history. ``resume=True`` continues exactly from ``last.pt``. Under ``torchrun``
    the model is wrapped in DistributedDataParallel and each process trains on its share
    of every batch's samples; only rank 0 writes files. ``on_epoch(history)`` is called
    after each epoch (live plots). ``metadata`` (plain dict, e.g. the dataset's build
    settings) is stored in the checkpoints. Introduced in notebooks/06_training.ipynb.
    """
    from tqdm.auto import tqdm

    recipe = RECIPES[recipe] if isinstance(recipe, str) else recipe
    recipe = replace(recipe, **recipe_overrides)
    if epochs is not None:
        recipe = replace(recipe, epochs=int(epochs))
    device = resolve_device(device)
    rank, world = _distributed()
    out_dir = Path(out_dir)
    if rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)
    train_set, val_set = preload(train_data), preload(val_data)
    if tuple(train_set.frames.shape[1:]) != tuple(model.input_shape):
        raise ValueError(f"the data's frames are {tuple(train_set.frames.shape[1:])} but the "
                         f"model expects {model.input_shape}; build the model with "
                         f"input_shape={tuple(train_set.frames.shape[1:])}")

    model.to(device)
    optimizer = torch.optim.AdamW(model.parameters(), lr=recipe.lr,
                                  weight_decay=recipe.weight_decay)
    history: list[dict] = []
    start_epoch, best_iou = 0, -1.0
    if resume:
        state = read_checkpoint(out_dir / "last.pt", map_location=device)
        model.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        start_epoch, best_iou = int(state["epoch"]) + 1, float(state["best_iou"])
        history = [dict(h) for h in state["history"]]
        torch.set_rng_state(state["torch_rng"].cpu())
    net = model
    if world > 1:
        net = nn.parallel.DistributedDataParallel(
            model, device_ids=[device.index] if device.type == "cuda" else None)

    loss_fn = nn.BCEWithLogitsLoss()
    for epoch in range(start_epoch, recipe.epochs):
        for group in optimizer.param_groups:
            group["lr"] = _lr_at(recipe, epoch, recipe.epochs)
        started = time.perf_counter()
        net.train()
        order = _epoch_order(len(train_set), seed, epoch)
        batches = [order[i:i + recipe.batch_size]
                   for i in range(0, len(order), recipe.batch_size)]
        if len(batches) > 1 and len(batches[-1]) < 2:
            # BatchNorm cannot train on a single sample: fold a lone last one into the
            # batch before it.
            batches[-2:] = [torch.cat(batches[-2:])]
        losses = []
        bar = tqdm(batches, desc=f"epoch {epoch + 1}/{recipe.epochs}", leave=False,
                   disable=not progress or rank != 0)
        for batch in bar:
            mine = batch[rank::world]  # each process takes its share of the batch
            if len(mine) == 0:
                mine = batch[:1]  # keep every process stepping in lockstep
            x = train_set.frames[mine].to(device, torch.float32)
            y = train_set.voxels[mine].to(device, torch.float32)
            loss = loss_fn(net(x), y)
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            optimizer.step()
            losses.append(loss.item())
            bar.set_postfix(loss=f"{losses[-1]:.4f}")
        if world > 1:
            # DDP keeps parameters equal; buffers (BatchNorm running statistics) are only
            # copied from rank 0 at the start of each forward, so align them once more.
            for buffer in model.buffers():
                dist.broadcast(buffer, src=0)
        val = _validate(model, val_set, device, loss_fn)
        record = {"epoch": epoch + 1, "train_loss": float(np.mean(losses)),
                  "val_loss": val["loss"], "val_iou": val["iou"],
                  "lr": float(optimizer.param_groups[0]["lr"]),
                  "seconds": time.perf_counter() - started}
        history.append(record)
        improved = record["val_iou"] > best_iou
        best_iou = max(best_iou, record["val_iou"])
        if rank == 0:
            extra = {"optimizer": optimizer.state_dict(), "epoch": epoch,
                     "best_iou": best_iou, "history": history, "recipe": asdict(recipe),
                     "torch_rng": torch.get_rng_state(), "seed": seed,
                     "metadata": metadata or {}}
            save_checkpoint(out_dir / "last.pt", model, **extra)
            if improved:
                save_checkpoint(out_dir / "best.pt", model, **extra)
            with atomic_path(out_dir / "history.json") as tmp:
                tmp.write_text(json.dumps(history, indent=1) + "\n")
            if progress:
                tqdm.write(f"epoch {epoch + 1:3d}: train loss {record['train_loss']:.4f}, "
                           f"val loss {record['val_loss']:.4f}, val IoU@0.3 "
                           f"{record['val_iou']:.3f} ({record['seconds']:.0f} s)")
        if on_epoch is not None and rank == 0:
            on_epoch(history)
    return history


@torch.no_grad()
def predict(model: E2V, frames: torch.Tensor, device: str = "auto",
            batch_size: int = 16) -> torch.Tensor:
    """Occupancy probabilities ``(N, 32, 32, 32)`` (CPU float32) for frames ``(N, D, H, W)``."""
    device = resolve_device(device)
    model.to(device).eval()
    out = []
    for i in range(0, len(frames), batch_size):
        x = frames[i:i + batch_size].to(device, torch.float32)
        out.append(torch.sigmoid(model(x)).float().cpu())
    return torch.cat(out) if out else torch.zeros(0, 32, 32, 32)


@torch.no_grad()
def _validate(model: E2V, data: TensorSet, device: torch.device, loss_fn) -> dict:
    was_training = model.training
    model.eval()
    losses, ious = [], []
    for i in range(0, len(data), 16):
        x = data.frames[i:i + 16].to(device, torch.float32)
        y = data.voxels[i:i + 16].to(device, torch.float32)
        logits = model(x)
        losses.append(loss_fn(logits, y).item() * len(x))
        ious.append(iou(torch.sigmoid(logits), y, threshold=0.3))
    model.train(was_training)
    return {"loss": float(np.sum(losses) / len(data)),
            "iou": float(np.mean(np.concatenate(ious)))}


def score_predictions(probabilities: torch.Tensor, voxels: torch.Tensor,
                      fscore_points: int = 8192) -> dict[str, np.ndarray]:
    """Per-sample metrics: ``{"iou@0.2": (N,), ..., "fscore@1%": (N,), "fscore@20%": (N,)}``.

    F-scores use threshold 0.3 (Pix2Vox++'s choice) and ``fscore_points`` surface samples.
    """
    scores = {f"iou@{t}": np.atleast_1d(iou(probabilities, voxels, threshold=t))
              for t in IOU_THRESHOLDS}
    f = fscores(probabilities, voxels, threshold=0.3,
                distances=tuple(FSCORE_DISTANCES.values()), n_points=fscore_points)
    for column, key in enumerate(FSCORE_DISTANCES):
        scores[key] = np.atleast_2d(f)[:, column]
    return scores


def _summarize(scores: dict[str, np.ndarray], categories: Sequence[str]) -> tuple[dict, dict]:
    overall = {key: float(np.mean(values)) for key, values in scores.items()}
    per_category = {}
    cats = np.asarray(categories)
    for category in dict.fromkeys(categories):  # first-seen order
        sel = cats == category
        per_category[category] = {key: float(np.mean(v[sel])) for key, v in scores.items()}
        per_category[category]["n"] = int(sel.sum())
    return overall, per_category


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
    """
    test = preload(data, progress=progress)
    probabilities = predict(model, test.frames, device)
    scores = score_predictions(probabilities, test.voxels, fscore_points)
    overall, per_category = _summarize(scores, test.categories)
    result = {
        "overall": overall,
        "per_category": per_category,
        "per_sample": [
            {"id": sid, "category": cat, **{k: float(v[i]) for k, v in scores.items()}}
            for i, (sid, cat) in enumerate(zip(test.ids, test.categories, strict=True))
        ],
    }
    if train_data is not None:
        train = preload(train_data)
        mean_shape = train.voxels.float().mean(0)
        baseline = score_predictions(mean_shape.expand(len(test), -1, -1, -1), test.voxels,
                                     fscore_points)
        result["baseline_mean_shape"] = _summarize(baseline, test.categories)[0]
        oracle = category_mean_shapes(train)
        guess = torch.stack([oracle.get(c, mean_shape) for c in test.categories])
        result["baseline_category_mean"] = _summarize(
            score_predictions(guess, test.voxels, fscore_points), test.categories)[0]
    return result


def category_mean_shapes(data: TensorSet) -> dict[str, torch.Tensor]:
    """Mean voxel grid (occupancy frequency, ``(32, 32, 32)``) of each category."""
    cats = np.asarray(data.categories)
    return {c: data.voxels[torch.from_numpy(cats == c)].float().mean(0)
            for c in dict.fromkeys(data.categories)}


def format_table(result: dict, categories: Sequence[str] | None = None,
                 keys: Sequence[str] = METRIC_KEYS) -> str:
    """The per-category table in the layout of the paper's Tables I and II (text)."""
    from e2vlib.shapes import CATEGORIES

    categories = categories or [c for c in CATEGORIES if c in result["per_category"]]
    header = f"{'category':<12} {'n':>4} " + " ".join(f"{k:>10}" for k in keys)
    lines = [header, "-" * len(header)]
    for c in categories:
        row = result["per_category"][c]
        lines.append(f"{c:<12} {row['n']:>4} " + " ".join(f"{row[k]:>10.3f}" for k in keys))
    lines.append("-" * len(header))
    n = sum(result["per_category"][c]["n"] for c in categories)
    lines.append(f"{'overall':<12} {n:>4} "
                 + " ".join(f"{result['overall'][k]:>10.3f}" for k in keys))
    for name, label in (("baseline_mean_shape", "mean shape"),
                        ("baseline_category_mean", "cat. mean")):
        if name in result:
            lines.append(f"{label:<12} {'':>4} "
                         + " ".join(f"{result[name][k]:>10.3f}" for k in keys))
    return "\n".join(lines)
