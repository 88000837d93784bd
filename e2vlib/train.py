"""Training and evaluation of E2V: AdamW + binary cross entropy, as in the paper.

:func:`fit` trains (with the paper's BCE, or a focal or BCE + Dice loss from
:mod:`e2vlib.losses`) with progress bars, keeps a per-epoch history, writes ``last.pt`` and
``best.pt`` (by validation IoU at :data:`e2vlib.paper.IOU_THRESHOLD`) atomically every
epoch, stores the data config in both, resumes exactly from ``last.pt``, and runs
data-parallel when launched with ``torchrun``. :func:`lr_schedule` is its learning rate
per epoch. :func:`evaluate` reports the Pix2Vox protocol: IoU at
:data:`e2vlib.paper.IOU_THRESHOLDS` and F-scores, overall (mean over samples) and per
category, with mean-shape baselines. :class:`TensorSet` holds a split in memory and
indexes like a dataset (``data[3]`` is an item, ``data[idx]`` a smaller TensorSet); its
frames are ``(N, n_frames, H, W)``, or ``(N, C, n_frames, H, W)`` for inputs of ``C``
channels (a model built with ``in_channels=C``).

Introduced in notebooks/06_training.ipynb and notebooks/07_evaluation.ipynb.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.distributed as dist
from torch import nn

from e2vlib import paper
from e2vlib.files import atomic_path
from e2vlib.losses import LOSSES, make_loss
from e2vlib.metrics import fscores, iou
from e2vlib.metrics import summarize as summarize_scores
from e2vlib.model import (
    E2V,
    CheckpointError,
    E2VConfig,
    check_frames_match,
    checkpoint_data_config,
    read_checkpoint,
    save_checkpoint,
)
from e2vlib.paper import (
    CATEGORIES,
    FSCORE_DISTANCE,
    FSCORE_DISTANCE_REPORTED,
    GRID_SIDE,
    IOU_THRESHOLD,
    IOU_THRESHOLDS,
)

FSCORE_DISTANCES = {"fscore@1%": FSCORE_DISTANCE, "fscore@20%": FSCORE_DISTANCE_REPORTED}
METRIC_KEYS = tuple(f"iou@{t}" for t in IOU_THRESHOLDS) + tuple(FSCORE_DISTANCES)

COSINE_FLOOR = 0.05
"""Fraction of the learning rate the cosine schedule ends at (ours)."""

WARMUP_STEPS = 40
"""Linear warm-up steps of the ``tiny_step`` recipe (ours: about one epoch of data_small's
training split at batch size 16)."""

VAL_BATCH = 16
"""Samples per forward pass when validating and predicting (no gradients: memory is small)."""

LEGACY_LOSS = "bce"
"""The loss of checkpoints written before the loss was recorded: fit only had BCE then."""


@dataclass(frozen=True)
class Recipe:
    """Optimizer and schedule: AdamW(lr, weight_decay), ``epochs`` of ``batch_size``.

    ``cosine``: decay the learning rate from ``lr`` to ``COSINE_FLOOR * lr`` over the
    epochs (see :func:`lr_schedule`). ``per_step``: set the rate before every optimizer
    step instead of once per epoch, after ``warmup_steps`` steps of linear warm-up from
    ``lr / warmup_steps`` (see :func:`lr_at_step`). Values are checked: a ValueError names
    a bad one.
    """

    lr: float
    batch_size: int
    epochs: int
    weight_decay: float = 0.01
    cosine: bool = False
    per_step: bool = False
    warmup_steps: int = 0

    def __post_init__(self) -> None:
        problems = []
        if not _is_whole(self.batch_size) or self.batch_size < 1:
            problems.append(f"batch_size must be a whole number >= 1, got {self.batch_size!r}:"
                            " pass a positive batch size (batch_size=..., --batch-size)")
        if not _is_whole(self.epochs) or self.epochs < 1:
            problems.append(f"epochs must be a whole number >= 1, got {self.epochs!r}: train "
                            "for at least one epoch (epochs=..., --epochs)")
        if not _is_number(self.lr) or not self.lr > 0 or not math.isfinite(self.lr):
            problems.append(f"lr must be a finite number > 0, got {self.lr!r}: pass a "
                            "positive learning rate (lr=..., --lr)")
        if not _is_whole(self.warmup_steps) or self.warmup_steps < 0:
            problems.append(f"warmup_steps must be a whole number >= 0, got "
                            f"{self.warmup_steps!r}")
        elif self.warmup_steps and not self.per_step:
            problems.append("warmup_steps needs per_step=True (the warm-up is counted in "
                            "optimizer steps)")
        if not _is_number(self.weight_decay) or not 0 <= self.weight_decay < math.inf:
            problems.append(f"weight_decay must be a finite number >= 0, got "
                            f"{self.weight_decay!r}")
        if problems:
            raise ValueError("invalid training recipe: " + "; ".join(problems))
        for name, kind in (("batch_size", int), ("epochs", int), ("lr", float),
                           ("weight_decay", float), ("warmup_steps", int)):
            object.__setattr__(self, name, kind(getattr(self, name)))


def _is_number(value: object) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool)


def _is_whole(value: object) -> bool:
    return _is_number(value) and float(value) == int(value)


RECIPES = {
    # The paper (Sec. V): AdamW, learning rate 1e-5, batch size 5, 100 epochs.
    "paper": Recipe(lr=paper.LEARNING_RATE, batch_size=paper.BATCH_SIZE, epochs=paper.EPOCHS),
    # Tuned for the tiny preset on data_small on a 2-core CPU (see bench/RESULTS.md).
    "tiny": Recipe(lr=2e-3, batch_size=16, epochs=30, weight_decay=1e-4, cosine=True),
    # "tiny" with the rate set every step: a linear warm-up, then the cosine over every
    # step (the capstone study's recipe; experiments/results/stability.json measured it).
    "tiny_step": Recipe(lr=2e-3, batch_size=16, epochs=30, weight_decay=1e-4, cosine=True,
                        per_step=True, warmup_steps=WARMUP_STEPS),
}


def get_recipe(recipe: str | Recipe = "tiny", **overrides: Any) -> Recipe:
    """A :class:`Recipe` by name (``"tiny"``, ``"paper"``) or as given, with fields changed.

    Unknown names, unknown fields and bad values raise a ValueError that names them.

    Examples
    --------
    >>> get_recipe("paper", epochs=2)  # doctest: +NORMALIZE_WHITESPACE
    Recipe(lr=1e-05, batch_size=5, epochs=2, weight_decay=0.01, cosine=False, per_step=False,
           warmup_steps=0)
    """
    if isinstance(recipe, str):
        if recipe not in RECIPES:
            raise ValueError(f"unknown recipe {recipe!r}; choose one of {sorted(RECIPES)} "
                             "or pass a train.Recipe")
        recipe = RECIPES[recipe]
    elif not isinstance(recipe, Recipe):
        raise ValueError(f"recipe must be a name {sorted(RECIPES)} or a train.Recipe, got "
                         f"{type(recipe).__name__}")
    valid = {f.name for f in fields(Recipe)}
    unknown = sorted(set(overrides) - valid)
    if unknown:
        raise ValueError(f"unknown recipe fields {unknown}; valid fields: {sorted(valid)}")
    return replace(recipe, **overrides)


def lr_schedule(recipe: str | Recipe, epoch: int, epochs: int | None = None) -> float:
    """Learning rate of epoch ``epoch`` (0-based) in a run of ``epochs`` epochs.

    Constant ``recipe.lr`` unless ``recipe.cosine``; then a cosine decay from ``lr`` at
    the first epoch to ``lr_min = COSINE_FLOOR * lr`` at the last one,

    ``lr_e = lr_min + (lr - lr_min) / 2 * (1 + cos(pi * e / (E - 1)))``, e = 0 .. E - 1.

    ``epochs`` (E) defaults to ``recipe.epochs``; :func:`fit` passes the length of the run
    it was asked for, so a shorter run decays faster. Epochs outside ``0 .. E - 1`` raise
    a ValueError.

    Examples
    --------
    >>> tiny = RECIPES["tiny"]
    >>> lr_schedule(tiny, 0) == tiny.lr
    True
    >>> round(lr_schedule(tiny, tiny.epochs - 1) / tiny.lr, 6) == COSINE_FLOOR
    True
    >>> lr_schedule("paper", 50) == RECIPES["paper"].lr  # the paper's: constant
    True
    """
    recipe = get_recipe(recipe)
    epochs = recipe.epochs if epochs is None else int(epochs)
    if epochs < 1 or not 0 <= epoch < epochs:
        raise ValueError(f"epoch must be in 0 .. {epochs - 1} (0-based) for a run of {epochs} "
                         f"epochs, got epoch {epoch}")
    if not recipe.cosine or epochs <= 1:
        return recipe.lr
    floor = COSINE_FLOOR * recipe.lr
    return float(floor + 0.5 * (recipe.lr - floor) * (1 + np.cos(np.pi * epoch / (epochs - 1))))


def lr_at_step(recipe: str | Recipe, step: int, total_steps: int) -> float:
    """The learning rate of optimizer step ``step`` (0 .. ``total_steps`` - 1) of a
    ``per_step`` recipe.

    Warm-up ``W = recipe.warmup_steps``: ``lr * (s + 1) / W`` for s < W; then, with
    ``recipe.cosine``, the cosine of :func:`lr_schedule` over the remaining steps,
    ``lr_min + (lr - lr_min) / 2 * (1 + cos(pi * (s - W) / (T - W - 1)))``; else ``lr``.

    Examples
    --------
    >>> r = Recipe(lr=1.0, batch_size=4, epochs=1, cosine=True, per_step=True, warmup_steps=2)
    >>> [round(lr_at_step(r, s, 6), 3) for s in range(6)]
    [0.5, 1.0, 1.0, 0.762, 0.288, 0.05]
    """
    recipe = get_recipe(recipe)
    warmup = recipe.warmup_steps
    if step < warmup:
        return recipe.lr * (step + 1) / warmup
    decay_steps = total_steps - warmup
    if not recipe.cosine or decay_steps <= 1:
        return recipe.lr
    floor = COSINE_FLOOR * recipe.lr
    phase = min(step - warmup, decay_steps - 1) / (decay_steps - 1)
    return float(floor + 0.5 * (recipe.lr - floor) * (1 + np.cos(np.pi * phase)))


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
    """In memory: frames uint8 ``(N, n_frames, H, W)``, voxels bool ``(N, 32, 32, 32)``.

    Frames may also have a channel axis, ``(N, C, n_frames, H, W)`` (e.g. the polarity
    representation's OFF and ON counts, for a model with ``in_channels=C``), and any dtype
    (uint8 for binary frames, float16/float32 for counts or time surfaces): only the
    first (sample) axis is ever indexed, and batches become float32 on the fly.

    ``categories`` and ``ids`` hold one string per sample; ``config`` is the dataset's
    build settings (a dict, or None), which :func:`fit` stores in its checkpoints.
    Indexing works like a dataset: ``data[i]`` (an int) is the item dict
    ``{"frames": float32 (n_frames, H, W) (or (C, n_frames, H, W)), "voxels": float32
    (32, 32, 32), "category", "id"}`` of :class:`~e2vlib.data.E2VDataset`; a slice, a
    sequence of ints or a boolean mask gives a smaller TensorSet (:meth:`subset`).

    Examples
    --------
    >>> data = TensorSet(torch.zeros(4, 2, 8, 8, dtype=torch.uint8),
    ...                  torch.zeros(4, 32, 32, 32, dtype=torch.bool),
    ...                  ["chair", "chair", "lamp", "lamp"], ["c0", "c1", "l0", "l1"])
    >>> data[2]["id"], data[2]["frames"].dtype
    ('l0', torch.float32)
    >>> data[1:3].ids, data[[3, 0]].categories
    (['c1', 'l0'], ['lamp', 'chair'])
    """

    frames: torch.Tensor
    voxels: torch.Tensor
    categories: list[str]
    ids: list[str]
    config: dict | None = None

    def __post_init__(self) -> None:
        sizes = {"frames": len(self.frames), "voxels": len(self.voxels),
                 "categories": len(self.categories), "ids": len(self.ids)}
        if len(set(sizes.values())) != 1:
            raise ValueError(f"TensorSet parts must have one entry per sample, got {sizes}")

    def __len__(self) -> int:
        return len(self.ids)

    def __getitem__(self, key) -> dict | TensorSet:
        if _is_scalar_index(key):
            i = int(key)
            if not -len(self) <= i < len(self):
                raise IndexError(f"index {i} is out of range for a TensorSet of {len(self)} "
                                 "samples")
            i %= len(self)
            return {"frames": self.frames[i].float(), "voxels": self.voxels[i].float(),
                    "category": self.categories[i], "id": self.ids[i]}
        return self.subset(key)

    def subset(self, indices) -> TensorSet:
        """The samples at ``indices`` (a slice, ints, or a boolean mask), as a TensorSet.

        Order follows ``indices``; tensors are copied (advanced indexing), ``config`` is
        shared.
        """
        idx = self._positions(indices)
        rows = torch.from_numpy(idx)
        return TensorSet(self.frames[rows], self.voxels[rows],
                         [self.categories[i] for i in idx], [self.ids[i] for i in idx],
                         self.config)

    def _positions(self, indices) -> np.ndarray:
        n = len(self)
        if isinstance(indices, slice):
            return np.arange(n)[indices]
        if isinstance(indices, torch.Tensor):
            indices = indices.detach().cpu().numpy()
        arr = np.asarray(indices)
        if arr.size == 0:
            return np.zeros(0, dtype=np.int64)
        if arr.dtype == bool:
            if arr.shape != (n,):
                raise IndexError(f"a boolean mask must have one entry per sample ({n}), got "
                                 f"shape {arr.shape}")
            return np.flatnonzero(arr)
        if arr.ndim != 1 or not np.issubdtype(arr.dtype, np.integer):
            raise IndexError("index a TensorSet with an int, a slice, a 1-D sequence of ints "
                             f"or a boolean mask, got {type(indices).__name__} "
                             f"of dtype {arr.dtype} and shape {arr.shape}")
        if arr.min() < -n or arr.max() >= n:
            raise IndexError(f"indices must be in -{n} .. {n - 1} for a TensorSet of {n} "
                             f"samples, got {arr.min()} .. {arr.max()}")
        return arr.astype(np.int64) % n


def _is_scalar_index(key: object) -> bool:
    if isinstance(key, torch.Tensor):
        return key.ndim == 0 and not key.is_floating_point() and key.dtype != torch.bool
    return isinstance(key, int | np.integer) and not isinstance(key, bool | np.bool_)


def preload(dataset, progress: bool = False) -> TensorSet:
    """Load every item of an :class:`~e2vlib.data.E2VDataset` (or a :class:`TensorSet`) once.

    Frames stay uint8 (4x smaller than float); batches are converted on the fly. The
    dataset's ``config`` (its build settings, when it has them) goes along.
    """
    if isinstance(dataset, TensorSet):
        return dataset
    from tqdm.auto import tqdm

    frames, voxels = [], []
    for index in tqdm(range(len(dataset)), desc="loading", disable=not progress, leave=False):
        f, v = dataset.arrays(index)
        frames.append(torch.from_numpy(np.ascontiguousarray(f, dtype=np.uint8)))
        voxels.append(torch.from_numpy(np.ascontiguousarray(v, dtype=bool)))
    ids = getattr(dataset, "ids", None)
    if ids is None:
        ids = [item[0] for item in dataset.items]
    return TensorSet(torch.stack(frames), torch.stack(voxels), list(dataset.categories),
                     list(ids), _config_dict(getattr(dataset, "config", None)))


def _config_dict(config: object) -> dict | None:
    """A dataset's build settings as a dict (a dict, or an object with ``to_dict``)."""
    if hasattr(config, "to_dict"):
        config = config.to_dict()
    return dict(config) if isinstance(config, dict) else None


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


def _batches(n: int, batch_size: int, seed: int, epoch: int) -> list[torch.Tensor]:
    """The batches (sample indices) of one epoch; a lone last sample joins the batch before
    it, because BatchNorm cannot train on a single sample."""
    order = _epoch_order(n, seed, epoch)
    batches = [order[i:i + batch_size] for i in range(0, len(order), batch_size)]
    if len(batches) > 1 and len(batches[-1]) < 2:
        batches[-2:] = [torch.cat(batches[-2:])]
    return batches


def _model_device(model: nn.Module) -> torch.device | None:
    """Device of the model's first parameter (or buffer); None for a model without any."""
    for tensor in (*model.parameters(), *model.buffers()):
        return tensor.device
    return None


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
    on_step: Callable[[dict], None] | None = None,
    metadata: dict | None = None,
    data_config: dict | None = None,
    loss: str = "bce",
    precision: str = "fp32",
    channels_last: bool = False,
    **recipe_overrides,
) -> list[dict]:
    """Train ``model`` with AdamW and a loss on logits (the paper's BCE); return the history.

    Parameters
    ----------
    model
        The :class:`~e2vlib.model.E2V` to train (in place); its ``sample_shape`` must be
        the shape of the data's samples: ``input_shape`` = ``(n_frames, H, W)``, or
        ``(in_channels, n_frames, H, W)`` for a model of several input channels.
    train_data, val_data
        :class:`~e2vlib.data.E2VDataset` or :class:`TensorSet` (non-empty).
    out_dir
        Every epoch writes ``out_dir/last.pt`` (model, optimizer, epoch, RNG state,
        history) and, when the validation IoU (at :data:`e2vlib.paper.IOU_THRESHOLD`)
        improves, ``out_dir/best.pt``; ``out_dir/history.json`` holds the history.
    recipe, epochs, **recipe_overrides
        ``"tiny"``, ``"paper"`` or a :class:`Recipe`; ``epochs`` and ``recipe_overrides``
        (``lr=``, ``batch_size=``, ...) change it. ``batch_size < 1``, ``epochs < 1`` or
        ``lr <= 0`` raise a ValueError naming the value.
    device
        ``"auto"``, ``"cpu"``, ``"cuda"``, ... (:func:`resolve_device`).
    seed
        Seeds the sample order of every epoch and torch's global generator (dropout), so
        the same call trains the same weights on every run.
    resume
        Continue exactly from ``out_dir/last.pt`` (weights, optimizer, RNG state). The
        checkpoint must hold the same model config and, when both are known, data made
        with the same frame settings (:func:`~e2vlib.model.check_frames_match`).
    on_epoch
        Called with the history after each epoch (live plots).
    on_step
        Called after every optimizer step with ``{"epoch", "step", "loss", "lr"}`` (epoch
        from 1, step counted over the whole run from 0); the gradients of that step are
        still on the model's parameters (diagnostics, per-step plots).
    metadata
        A plain dict stored in the checkpoints under ``"metadata"``.
    data_config
        The build settings of the training data (``BuildConfig.to_dict()``), stored in
        every checkpoint as ``"data_config"``; defaults to ``train_data.config`` when that
        is a dict.
    loss
        The training loss, one of :data:`e2vlib.losses.LOSSES`: ``"bce"`` (mean binary
        cross-entropy, the paper's), ``"focal"`` or ``"bce_dice"``. Validation reports the
        same loss as ``val_loss``; ``best.pt`` is still picked by validation IoU. The name
        is stored in the checkpoints under ``"loss"``, and resuming with another loss is
        refused.
    precision
        ``"fp32"`` (default) or ``"bf16"``: the training forward pass under
        ``torch.autocast`` in bfloat16 (the loss, the optimizer and validation stay in
        float32). Fast on CPUs with AVX-512 BF16 or AMX and on recent GPUs
        (:func:`bf16_is_fast`); elsewhere it is refused with a ValueError. Every step's
        gradients are checked: a NaN/inf one raises FloatingPointError naming the
        parameter (oneDNN's bfloat16 kernels give them for a convolution whose input is
        one voxel along every axis; then train in fp32 or on larger frames).
    channels_last
        Store the convolution weights channels-last (``torch.channels_last_3d`` for 3D,
        ``torch.channels_last`` for 2D kernels), which oneDNN runs faster on CPU. The
        weights are the same numbers; only float rounding in the convolutions differs.
        See bench/RESULTS.md ("Faster CPU training") for what each option gains.

    Under ``torchrun`` the model is wrapped in DistributedDataParallel and each process
    trains on its share of every batch's samples; only rank 0 writes files.
    Introduced in notebooks/06_training.ipynb.
    """
    from tqdm.auto import tqdm

    if epochs is not None:
        recipe_overrides = {**recipe_overrides, "epochs": epochs}
    recipe = get_recipe(recipe, **recipe_overrides)
    if not isinstance(loss, str) or loss not in LOSSES:
        raise ValueError(f"unknown loss {loss!r}; choose one of {', '.join(LOSSES)} "
                         "(e2vlib.losses.LOSSES)")
    loss_fn = make_loss(loss)
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {', '.join(PRECISIONS)}, got {precision!r}")
    if not _is_whole(seed):
        raise ValueError(f"seed must be a whole number, got {seed!r}")
    seed = int(seed)
    device = resolve_device(device)
    rank, world = _distributed()
    out_dir = Path(out_dir)
    train_set, val_set = preload(train_data), preload(val_data)
    for name, data in (("train_data", train_set), ("val_data", val_set)):
        if len(data) == 0:
            raise ValueError(f"{name} is empty; give fit at least one sample")
    for name, data in (("train_data", train_set), ("val_data", val_set)):
        _check_sample_shape(model, tuple(data.frames.shape[1:]), name)
    if data_config is None:
        data_config = _config_dict(getattr(train_data, "config", None)) or train_set.config
    elif _config_dict(data_config) is None:
        raise ValueError(f"data_config must be a dict (e.g. BuildConfig.to_dict()) or None, "
                         f"got {type(data_config).__name__}")
    else:
        data_config = _config_dict(data_config)
    if rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)

    # Dropout (and anything else drawing from torch's global generator) starts from the
    # seed; a resumed run restores the generator's state from last.pt instead.
    torch.manual_seed(seed)
    model.to(device)
    if precision == "bf16" and not bf16_is_fast(device):
        raise ValueError(f"precision='bf16' on {device}: this device has no fast bfloat16 "
                         "(AVX-512 BF16/AMX CPU or a bf16 GPU); train with precision='fp32'")
    if channels_last:
        to_channels_last(model)
    optimizer = torch.optim.AdamW(model.parameters(), lr=recipe.lr,
                                  weight_decay=recipe.weight_decay)
    history: list[dict] = []
    start_epoch, best_iou = 0, -1.0
    if resume:
        state = _read_resume_state(out_dir / "last.pt", model, data_config, device, loss)
        model.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        start_epoch, best_iou = int(state["epoch"]) + 1, float(state["best_iou"])
        history = [dict(h) for h in state["history"]]
        torch.set_rng_state(state["torch_rng"].cpu())
        if device.type == "cuda" and state.get("cuda_rng") is not None:
            torch.cuda.set_rng_state(state["cuda_rng"].cpu(), device)
    net = model
    if world > 1:
        net = nn.parallel.DistributedDataParallel(
            model, device_ids=[device.index] if device.type == "cuda" else None)

    steps_per_epoch = len(_batches(len(train_set), recipe.batch_size, seed, 0))
    total_steps = steps_per_epoch * recipe.epochs
    for epoch in range(start_epoch, recipe.epochs):
        for group in optimizer.param_groups:
            group["lr"] = lr_schedule(recipe, epoch, recipe.epochs)
        started = time.perf_counter()
        net.train()
        batches = _batches(len(train_set), recipe.batch_size, seed, epoch)
        losses = []
        bar = tqdm(batches, desc=f"epoch {epoch + 1}/{recipe.epochs}", leave=False,
                   disable=not progress or rank != 0)
        for batch in bar:
            mine = batch[rank::world]  # each process takes its share of the batch
            if len(mine) == 0:
                mine = batch[:1]  # keep every process stepping in lockstep
            step = epoch * steps_per_epoch + len(losses)
            if recipe.per_step:
                for group in optimizer.param_groups:
                    group["lr"] = lr_at_step(recipe, step, total_steps)
            x = train_set.frames[mine].to(device, torch.float32)
            y = train_set.voxels[mine].to(device, torch.float32)
            with torch.autocast(device.type, dtype=torch.bfloat16,
                                enabled=precision == "bf16"):
                logits = net(x)
            value = loss_fn(logits.float(), y)
            optimizer.zero_grad(set_to_none=True)
            value.backward()
            if precision == "bf16":
                _check_gradients(model, epoch, len(losses))
            optimizer.step()
            losses.append(value.item())
            bar.set_postfix(loss=f"{losses[-1]:.4f}")
            if on_step is not None and rank == 0:
                on_step({"epoch": epoch + 1, "step": step, "loss": losses[-1],
                         "lr": float(optimizer.param_groups[0]["lr"])})
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
                     "torch_rng": torch.get_rng_state(), "seed": seed, "loss": loss,
                     "precision": precision, "channels_last": bool(channels_last),
                     "metadata": metadata or {}}
            if device.type == "cuda":
                extra["cuda_rng"] = torch.cuda.get_rng_state(device)
            save_checkpoint(out_dir / "last.pt", model, data_config=data_config, **extra)
            if improved:
                save_checkpoint(out_dir / "best.pt", model, data_config=data_config, **extra)
            with atomic_path(out_dir / "history.json") as tmp:
                tmp.write_text(json.dumps(history, indent=1) + "\n")
            if progress:
                tqdm.write(f"epoch {epoch + 1:3d}: train loss {record['train_loss']:.4f}, "
                           f"val loss {record['val_loss']:.4f}, val IoU@{IOU_THRESHOLD} "
                           f"{record['val_iou']:.3f} ({record['seconds']:.0f} s)")
        if on_epoch is not None and rank == 0:
            on_epoch(history)
    return history


