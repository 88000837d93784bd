"""The event frames lifted into the grid inside a network: :class:`Lifting`, :class:`LiftStem`.

A hybrid E2V (``E2VConfig.lift`` other than ``"none"``) reads, beside its encoder's features,
the frames back-projected through the known orbit: :func:`e2vlib.geometry.lift_frames`
written with torch so that it runs on the batch, on any device. The table of where each
voxel centre lands in each frame (:func:`e2vlib.geometry.lifting_table`) is built from the
config once per orbit and process (:func:`look_up_matrix`), never stored in a checkpoint
(26 MB at 100 frames). Tests show both give the same volumes.

Introduced in notebooks/15_learning_meets_geometry.ipynb.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from e2vlib.geometry import LIFTED_CHANNELS, MERGE_FRAMES, lifting_table
from e2vlib.model.config import GRID_SIDE, E2VConfig
from e2vlib.model.encoders import conv_layer, norm_layer


@functools.lru_cache(maxsize=4)
def look_up_matrix(n_frames: int, resolution: int, dt_us: int) -> torch.Tensor:
    """The lifting table as a sparse 0/1 CSR matrix ``(32^3, n_frames (resolution^2 + 1))``:
    row ``v`` has a 1 at each frame's pixel under voxel ``v`` (the frame's extra last pixel,
    always set, when the voxel projects outside it). Built once per orbit and process (about
    1 s at 100 frames of 64 x 64) and shared by every model of that orbit: read-only."""
    table = lifting_table(n_frames, dt_us, resolution, GRID_SIDE)
    pixels = resolution * resolution + 1  # the extra pixel: outside the frame, always set
    column = np.where(table < 0, pixels - 1, table) + pixels * np.arange(n_frames)[:, None]
    voxels = table.shape[1]
    # A sparse product sums, for every voxel, its pixel over the frames (a gather would copy
    # n_frames x 32^3 values per sample first; this is about 20x faster on a CPU).
    with warnings.catch_warnings():  # torch calls its sparse CSR support "beta"
        warnings.simplefilter("ignore", UserWarning)
        return torch.sparse_coo_tensor(
            torch.from_numpy(np.stack([np.tile(np.arange(voxels), n_frames), column.ravel()])),
            torch.ones(column.size, device="cpu"), (voxels, n_frames * pixels),
            check_invariants=True, device="cpu").coalesce().to_sparse_csr()


class Lifting(nn.Module):
    """Binary frames ``(B, n, H, W)`` -> lifted volume ``(B, 2, 32, 32, 32)`` (no weights).

    The channels of :data:`e2vlib.geometry.LIFTED_CHANNELS`, exactly as
    :func:`e2vlib.geometry.lift_frames` computes them for one sample. ``dt_us``: the frames'
    window length on the orbit's clock (frame ``k`` from ``k dt`` to ``(k + 1) dt``).
    """

    def __init__(self, n_frames: int, resolution: int, dt_us: int,
                 merge_frames: int = MERGE_FRAMES) -> None:
        super().__init__()
        self.merge_frames = merge_frames
        self.register_buffer("look_up", look_up_matrix(n_frames, resolution, dt_us),
                             persistent=False)

    @torch.no_grad()
    def forward(self, frames: torch.Tensor) -> torch.Tensor:
        b, n, h, w = frames.shape
        events = (frames > 0).to(torch.uint8)  # 0/1 bytes: the elementwise steps run ~10x faster
        # silhouettes: neighbouring frames merged (an OR over merge_frames shifts in time),
        # then each row filled between its outermost events
        r = self.merge_frames // 2
        padded = F.pad(events, (0, 0, 0, 0, r, r))
        merged = padded[:, :n]
        for shift in range(1, self.merge_frames):
            merged = torch.maximum(merged, padded[:, shift:shift + n])
        filled = (torch.cummax(merged, dim=3).values
                  & torch.cummax(merged.flip(3), dim=3).values.flip(3))
        channels = []
        for images in (filled, events):
            flat = images.reshape(b, n, h * w).float()
            used = flat.amax(dim=2, keepdim=True)  # (b, n, 1): 1 for frames with events
            with_outside = torch.cat([flat, torch.ones_like(used)], dim=2) * used
            held = (self.look_up @ with_outside.reshape(b, -1).T).T  # (b, 32^3) frames held
            channels.append(held / used.sum(1).clamp(min=1))
        return torch.stack(channels, 1).view(b, len(LIFTED_CHANNELS), *(GRID_SIDE,) * 3)


class LiftStem(nn.Module):
    """Lifted volume ``(B, 2, 32, 32, 32)`` -> features ``(B, lift_width, 32, 32, 32)``:
    one 3x3x3 convolution, norm, ReLU (a voxel sees its neighbours' evidence)."""

    def __init__(self, config: E2VConfig) -> None:
        super().__init__()
        self.layers = nn.Sequential(
            conv_layer(3, len(LIFTED_CHANNELS), config.lift_width, 3),
            norm_layer(config.norm, config.lift_width),
            nn.ReLU(inplace=True),
        )

    def forward(self, lifted: torch.Tensor) -> torch.Tensor:
        return self.layers(lifted)
