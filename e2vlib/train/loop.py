"""The training loop, :func:`fit`, and the pieces it is made of.

:func:`fit` is the one training loop of the library, the one a lesson reads and the one
``python -m e2vlib train`` runs: seed, AdamW from the recipe, the learning rate per epoch (or
per step), then epochs of :func:`train_step` (forward, loss, backward, optimizer step), a
validation pass, and the files of the run. The speed and scale band joins it through
:class:`FitHooks` (:func:`e2vlib.scale.training.fit_at_scale`: resume, torchrun, bfloat16,
channels-last) and never copies it. Its helpers: :func:`epoch_batches` (the seeded sample
order), :func:`save_run` (the checkpoints), :func:`epoch_line` (the printed line),
:func:`fit_settings` and :func:`fit_data` (the checked arguments).
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch
from torch import nn

from e2vlib.files import atomic_path
from e2vlib.inputs.tensors import TensorSet, preload, settings_dict
from e2vlib.losses import LOSSES, make_loss
from e2vlib.model import E2V, save_checkpoint
from e2vlib.paper import IOU_THRESHOLD
from e2vlib.train.devices import resolve_device
from e2vlib.train.evaluation import validation_scores
from e2vlib.train.recipes import Recipe, get_recipe, is_whole_number, lr_at_step, lr_schedule

SCALE_OPTIONS = ("resume", "precision", "channels_last")
"""Options of :func:`e2vlib.scale.training.fit_at_scale` that :func:`fit` does not take."""


def init_output_prior(model: E2V, occupancy: float, weight_scale: float = 0.01) -> None:
    """Start ``model``'s output layer at occupancy probability ``occupancy`` (in (0, 1)):
    bias ``log(p / (1 - p))``, weights scaled by ``weight_scale``, so the first predictions
    are about ``occupancy`` everywhere instead of about 0.5 plus whatever the features add.

    Without it the first steps of BCE see mostly empty voxels predicted as occupied (mean
    probability 0.78-0.85 for the tiny presets against data_small's occupancy of 0.076) and push
    every activation down; in some seeds that kills every unit of the fully connected
    bridge, and the network then learns one grid for every input
    (experiments/collapse_probe.py measures it).

    Examples
    --------
    >>> from e2vlib.model import build_e2v
    >>> model = build_e2v("tiny", seed=0, input_shape=(8, 16, 16))
    >>> init_output_prior(model, 0.2)
    >>> round(float(torch.sigmoid(model.head.bias.detach())[0]), 6)
    0.2
    """
    if not 0 < occupancy < 1:
        raise ValueError(f"occupancy must be in (0, 1), got {occupancy!r}: the training "
                         "labels are all empty or all full")
    with torch.no_grad():
        model.head.weight.mul_(weight_scale)
        model.head.bias.fill_(float(np.log(occupancy / (1 - occupancy))))


def fit(
    model: E2V,
    train_data,
    val_data,
    out_dir: str | os.PathLike,
    recipe: str | Recipe = "tiny",
    epochs: int | None = None,
    device: str = "auto",
    seed: int = 0,
    progress: bool = True,
    on_epoch: Callable[[list[dict]], None] | None = None,
    metadata: dict | None = None,
    data_config: dict | None = None,
    loss: str = "bce",
    on_step: Callable[[dict], None] | None = None,
    hooks: FitHooks | None = None,
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
        ``lr <= 0`` raise a ValueError naming the value. The learning rate is set once per
        epoch (:func:`lr_schedule`), or before every step for a recipe with ``per_step``
        (:func:`lr_at_step`, with its warm-up).
    device
        ``"auto"``, ``"cpu"``, ``"cuda"``, ... (:func:`resolve_device`).
    seed
        Seeds the sample order of every epoch and torch's global generator (dropout), so
        the same call trains the same weights on every run.
    on_epoch
        Called with the history after each epoch (live plots); raising in it stops the run.
    metadata
        A plain dict stored in the checkpoints under ``"metadata"``.
    data_config
        The build settings of the training data (``BuildConfig.to_dict()``), stored in
        every checkpoint as ``"data_config"``; defaults to ``train_data.config`` when that
        is a dict.
    loss
        The training loss, one of :data:`e2vlib.losses.LOSSES`: ``"bce"`` (mean binary
        cross-entropy, the paper's), ``"focal"`` or ``"bce_dice"``. Validation reports the
        same loss as ``val_loss``; ``best.pt`` is still picked by validation IoU.
    on_step
        Called after every optimizer step with ``{"epoch", "step", "loss", "lr"}`` (epoch
        from 1, step counted over the whole run from 0); the gradients of that step are
        still on the model's parameters (diagnostics, per-step plots).
    hooks
        What the speed and scale band adds to this loop (:class:`FitHooks`; none by
        default): :func:`e2vlib.scale.training.fit_at_scale` resumes from ``last.pt``,
        trains under ``torchrun``, in bfloat16 or channels-last through them.

    Returns
    -------
    list[dict]
        One row per epoch: ``epoch`` (from 1), ``train_loss`` (mean over the epoch's
        steps), ``val_loss``, ``val_iou`` (at the end of the epoch), ``lr``, ``seconds``.

    Introduced in notebooks/06_training.ipynb.

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.model import build_e2v, read_checkpoint
    >>> voxels = torch.zeros(4, 32, 32, 32, dtype=torch.bool); voxels[:, 8:24] = True
    >>> data = TensorSet(torch.zeros(4, 8, 16, 16, dtype=torch.uint8), voxels,
    ...                  ["chair"] * 4, ["a", "b", "c", "d"])
    >>> model = build_e2v("tiny", seed=0, input_shape=(8, 16, 16))
    >>> with tempfile.TemporaryDirectory() as out:
    ...     history = fit(model, data, data, out, epochs=2, batch_size=2, device="cpu",
    ...                   progress=False)
    ...     files = sorted(p.name for p in Path(out).iterdir())
    ...     last_epoch = read_checkpoint(Path(out) / "last.pt")["epoch"]
    >>> [h["epoch"] for h in history], files, last_epoch   # last.pt counts epochs from 0
    ([1, 2], ['best.pt', 'history.json', 'last.pt'], 1)
    """
    from tqdm.auto import tqdm

    recipe, loss_fn, device, seed = fit_settings(recipe, epochs, loss, device, seed,
                                                 recipe_overrides)
    train_set, val_set, data_config = fit_data(model, train_data, val_data, data_config)
    hooks = hooks or FitHooks()
    out_dir = Path(out_dir)
    if hooks.saves:
        out_dir.mkdir(parents=True, exist_ok=True)

    torch.manual_seed(seed)  # dropout draws from torch's global generator
    if recipe.output_prior:  # start the predictions at the labels' occupancy (or at p)
        p = recipe.output_prior_p
        init_output_prior(model, float(train_set.voxels.float().mean()) if p is None else p)
    model.to(device)
    optimizer = torch.optim.AdamW(model.parameters(), lr=recipe.lr,
                                  weight_decay=recipe.weight_decay)
    net, history, best_iou = hooks.start(model, optimizer, out_dir, data_config)
    steps = len(epoch_batches(len(train_set), recipe.batch_size, seed, 0))  # per epoch
    for epoch in range(len(history), recipe.epochs):  # a resumed history holds epochs done
        _set_lr(optimizer, lr_schedule(recipe, epoch, recipe.epochs))
        started, losses = time.perf_counter(), []
        net.train()
        batches = epoch_batches(len(train_set), recipe.batch_size, seed, epoch)
        bar = tqdm(batches, desc=f"epoch {epoch + 1}/{recipe.epochs}", leave=False,
                   disable=not progress)
        for i, batch in enumerate(bar):
            step = epoch * steps + i
            if recipe.per_step:
                _set_lr(optimizer, lr_at_step(recipe, step, steps * recipe.epochs))
            batch = hooks.begin_step(epoch, i, batch)
            x = train_set.frames[batch].to(device, torch.float32)
            y = train_set.voxels[batch].to(device, torch.float32)
            losses.append(train_step(net, optimizer, loss_fn, x, y, hooks))
            bar.set_postfix(loss=f"{losses[-1]:.4f}")
            if on_step is not None:
                on_step({"epoch": epoch + 1, "step": step, "loss": losses[-1],
                         "lr": float(optimizer.param_groups[0]["lr"])})
        hooks.end_epoch()
        val = validation_scores(model, val_set, device, loss_fn)
        history.append({"epoch": epoch + 1, "train_loss": float(np.mean(losses)),
                        "val_loss": val["loss"], "val_iou": val["iou"],
                        "lr": float(optimizer.param_groups[0]["lr"]),
                        "seconds": time.perf_counter() - started})
        improved = val["iou"] > best_iou  # best.pt keeps the best validation IoU
        best_iou = max(best_iou, val["iou"])
        if hooks.saves:
            save_run(out_dir, model, optimizer, history, best_iou, improved, recipe=recipe,
                     seed=seed, loss=loss, data_config=data_config, metadata=metadata,
                     **hooks.checkpoint_entries())
        if progress:
            print(epoch_line(history[-1]))
        if on_epoch is not None:
            on_epoch(history)
    return history


def train_step(model: nn.Module, optimizer: torch.optim.Optimizer, loss_fn,
               x: torch.Tensor, y: torch.Tensor, hooks: FitHooks | None = None) -> float:
    """One optimizer step on the batch ``x`` (frames, float32) with labels ``y``
    (``(B, 32, 32, 32)`` float 0/1): forward, loss, gradients, AdamW; returns the loss.

    ``hooks`` (:class:`FitHooks`) may run the forward pass under autocast and check the
    gradients before the step; the loss is always computed in float32.

    Examples
    --------
    >>> from e2vlib.model import build_e2v
    >>> model = build_e2v("tiny", seed=0, input_shape=(8, 16, 16))
    >>> optimizer = torch.optim.AdamW(model.parameters(), lr=1e-3)
    >>> x, y = torch.rand(2, 8, 16, 16), torch.zeros(2, 32, 32, 32)
    >>> loss = train_step(model, optimizer, make_loss("bce"), x, y)
    >>> loss > train_step(model, optimizer, make_loss("bce"), x, y)  # one step helped
    True
    """
    hooks = hooks or FitHooks()
    with hooks.autocast():  # plain fit: nothing; bf16 training: the forward in bfloat16
        logits = model(x)
    value = loss_fn(logits.float(), y)
    optimizer.zero_grad(set_to_none=True)
    value.backward()
    hooks.after_backward()  # bf16 training: stop on a NaN/inf gradient before the step
    optimizer.step()
    return value.item()


class FitHooks:
    """The places where :func:`fit`'s loop lets the speed and scale band add to it; this
    base adds nothing (a plain run). :class:`e2vlib.scale.training.ScaleHooks` fills them in
    for resume, torchrun, bfloat16 and channels-last, so those runs go through the same
    loop and the same :func:`train_step`.

    ``saves``: whether this process writes ``last.pt``, ``best.pt`` and ``history.json``
    (under torchrun only rank 0 does).
    """

    saves: bool = True

    def start(self, model: nn.Module, optimizer: torch.optim.Optimizer, out_dir: Path,
              data_config: dict | None) -> tuple[nn.Module, list[dict], float]:
        """Called once, after the optimizer is made: ``(the module to train, the history of
        the epochs done, the best validation IoU so far)``; here ``(model, [], -1.0)``."""
        return model, [], -1.0

    def begin_step(self, epoch: int, step: int, batch: torch.Tensor) -> torch.Tensor:
        """Before step ``step`` (from 0) of epoch ``epoch`` (from 0): the sample indices
        this process trains on, here all of ``batch``."""
        return batch

    def autocast(self) -> contextlib.AbstractContextManager:
        """The context of the forward pass of a training step; here none."""
        return contextlib.nullcontext()

    def after_backward(self) -> None:
        """After the gradients of a step are computed, before the optimizer uses them."""

    def end_epoch(self) -> None:
        """After an epoch's last step, before validation."""

    def checkpoint_entries(self) -> dict:
        """Entries stored in ``last.pt`` and ``best.pt`` besides :func:`save_run`'s."""
        return {}


def _set_lr(optimizer: torch.optim.Optimizer, lr: float) -> None:
    """Set the learning rate of every parameter group of ``optimizer`` to ``lr``."""
    for group in optimizer.param_groups:
        group["lr"] = lr


def _epoch_order(n: int, seed: int, epoch: int) -> torch.Tensor:
    """The shuffled sample order of one epoch: a function of (seed, epoch) only."""
    return torch.randperm(n, generator=torch.Generator().manual_seed(seed * 100_003 + epoch))


def epoch_batches(n: int, batch_size: int, seed: int, epoch: int) -> list[torch.Tensor]:
    """The batches (sample indices) of epoch ``epoch`` of ``n`` samples, shuffled as a
    function of ``(seed, epoch)`` only; a lone last sample joins the batch before it,
    because BatchNorm cannot train on a single sample.

    Examples
    --------
    >>> [len(b) for b in epoch_batches(9, 4, seed=0, epoch=0)]
    [4, 5]
    >>> sorted(torch.cat(epoch_batches(9, 4, seed=0, epoch=1)).tolist()) == list(range(9))
    True
    """
    order = _epoch_order(n, seed, epoch)
    batches = [order[i:i + batch_size] for i in range(0, len(order), batch_size)]
    if len(batches) > 1 and len(batches[-1]) < 2:
        batches[-2:] = [torch.cat(batches[-2:])]
    return batches


def save_run(out_dir: Path, model: E2V, optimizer: torch.optim.Optimizer,
             history: list[dict], best_iou: float, improved: bool, *, recipe: Recipe,
             seed: int, loss: str, data_config: dict | None, metadata: dict | None = None,
             **extra) -> None:
    """Write ``out_dir/last.pt`` (the model, the optimizer, the epoch counted from 0, the best
    IoU so far, the history, the recipe, the seed, the loss, torch's random state(s),
    ``metadata`` and ``extra``), ``out_dir/best.pt`` (the same) when ``improved``, and
    ``out_dir/history.json``; each written to a temporary file, then renamed."""
    state = {"optimizer": optimizer.state_dict(), "epoch": history[-1]["epoch"] - 1,
             "best_iou": best_iou, "history": history, "recipe": asdict(recipe),
             "torch_rng": torch.get_rng_state(), "seed": seed, "loss": loss,
             "metadata": metadata or {}, **extra}
    device = next(model.parameters()).device
    if device.type == "cuda":
        state["cuda_rng"] = torch.cuda.get_rng_state(device)
    save_checkpoint(out_dir / "last.pt", model, data_config=data_config, **state)
    if improved:
        save_checkpoint(out_dir / "best.pt", model, data_config=data_config, **state)
    with atomic_path(out_dir / "history.json") as tmp:
        tmp.write_text(json.dumps(history, indent=1) + "\n")


def epoch_line(record: dict) -> str:
    """One history row as the line :func:`fit` prints after each epoch.

    Examples
    --------
    >>> epoch_line({"epoch": 3, "train_loss": 0.25, "val_loss": 0.3, "val_iou": 0.41,
    ...             "seconds": 12.4})
    'epoch   3: train loss 0.2500, val loss 0.3000, val IoU@0.3 0.410 (12 s)'
    """
    return (f"epoch {record['epoch']:3d}: train loss {record['train_loss']:.4f}, "
            f"val loss {record['val_loss']:.4f}, val IoU@{IOU_THRESHOLD} "
            f"{record['val_iou']:.3f} ({record['seconds']:.0f} s)")


def fit_settings(recipe: str | Recipe, epochs: int | None, loss: str, device: str,
                 seed: int, overrides: dict) -> tuple[Recipe, Callable, torch.device, int]:
    """:func:`fit`'s checked settings: ``(recipe with epochs and overrides, loss function,
    device, seed)``; a bad one raises a ValueError naming it and the fix."""
    scale = sorted(set(overrides) & set(SCALE_OPTIONS))
    if scale:
        raise ValueError(f"fit has no option {', '.join(scale)}: resume, precision and "
                         "channels_last are options of e2vlib.scale.training.fit_at_scale "
                         "(same arguments besides), which runs fit with them")
    if epochs is not None:
        overrides = {**overrides, "epochs": epochs}
    recipe = get_recipe(recipe, **overrides)
    if not isinstance(loss, str) or loss not in LOSSES:
        raise ValueError(f"unknown loss {loss!r}; choose one of {', '.join(LOSSES)} "
                         "(e2vlib.losses.LOSSES)")
    if not is_whole_number(seed):
        raise ValueError(f"seed must be a whole number, got {seed!r}")
    return recipe, make_loss(loss), resolve_device(device), int(seed)


def fit_data(model: E2V, train_data, val_data,
             data_config: dict | None) -> tuple[TensorSet, TensorSet, dict | None]:
    """``(train set, val set, data config)`` for :func:`fit`: both splits in memory
    (:func:`~e2vlib.inputs.preload`), checked non-empty and of the model's sample shape,
    and the training data's build settings (``data_config``, else ``train_data.config``)."""
    train_set, val_set = preload(train_data), preload(val_data)
    for name, data in (("train_data", train_set), ("val_data", val_set)):
        if len(data) == 0:
            raise ValueError(f"{name} is empty; give fit at least one sample")
    for name, data in (("train_data", train_set), ("val_data", val_set)):
        _check_sample_shape(model, tuple(data.frames.shape[1:]), name)
    if data_config is None:
        data_config = settings_dict(getattr(train_data, "config", None)) or train_set.config
    elif settings_dict(data_config) is None:
        raise ValueError(f"data_config must be a dict (e.g. BuildConfig.to_dict()) or None, "
                         f"got {type(data_config).__name__}")
    else:
        data_config = settings_dict(data_config)
    return train_set, val_set, data_config


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