PRECISIONS = ("fp32", "bf16")
"""The ``precision=`` choices of :func:`fit`."""


def _check_gradients(model: nn.Module, epoch: int, step: int) -> None:
    """Raise FloatingPointError naming the first parameter whose gradient is NaN/inf.

    Only bf16 training checks (one reduction per parameter and step). oneDNN's bfloat16
    kernels (torch 2.13 on an Intel Xeon, AMX or AVX-512 BF16) return garbage, often inf
    or NaN, for the weight gradient of a 3x3x3 convolution whose input is a single voxel
    along every axis (the taps that only see padding should get 0); with 2 or more voxels
    per axis they agree with fp32. The tiny preset's deepest convolution sees 7 x 4 x 4
    voxels, but a model for small frames can end in such a layer, and a NaN weight would
    otherwise only surface later, far from its cause.
    """
    for name, parameter in model.named_parameters():
        if parameter.grad is not None and not torch.isfinite(parameter.grad).all():
            raise FloatingPointError(
                f"bf16 training gave a non-finite gradient for {name} (epoch {epoch + 1}, "
                f"step {step + 1}); this device's bfloat16 kernels are not usable for this "
                "model (a convolution whose input is 1 voxel along every axis gives such "
                "gradients): train with precision='fp32' or on larger frames")


