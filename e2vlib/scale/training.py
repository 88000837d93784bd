"""Training at scale: :func:`fit_at_scale` is :func:`e2vlib.train.fit` with resume, torchrun,
bfloat16, channels-last, a learning rate set every step and a callback per step.

It is built from core's pieces (:func:`~e2vlib.train.loop.train_epoch`,
:func:`~e2vlib.train.evaluation.validation_scores`, :func:`~e2vlib.train.loop.save_run`, ...)
and, with its options off, trains the same weights and history as ``fit`` from the same call
(tests/test_train.py checks it). Here too: what resuming checks (:func:`resume_problems`,
:func:`read_resume_state`), the device's bfloat16 (:func:`bf16_is_fast`), channels-last
weights (:func:`to_channels_last`) and joining a torchrun process group
(:func:`init_distributed_from_env`). See bench/RESULTS.md ("Faster CPU training") for what
each speed option gains.
"""

from __future__ import annotations

import itertools
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
import torch.distributed as dist
from torch import nn

from e2vlib.model import (
    E2V,
    CheckpointError,
    E2VConfig,
    check_frames_match,
    check_state_matches,
    checkpoint_data_config,
    read_checkpoint,
)
from e2vlib.scale.options import PRECISIONS
from e2vlib.train.evaluation import validation_scores
from e2vlib.train.loop import (
    epoch_batches,
    epoch_line,
    fit_data,
    fit_settings,
    init_output_prior,
    save_run,
    train_epoch,
)
from e2vlib.train.recipes import Recipe, lr_at_step, lr_schedule

LEGACY_LOSS = "bce"
"""The loss of checkpoints written before the loss was recorded: fit only had BCE then."""

RESUME_KEYS = ("optimizer", "epoch", "best_iou", "history", "torch_rng")
"""What ``last.pt`` must hold besides the model for :func:`fit_at_scale` to resume from it."""


