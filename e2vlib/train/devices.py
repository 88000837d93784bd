"""Where and how fast training runs: the device, bfloat16, channels-last, and torchrun.
"""

from __future__ import annotations

import os

import torch
import torch.distributed as dist
from torch import nn


def resolve_device(device: str | torch.device = "auto") -> torch.device:
    """``"auto"`` -> CUDA if available, else CPU; ``"cpu"``/``"cuda"``/``"cuda:1"`` as given.

    Asking for CUDA on a machine without it raises a ValueError saying so.

    Examples
    --------
    >>> resolve_device("cpu")
    device(type='cpu')
    >>> resolve_device("auto").type in ("cpu", "cuda")
    True
    """
    if str(device) == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    device = torch.device(device)
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError("device 'cuda' requested but torch.cuda.is_available() is False; "
                         "use --device cpu or install a CUDA build of torch (README: GPU)")
    return device


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


def _model_device(model: nn.Module) -> torch.device | None:
    """Device of the model's first parameter (or buffer); None for a model without any."""
    for tensor in (*model.parameters(), *model.buffers()):
        return tensor.device
    return None


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