def bf16_is_fast(device: str | torch.device = "cpu") -> bool:
    """Whether ``device`` runs bfloat16 convolutions natively (CPU: AVX-512 BF16 or AMX,
    through oneDNN; CUDA: compute capability 8.0 or newer)."""
    device = torch.device(device)
    if device.type == "cuda":
        return torch.cuda.is_available() and torch.cuda.is_bf16_supported()
    if device.type == "cpu":
        return bool(torch.backends.mkldnn.is_available()
                    and torch.ops.mkldnn._is_mkldnn_bf16_supported())
    return False


def to_channels_last(model: nn.Module) -> nn.Module:
    """Store every 5D weight as ``channels_last_3d`` and every 4D one as ``channels_last``,
    in place (the values are unchanged); returns ``model``."""
    formats = {5: torch.channels_last_3d, 4: torch.channels_last}
    for tensor in [*model.parameters(), *model.buffers()]:
        if tensor.dim() in formats:
            tensor.data = tensor.data.contiguous(memory_format=formats[tensor.dim()])
    return model


RESUME_KEYS = ("optimizer", "epoch", "best_iou", "history", "torch_rng")
"""What ``last.pt`` must hold besides the model for :func:`fit` to resume from it."""


def _check_sample_shape(model: E2V, got: tuple[int, ...], name: str) -> None:
    """Raise ValueError unless samples of shape ``got`` fit ``model`` (channels included)."""
    want = tuple(getattr(model, "sample_shape", model.input_shape))
    if got == want:
        return
    channels = getattr(model, "in_channels", 1)
    if len(got) == 4 and got[0] == 1:
        fix = None  # a channel axis of size 1: one-channel models take none
    elif len(got) == 4:
        fix = f"input_shape={got[1:]}, in_channels={got[0]}"
    elif len(got) == 3:
        fix = f"input_shape={got}" + (", in_channels=1" if channels > 1 else "")
    else:
        fix = None
    layout = ("(n_frames, H, W)" if channels == 1 else "(channels, n_frames, H, W)")
    if fix:
        advice = f"build the model with {fix}"
    elif len(got) == 4:
        advice = "drop the channel axis of size 1 (frames[:, 0]): one channel has none"
    else:
        advice = "give frames of shape (N, n_frames, H, W) or (N, C, n_frames, H, W)"
    raise ValueError(f"the {name} frames are {got} per sample but the model expects "
                     f"{want} = {layout} (input_shape={tuple(model.input_shape)}, "
                     f"in_channels={channels}); {advice}")


