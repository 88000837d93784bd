"""Training at scale: :func:`fit_at_scale` is :func:`e2vlib.train.fit` with resume, torchrun,
bfloat16 and channels-last.

It runs ``fit`` itself, adding these through :class:`ScaleHooks` (the places
:class:`~e2vlib.train.FitHooks` names in ``fit``'s loop), so every run trains through the one
loop and the one step; with its options off it trains the same weights and history as ``fit``
from the same call (tests/test_train.py checks it). Here too: what resuming checks
(:func:`resume_problems`, :func:`read_resume_state`), the device's bfloat16
(:func:`bf16_is_fast`), channels-last weights (:func:`to_channels_last`) and joining a
torchrun process group (:func:`init_distributed_from_env`). See bench/RESULTS.md ("Faster CPU
training") for what each speed option gains.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path

import torch
import torch.distributed as dist
from torch import nn

from e2vlib.model import (
    E2V,
    CheckpointError,
    E2VConfig,
    check_frames_match,
    checkpoint_data_config,
    read_checkpoint,
)
from e2vlib.model.integrity import check_state_matches
from e2vlib.scale.options import PRECISIONS
from e2vlib.train.devices import model_device, resolve_device
from e2vlib.train.loop import FitHooks, fit
from e2vlib.train.recipes import Recipe

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
    """:func:`e2vlib.train.fit` (same arguments, files and history) with these options,
    which it adds to ``fit``'s loop through :class:`ScaleHooks`:

    resume
        Continue exactly from ``out_dir/last.pt`` (weights, optimizer, RNG state, history).
        The checkpoint must hold the same model config, the same loss and, when both are
        known, data made with the same frame settings (:func:`read_resume_state`).
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

    Under ``torchrun`` (after :func:`init_distributed_from_env`) the model is wrapped in
    DistributedDataParallel and each process trains on its share of every batch's samples;
    only rank 0 writes files, prints and calls ``on_epoch`` and ``on_step``. ``last.pt`` and
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
    where = resolve_device(device)
    if precision == "bf16" and not bf16_is_fast(where):
        raise ValueError(f"precision='bf16' on {where}: this device has no fast bfloat16 "
                         "(AVX-512 BF16/AMX CPU or a bf16 GPU); train with precision='fp32'")
    hooks = ScaleHooks(resume=resume, precision=precision, channels_last=channels_last,
                       loss=loss)
    main = hooks.saves  # rank 0 (or not under torchrun) prints and calls back
    return fit(model, train_data, val_data, out_dir, recipe=recipe, epochs=epochs,
               device=device, seed=seed, progress=progress and main,
               on_epoch=on_epoch if main else None, metadata=metadata,
               data_config=data_config, loss=loss, on_step=on_step if main else None,
               hooks=hooks, **recipe_overrides)


class ScaleHooks(FitHooks):
    """:class:`~e2vlib.train.FitHooks` for :func:`fit_at_scale`: channels-last weights and a
    resume from ``last.pt`` before the first epoch, DistributedDataParallel under torchrun
    (each process trains on its share of every batch; BatchNorm statistics aligned after
    each epoch; only rank 0 writes), the forward pass under bfloat16 autocast with every
    gradient checked, and ``precision`` and ``channels_last`` recorded in the checkpoints."""

    def __init__(self, resume: bool = False, precision: str = "fp32",
                 channels_last: bool = False, loss: str = "bce") -> None:
        self.resume, self.precision, self.loss = resume, precision, loss
        self.channels_last = bool(channels_last)
        self.rank, self.world = _distributed()
        self.saves = self.rank == 0
        self.model: nn.Module | None = None  # set by start, with the device it trains on
        self.device = torch.device("cpu")
        self.where = (0, 0)  # (epoch, step) of the step under way, both from 0

    def start(self, model, optimizer, out_dir, data_config):
        self.model, self.device = model, model_device(model)
        if self.channels_last:
            to_channels_last(model)
        history, best_iou = [], -1.0
        if self.resume:
            history, best_iou = _restore(out_dir / "last.pt", model, optimizer, data_config,
                                         self.loss)
        net = model if self.world == 1 else nn.parallel.DistributedDataParallel(
            model, device_ids=[self.device.index] if self.device.type == "cuda" else None)
        return net, history, best_iou

    def begin_step(self, epoch, step, batch):
        """This process's share of ``batch``; a process left without a sample repeats the
        first, to keep every process stepping in lockstep."""
        self.where = (epoch, step)
        mine = batch[self.rank::self.world]
        return mine if len(mine) else batch[:1]

    def autocast(self):
        return torch.autocast(self.device.type, dtype=torch.bfloat16,
                              enabled=self.precision == "bf16")

    def after_backward(self):
        if self.precision == "bf16":
            _check_gradients(self.model, *self.where)

    def end_epoch(self):
        if self.world > 1:
            # DDP keeps parameters equal; buffers (BatchNorm running statistics) are only
            # copied from rank 0 at the start of each forward, so align them once more.
            for buffer in self.model.buffers():
                dist.broadcast(buffer, src=0)

    def checkpoint_entries(self):
        return {"precision": self.precision, "channels_last": self.channels_last}


def _restore(path: Path, model: E2V, optimizer: torch.optim.Optimizer,
             data_config: dict | None, loss: str) -> tuple[list[dict], float]:
    """Load ``last.pt`` into ``model`` (on its device), ``optimizer`` and torch's random
    generators after :func:`read_resume_state`'s checks; returns ``(history, best IoU)``."""
    device = model_device(model)
    state = read_resume_state(path, model, data_config, device, loss)
    model.load_state_dict(state["model"])
    optimizer.load_state_dict(state["optimizer"])
    torch.set_rng_state(state["torch_rng"].cpu())
    if device.type == "cuda" and state.get("cuda_rng") is not None:
        torch.cuda.set_rng_state(state["cuda_rng"].cpu(), device)
    history = [dict(h) for h in state["history"]]
    if len(history) != int(state["epoch"]) + 1:
        raise CheckpointError(f"cannot resume from {path}: it records epoch "
                              f"{int(state['epoch']) + 1} but a history of {len(history)}")
    return history, float(state["best_iou"])


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
    for key, kind in (("epoch", int), ("best_iou", float)):  # bookkeeping fit wrote
        value = state[key]
        if (isinstance(value, bool) or not isinstance(value, (int, float, torch.Tensor))
                or (isinstance(value, torch.Tensor) and value.numel() != 1)
                or not math.isfinite(float(value)) or float(value) < 0
                or (kind is int and float(value) != int(value))):
            raise CheckpointError(
                f"cannot resume from {path}: its {key} is {str(value)[:40]!r}, not a "
                f"{'whole number' if kind is int else 'score'} (a damaged or hand-edited "
                "last.pt); start a new run without --resume, e.g. into another folder.")
    if not isinstance(state["history"], list):
        raise CheckpointError(f"cannot resume from {path}: its history is not a list (a "
                              "damaged or hand-edited last.pt); start a new run without "
                              "--resume, e.g. into another folder.")
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