def fit_at_scale(
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
    """:func:`e2vlib.train.fit` (same arguments, files and history) with these options:

    resume
        Continue exactly from ``out_dir/last.pt`` (weights, optimizer, RNG state, history).
        The checkpoint must hold the same model config, the same loss and, when both are
        known, data made with the same frame settings (:func:`read_resume_state`).
    on_step
        Called after every optimizer step with ``{"epoch", "step", "loss", "lr"}`` (epoch
        from 1, step counted over the whole run from 0); the gradients of that step are
        still on the model's parameters (diagnostics, per-step plots).
    precision
        ``"fp32"`` (default) or ``"bf16"``: the training forward pass under
        ``torch.autocast`` in bfloat16 (the loss, the optimizer and validation stay in
        float32). Fast on CPUs with AVX-512 BF16 or AMX and on recent GPUs
        (:func:`bf16_is_fast`); elsewhere it is refused with a ValueError. Every step's
        gradients are checked: a NaN/inf one raises FloatingPointError naming the
        parameter (oneDNN's bfloat16 kernels give them for a convolution whose input is
        one voxel along every axis; then train in fp32 or on larger frames).
    channels_last
        Store the convolution weights channels-last (:func:`to_channels_last`), which
        oneDNN runs faster on CPU. The weights are the same numbers; only float rounding
        in the convolutions differs.

    A recipe with ``per_step`` sets the learning rate before every optimizer step
    (:func:`~e2vlib.train.lr_at_step`, with its warm-up) instead of once per epoch. Under
    ``torchrun`` (after :func:`init_distributed_from_env`) the model is wrapped in
    DistributedDataParallel and each process trains on its share of every batch's samples;
    only rank 0 writes files and calls ``on_epoch`` and ``on_step``. ``last.pt`` and
    ``best.pt`` also record ``precision`` and ``channels_last``.

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.model import build_e2v
    >>> from e2vlib.inputs import TensorSet
    >>> voxels = torch.zeros(4, 32, 32, 32, dtype=torch.bool); voxels[:, 8:24] = True
    >>> data = TensorSet(torch.zeros(4, 8, 16, 16, dtype=torch.uint8), voxels,
    ...                  ["chair"] * 4, ["a", "b", "c", "d"])
    >>> def stop(history):
    ...     raise KeyboardInterrupt   # a crash after the first epoch
    >>> with tempfile.TemporaryDirectory() as out:
    ...     try:
    ...         fit_at_scale(build_e2v("tiny", seed=0, input_shape=(8, 16, 16)), data, data,
    ...                      out, epochs=2, batch_size=2, device="cpu", progress=False,
    ...                      on_epoch=stop)
    ...     except KeyboardInterrupt:
    ...         pass
    ...     history = fit_at_scale(build_e2v("tiny", seed=1, input_shape=(8, 16, 16)), data,
    ...                            data, out, epochs=2, batch_size=2, device="cpu",
    ...                            progress=False, resume=True)
    >>> [h["epoch"] for h in history]   # epoch 1 read from last.pt, epoch 2 trained
    [1, 2]
    """
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {', '.join(PRECISIONS)}, got {precision!r}")
    recipe, loss_fn, device, seed = fit_settings(recipe, epochs, loss, device, seed,
                                                 recipe_overrides, per_step=True)
    rank, world = _distributed()
    train_set, val_set, data_config = fit_data(model, train_data, val_data, data_config)
    out_dir = Path(out_dir)
    if rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)

    torch.manual_seed(seed)  # as fit; a resumed run restores the generator from last.pt
    if recipe.output_prior and not resume:
        p = recipe.output_prior_p
        init_output_prior(model, float(train_set.voxels.float().mean()) if p is None else p)
    model.to(device)
    if precision == "bf16" and not bf16_is_fast(device):
        raise ValueError(f"precision='bf16' on {device}: this device has no fast bfloat16 "
                         "(AVX-512 BF16/AMX CPU or a bf16 GPU); train with precision='fp32'")
    if channels_last:
        to_channels_last(model)
    optimizer = torch.optim.AdamW(model.parameters(), lr=recipe.lr,
                                  weight_decay=recipe.weight_decay)
    history, start_epoch, best_iou = [], 0, -1.0
    if resume:
        history, start_epoch, best_iou = _restore(out_dir / "last.pt", model, optimizer,
                                                  data_config, device, loss)
    net = model if world == 1 else nn.parallel.DistributedDataParallel(
        model, device_ids=[device.index] if device.type == "cuda" else None)
    steps_per_epoch = len(epoch_batches(len(train_set), recipe.batch_size, seed, 0))
    for epoch in range(start_epoch, recipe.epochs):
        for group in optimizer.param_groups:
            group["lr"] = lr_schedule(recipe, epoch, recipe.epochs)
        started = time.perf_counter()
        batches = [_share(b, rank, world)
                   for b in epoch_batches(len(train_set), recipe.batch_size, seed, epoch)]
        step = _scale_step(net, model, optimizer, loss_fn, recipe, epoch, steps_per_epoch,
                           precision, on_step if rank == 0 else None)
        losses = train_epoch(net, train_set, batches, device, step,
                             f"epoch {epoch + 1}/{recipe.epochs}", progress and rank == 0)
        if world > 1:
            # DDP keeps parameters equal; buffers (BatchNorm running statistics) are only
            # copied from rank 0 at the start of each forward, so align them once more.
            for buffer in model.buffers():
                dist.broadcast(buffer, src=0)
        val = validation_scores(model, val_set, device, loss_fn)
        history.append({"epoch": epoch + 1, "train_loss": float(np.mean(losses)),
                        "val_loss": val["loss"], "val_iou": val["iou"],
                        "lr": float(optimizer.param_groups[0]["lr"]),
                        "seconds": time.perf_counter() - started})
        improved = val["iou"] > best_iou
        best_iou = max(best_iou, val["iou"])
        if rank == 0:
            save_run(out_dir, model, optimizer, history, best_iou, improved, recipe=recipe,
                     seed=seed, loss=loss, data_config=data_config, metadata=metadata,
                     precision=precision, channels_last=bool(channels_last))
            if progress:
                print(epoch_line(history[-1]))
            if on_epoch is not None:
                on_epoch(history)
    return history


def _share(batch: torch.Tensor, rank: int, world: int) -> torch.Tensor:
    """This process's share of ``batch``; a process left without a sample repeats the
    first, to keep every process stepping in lockstep."""
    mine = batch[rank::world]
    return mine if len(mine) else batch[:1]


