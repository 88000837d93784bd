"""E2V's bridge and decoder: encoder output -> hidden volume (C, 32, 32, 32) -> features.

- :class:`Bridge` brings the encoder's ``(B, c, t, h, w)`` output to a hidden volume
  ``(B, C, 32, 32, 32)`` in one of three ways (``E2VConfig.bridge``): ``"reshape"`` (no
  weights; the paper's C from the input shape), ``"interp"`` (1x1x1 conv, trilinear
  resize) or ``"fc"`` (fully connected to a small seed volume: global context).
- :class:`UNetDecoder` is UNet-like and inspired by the Pix2Vox++ refiner: 3D conv down
  blocks, a bottleneck, transposed-conv up blocks with added skip connections; its output
  keeps the hidden volume's shape, and E2V's 1x1x1 head turns it into one logit per voxel.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from e2vlib.model.config import GRID_SIDE, PRESETS, E2VConfig
from e2vlib.model.encoders import conv_layer, norm_layer

# --------------------------------------------------------------------------- bridge


class Bridge(nn.Module):
    """Encoder output ``(B, c, t, h, w)`` -> hidden volume ``(B, C, 32, 32, 32)``.

    See :class:`E2VConfig` for the three kinds.

    Examples
    --------
    >>> config = E2VConfig(input_shape=(16, 32, 32))  # bridge "fc": 4 channels from a 4^3 seed
    >>> Bridge(config, (64, 1, 1, 1))(torch.zeros(2, 64, 1, 1, 1)).shape
    torch.Size([2, 4, 32, 32, 32])
    >>> reshape = Bridge(E2VConfig(bridge="reshape"), (64, 4, 16, 8))  # 32768 values: C = 1
    >>> reshape.channels, reshape(torch.zeros(1, 64, 4, 16, 8)).shape
    (1, torch.Size([1, 1, 32, 32, 32]))

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, config: E2VConfig, encoder_shape: tuple[int, int, int, int]) -> None:
        super().__init__()
        self.kind = config.bridge
        n_in = math.prod(encoder_shape)
        r3 = GRID_SIDE**3
        if self.kind == "reshape":
            if n_in % r3:
                raise ValueError(
                    f"bridge='reshape' needs the encoder output {encoder_shape} "
                    f"({n_in} values) to be a multiple of {GRID_SIDE}^3 = {r3}; "
                    f"input_shape {config.input_shape} does not give that. Use an input whose "
                    f"encoder output fits (as the paper preset's {PRESETS['paper'].input_shape} "
                    "does), "
                    "or bridge='interp' / bridge='fc'."
                )
            self.channels = n_in // r3
        elif self.kind == "interp":
            self.channels = config.hidden_channels
            self.project = nn.Sequential(
                conv_layer(3, encoder_shape[0], self.channels, 1),
                norm_layer(config.norm, self.channels),
                nn.ReLU(inplace=True),
            )
        else:  # "fc"
            self.channels = config.hidden_channels
            self.seed_size = config.seed_size
            layers = [nn.Flatten(), nn.Dropout(config.dropout),
                      nn.Linear(n_in, self.channels * self.seed_size**3)]
            if config.bridge_norm:  # normalise the seed volume, then the ReLU
                self.seed_norm = nn.Sequential(norm_layer(config.norm, self.channels),
                                               nn.ReLU(inplace=True))
            else:  # the layout older checkpoints store
                layers.append(nn.ReLU(inplace=True))
            self.fc = nn.Sequential(*layers)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        b, size = z.shape[0], (GRID_SIDE,) * 3
        if self.kind == "reshape":
            return z.reshape(b, self.channels, *size)
        if self.kind == "interp":
            y = self.project(z)
        else:
            y = self.fc(z).view(b, self.channels, *(self.seed_size,) * 3)
            if hasattr(self, "seed_norm"):
                y = self.seed_norm(y)
        if tuple(y.shape[-3:]) == size:
            return y
        return F.interpolate(y, size=size, mode="trilinear", align_corners=False)


# --------------------------------------------------------------------------- decoder


class UNetDecoder(nn.Module):
    """Hidden volume ``(B, C, 32, 32, 32)`` -> features ``(B, C, 32, 32, 32)`` (Pix2Vox++-like).

    Down block i: max-pool 2 -> 3x3x3 conv -> norm -> LeakyReLU(0.2), halving the grid
    (32 -> 16 -> 8 -> 4 for three widths). Pooling before the conv (Pix2Vox++ convolves
    first) does 8x less work on the fine grid for the same parameters.
    Bottleneck at the coarsest grid: ``"fc"`` flattens (128 x 4^3 = 8192 in the paper
    preset), goes through ``bottleneck_features`` and back, and is added to its input, as
    the refiner does. Up block i: transposed conv (kernel 4, stride 2, padding 1; exactly
    doubles the grid) -> norm -> ReLU, then the down path's features of the same size are
    **added** (Pix2Vox++ skips; addition keeps widths small where a classic UNet concatenates).

    Examples
    --------
    Three down blocks (widths 16, 32, 64) take 32^3 to a 64 x 4^3 bottom and back:

    >>> decoder = UNetDecoder(4, E2VConfig(decoder_widths=(16, 32, 64))).eval()
    >>> decoder.bottom_shape, decoder(torch.zeros(1, 4, 32, 32, 32)).shape
    ((64, 4, 4, 4), torch.Size([1, 4, 32, 32, 32]))

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, channels: int, config: E2VConfig) -> None:
        super().__init__()
        widths = (channels, *config.decoder_widths)
        self.down = nn.ModuleList(
            nn.Sequential(
                nn.MaxPool3d(2),
                conv_layer(3, widths[i], widths[i + 1], 3),
                norm_layer(config.norm, widths[i + 1]),
                nn.LeakyReLU(0.2, inplace=True),
            )
            for i in range(len(widths) - 1)
        )
        side = GRID_SIDE // 2 ** (len(widths) - 1)
        self.bottom_shape = (widths[-1], side, side, side)
        n_bottom = math.prod(self.bottom_shape)
        if config.bottleneck == "fc":
            self.bottleneck: nn.Module = nn.Sequential(
                nn.Flatten(),
                nn.Dropout(config.dropout),
                nn.Linear(n_bottom, config.bottleneck_features),
                nn.ReLU(inplace=True),
                nn.Linear(config.bottleneck_features, n_bottom),
                nn.ReLU(inplace=True),
            )
        elif config.bottleneck == "conv":
            self.bottleneck = nn.Sequential(
                conv_layer(3, widths[-1], widths[-1], 3),
                norm_layer(config.norm, widths[-1]),
                nn.ReLU(inplace=True),
            )
        else:
            self.bottleneck = nn.Identity()
        self.up = nn.ModuleList(
            nn.Sequential(
                nn.ConvTranspose3d(widths[i + 1], widths[i], 4, stride=2, padding=1, bias=False),
                norm_layer(config.norm, widths[i]),
                nn.ReLU(inplace=True),
            )
            for i in reversed(range(len(widths) - 1))
        )

    def forward(self, h: torch.Tensor) -> torch.Tensor:
        skips = [h]
        for block in self.down:
            skips.append(block(skips[-1]))
        bottom = skips.pop()
        y = bottom + self.bottleneck(bottom).view(bottom.shape)
        for block in self.up:
            y = block(y) + skips.pop()
        return y
