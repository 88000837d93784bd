"""The training loop, :func:`fit`, and what resuming it checks.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch
import torch.distributed as dist
from torch import nn

from e2vlib.files import atomic_path
from e2vlib.inputs.tensors import _config_dict, preload
from e2vlib.losses import LOSSES, make_loss
from e2vlib.model import (
    E2V,
    CheckpointError,
    E2VConfig,
    check_frames_match,
    checkpoint_data_config,
    read_checkpoint,
    save_checkpoint,
)
from e2vlib.paper import IOU_THRESHOLD
from e2vlib.train.devices import (
    PRECISIONS,
    _check_gradients,
    _distributed,
    bf16_is_fast,
    resolve_device,
    to_channels_last,
)
from e2vlib.train.evaluation import _validate
from e2vlib.train.recipes import Recipe, _is_whole, get_recipe, lr_at_step, lr_schedule

LEGACY_LOSS = "bce"
"""The loss of checkpoints written before the loss was recorded: fit only had BCE then."""


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

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.model import build_e2v
    >>> from e2vlib.train import TensorSet
    >>> voxels = torch.zeros(4, 32, 32, 32, dtype=torch.bool); voxels[:, 8:24] = True
    >>> data = TensorSet(torch.zeros(4, 8, 16, 16, dtype=torch.uint8), voxels,
    ...                  ["chair"] * 4, ["a", "b", "c", "d"])
    >>> model = build_e2v("tiny", seed=0, input_shape=(8, 16, 16))
    >>> with tempfile.TemporaryDirectory() as out:
    ...     history = fit(model, data, data, out, epochs=2, batch_size=2, device="cpu",
    ...                   progress=False)
    ...     files = sorted(p.name for p in Path(out).iterdir())
    ...     last_epoch = read_resume_state(Path(out) / "last.pt", model, None,
    ...                                    torch.device("cpu"))["epoch"]
    >>> [h["epoch"] for h in history], files, last_epoch   # last.pt counts epochs from 0
    ([1, 2], ['best.pt', 'history.json', 'last.pt'], 1)
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
    if recipe.output_prior and not resume:
        init_output_prior(model, float(train_set.voxels.float().mean())
                          if recipe.output_prior_p is None else recipe.output_prior_p)
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
        state = read_resume_state(out_dir / "last.pt", model, data_config, device, loss)
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


def _stored_config(state: dict) -> dict:
    """A checkpoint's model config as a dict, with fields added after it was written (such
    as ``in_channels``) filled in where it is a valid config."""
    stored = dict(state["config"])
    try:
        return E2VConfig.from_dict(stored).to_dict()
    except (ValueError, TypeError):
        return stored  # not a valid config: a comparison names what differs


def resume_problems(state: dict, config: E2VConfig | None = None) -> tuple[list[str], list[str]]:
    """What keeps ``state`` (a read ``last.pt``) from resuming a run of a model of
    ``config``: ``(missing, differ)``, the :data:`RESUME_KEYS` it lacks and the config fields
    that differ (sorted; ``[]`` without ``config``). :func:`read_resume_state` and the
    command line's ``train --resume`` word their errors from it.

    Examples
    --------
    >>> from e2vlib.model import PRESETS
    >>> state = {"config": PRESETS["tiny"].to_dict(), "epoch": 3}
    >>> missing, differ = resume_problems(state, PRESETS["tiny2d"])
    >>> missing, differ
    (['optimizer', 'best_iou', 'history', 'torch_rng'], ['encoder'])
    """
    missing = [key for key in RESUME_KEYS if key not in state]
    if config is None:
        return missing, []
    ours, stored = config.to_dict(), _stored_config(state)
    return missing, sorted(k for k in ours.keys() | stored.keys() if ours.get(k) != stored.get(k))


def read_resume_state(path: Path, model: E2V, data_config: dict | None,
                       device: torch.device, loss: str = LEGACY_LOSS) -> dict:
    """Read ``last.pt`` for a resume and check it belongs to this model and data.

    Examples
    --------
    See :func:`fit`'s example; a missing file is named, with the fix:

    >>> from e2vlib.model import build_e2v
    >>> read_resume_state(Path("no/such/last.pt"), build_e2v("tiny", input_shape=(8, 16, 16)),
    ...                   None, torch.device("cpu"))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    FileNotFoundError: checkpoint no/such/last.pt does not exist; train one first ...
    """
    state = read_checkpoint(path, map_location=device)
    missing, differ = resume_problems(state, model.config)
    if missing:
        raise CheckpointError(
            f"cannot resume from {path}: it has no {missing} (a slimmed or hand-made "
            "checkpoint keeps only the weights). Resume needs the last.pt that fit writes; "
            "start a new run without resume (--resume) instead, e.g. into another folder.")
    if differ:
        ours, stored = model.config.to_dict(), _stored_config(state)
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