def _scale_step(net: nn.Module, model: nn.Module, optimizer: torch.optim.Optimizer, loss_fn,
                recipe: Recipe, epoch: int, steps_per_epoch: int, precision: str,
                on_step: Callable[[dict], None] | None) -> Callable:
    """The training step of epoch ``epoch`` for :func:`~e2vlib.train.loop.train_epoch`:
    :func:`~e2vlib.train.loop.train_step` with the rate set per step (recipes with
    ``per_step``), the forward pass under bfloat16 autocast (``precision="bf16"``), every
    bf16 gradient checked, and ``on_step`` called after the step."""
    count = itertools.count()
    total_steps = steps_per_epoch * recipe.epochs

    def step(x: torch.Tensor, y: torch.Tensor) -> float:
        in_epoch = next(count)
        index = epoch * steps_per_epoch + in_epoch
        if recipe.per_step:
            for group in optimizer.param_groups:
                group["lr"] = lr_at_step(recipe, index, total_steps)
        with torch.autocast(x.device.type, dtype=torch.bfloat16, enabled=precision == "bf16"):
            logits = net(x)
        value = loss_fn(logits.float(), y)
        optimizer.zero_grad(set_to_none=True)
        value.backward()
        if precision == "bf16":
            _check_gradients(model, epoch, in_epoch)
        optimizer.step()
        if on_step is not None:
            on_step({"epoch": epoch + 1, "step": index, "loss": value.item(),
                     "lr": float(optimizer.param_groups[0]["lr"])})
        return value.item()

    return step


def _restore(path: Path, model: E2V, optimizer: torch.optim.Optimizer,
             data_config: dict | None, device: torch.device,
             loss: str) -> tuple[list[dict], int, float]:
    """Load ``last.pt`` into ``model``, ``optimizer`` and torch's random generators after
    :func:`read_resume_state`'s checks; returns ``(history, next epoch, best IoU)``."""
    state = read_resume_state(path, model, data_config, device, loss)
    model.load_state_dict(state["model"])
    optimizer.load_state_dict(state["optimizer"])
    torch.set_rng_state(state["torch_rng"].cpu())
    if device.type == "cuda" and state.get("cuda_rng") is not None:
        torch.cuda.set_rng_state(state["cuda_rng"].cpu(), device)
    return ([dict(h) for h in state["history"]], int(state["epoch"]) + 1,
            float(state["best_iou"]))


# ----------------------------------------------------------------------------- resume checks


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
    """Read ``last.pt`` for a resume and check it belongs to this model, loss and data.

    Examples
    --------
    A missing file is named, with the fix:

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
    check_state_matches(state, f"checkpoint {path}")  # int or bool weights: never cast
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


# ----------------------------------------------------------------------------- devices


def _distributed() -> tuple[int, int]:
    """``(rank, world_size)``; ``(0, 1)`` when not running under torch.distributed."""
    if dist.is_available() and dist.is_initialized():
        return dist.get_rank(), dist.get_world_size()
    return 0, 1


def init_distributed_from_env() -> bool:
    """Join the process group that ``torchrun`` describes in the environment, if any.

    Uses NCCL when CUDA is available, else gloo (CPU). Returns True if distributed.

    Examples
    --------
    >>> init_distributed_from_env()  # a plain run, not under torchrun: nothing to join
    False
    """
    if int(os.environ.get("WORLD_SIZE", "1")) <= 1 or dist.is_initialized():
        return dist.is_initialized()
    backend = "nccl" if torch.cuda.is_available() else "gloo"
    dist.init_process_group(backend=backend)
    if backend == "nccl":
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", "0")))
    return True


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
    through oneDNN; CUDA: compute capability 8.0 or newer).

    Examples
    --------
    >>> bf16_is_fast("cpu") in (True, False)  # True only on a CPU with AVX-512 BF16 or AMX
    True
    """
    device = torch.device(device)
    if device.type == "cuda":
        return torch.cuda.is_available() and torch.cuda.is_bf16_supported()
    if device.type == "cpu":
        return bool(torch.backends.mkldnn.is_available()
                    and torch.ops.mkldnn._is_mkldnn_bf16_supported())
    return False


def to_channels_last(model: nn.Module) -> nn.Module:
    """Store every 5D weight as ``channels_last_3d`` and every 4D one as ``channels_last``,
    in place (the values are unchanged); returns ``model``.

    Examples
    --------
    >>> from e2vlib.model import build_e2v
    >>> model = to_channels_last(build_e2v("tiny", seed=0, input_shape=(8, 16, 16)))
    >>> conv = next(p for p in model.parameters() if p.ndim == 5)
    >>> conv.is_contiguous(memory_format=torch.channels_last_3d)
    True
    """
    formats = {5: torch.channels_last_3d, 4: torch.channels_last}
    for tensor in [*model.parameters(), *model.buffers()]:
        if tensor.dim() in formats:
            tensor.data = tensor.data.contiguous(memory_format=formats[tensor.dim()])
    return model