def _read_resume_state(path: Path, model: E2V, data_config: dict | None,
                       device: torch.device, loss: str = LEGACY_LOSS) -> dict:
    """Read ``last.pt`` for a resume and check it belongs to this model and data."""
    state = read_checkpoint(path, map_location=device)
    missing = [key for key in RESUME_KEYS if key not in state]
    if missing:
        raise CheckpointError(
            f"cannot resume from {path}: it has no {missing} (a slimmed or hand-made "
            "checkpoint keeps only the weights). Resume needs the last.pt that fit writes; "
            "start a new run without resume (--resume) instead, e.g. into another folder.")
    ours = model.config.to_dict()
    stored = dict(state["config"])
    try:  # fill in fields added after the checkpoint was written (in_channels, ...)
        stored = E2VConfig.from_dict(stored).to_dict()
    except (ValueError, TypeError):
        pass  # not a valid config: the comparison below names what differs
    differ = sorted(k for k in ours.keys() | stored.keys() if ours.get(k) != stored.get(k))
    if differ:
        details = ", ".join(f"{k}: {stored.get(k)!r} in last.pt, {ours.get(k)!r} given"
                            for k in differ)
        raise ValueError(
            f"cannot resume from {path}: it holds a different model ({details}). Resume "
            "with the model stored there (load_checkpoint(last.pt); on the command line "
            "drop --preset), or train the new model into another folder.")
    stored_loss = state.get("loss", LEGACY_LOSS)
    if stored_loss != loss:
        raise ValueError(
            f"cannot resume from {path}: it was trained with loss={stored_loss!r}, but "
            f"loss={loss!r} was given. Resume with loss={stored_loss!r}, or train with "
            f"loss={loss!r} into another folder.")
    check_frames_match(checkpoint_data_config(state), data_config, path, "the training data")
    return state


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
    """
    if not _is_whole(batch_size) or batch_size < 1:
        raise ValueError(f"batch_size must be a whole number >= 1, got {batch_size!r}")
    frames = torch.as_tensor(frames)
    device = resolve_device(device)
    home, was_training = _model_device(model), model.training
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
def _validate(model: E2V, data: TensorSet, device: torch.device, loss_fn) -> dict:
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


def score_predictions(probabilities: torch.Tensor, voxels: torch.Tensor,
                      fscore_points: int = 8192) -> dict[str, np.ndarray]:
    """Per-sample metrics: ``{"iou@0.2": (N,), ..., "fscore@1%": (N,), "fscore@20%": (N,)}``.

    F-scores use :data:`e2vlib.paper.IOU_THRESHOLD` (Pix2Vox++'s choice) and
    ``fscore_points`` surface samples.
    """
    scores = {f"iou@{t}": np.atleast_1d(iou(probabilities, voxels, threshold=t))
              for t in IOU_THRESHOLDS}
    f = fscores(probabilities, voxels, threshold=IOU_THRESHOLD,
                distances=tuple(FSCORE_DISTANCES.values()), n_points=fscore_points)
    for column, key in enumerate(FSCORE_DISTANCES):
        scores[key] = np.atleast_2d(f)[:, column]
    return scores


def _summarize(scores: dict[str, np.ndarray], categories: Sequence[str]) -> tuple[dict, dict]:
    table = summarize_scores(scores, categories)
    return table["overall"], table["per_category"]


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
