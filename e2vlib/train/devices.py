"""Where training runs: :func:`resolve_device` picks the device. How fast it runs (bfloat16,
channels-last, torchrun) is :mod:`e2vlib.scale.training`'s.
"""

from __future__ import annotations

import torch
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
                         "use --device cpu or install a CUDA build of torch (docs/setup.md: GPU)")
    return device


def model_device(model: nn.Module) -> torch.device | None:
    """Device of the model's first parameter (or buffer); None for a model without any."""
    for tensor in (*model.parameters(), *model.buffers()):
        return tensor.device
    return None
