"""The E2V network: a 3D ResNet encoder, a bridge to a 32^3 hidden volume, a UNet decoder.

E2V (Chen et al., ICVR 2023) treats a stack of ``D`` binary event frames as a 3D volume
``(D, H, W)`` and maps it to 32^3 occupancy logits in three parts:

1. **encoder** -- a ResNet whose 2D convolutions are all replaced by 3D ones (the paper
   uses ResNet-152), so a 3x3x3 kernel sees 3 consecutive frames of a 3x3 patch;
2. **bridge** -- brings the encoder's ``(c, d, h, w)`` output to a hidden volume
   ``(C, 32, 32, 32)``;
3. **decoder** -- a UNet-like 3D network inspired by the Pix2Vox++ refiner (3D conv down
   blocks, a bottleneck, transposed-conv up blocks with skip connections) ending in one
   logit per voxel.

Shapes: input ``(batch, D, H, W)`` float, output ``(batch, 32, 32, 32)`` logits indexed
``[b, x, y, z]``; probabilities are ``sigmoid(logits)``.

The paper gives the encoder, the hidden-volume idea, the decoder style and the total of
149,155,905 parameters, but not the decoder's widths; every choice made here is written
next to the code that makes it. Presets: ``"paper"`` (149.8 M parameters, input
100 x 256 x 256), ``"tiny"`` (2.8 M, input 100 x 64 x 64, trains on a laptop CPU) and
``"tiny2d"`` (tiny with a per-frame 2D encoder, the paper's suggested future work).

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

VOXEL_RESOLUTION = 32
"""Side of the output occupancy grid (the paper's 32^3)."""

PAPER_PARAMETERS = 149_155_905
"""Total parameter count the paper reports for E2V."""

RESNET_LAYERS: dict[int, tuple[str, tuple[int, int, int, int]]] = {
    10: ("basic", (1, 1, 1, 1)),
    18: ("basic", (2, 2, 2, 2)),
    34: ("basic", (3, 4, 6, 3)),
    50: ("bottleneck", (3, 4, 6, 3)),
    101: ("bottleneck", (3, 4, 23, 3)),
    152: ("bottleneck", (3, 8, 36, 3)),
}
"""ResNet depth -> (default block type, residual blocks per stage), as in He et al. 2016."""

ENCODERS = ("resnet3d", "frames2d")
BRIDGES = ("reshape", "interp", "fc")
BOTTLENECKS = ("fc", "conv", "none")
NORMS = ("batch", "group")


class CheckpointError(ValueError):
    """A checkpoint file cannot be read or does not describe an E2V model.

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """


# --------------------------------------------------------------------------- config


@dataclass(frozen=True)
class E2VConfig:
    """Everything needed to rebuild an :class:`E2V` (stored in checkpoints as a plain dict).

    - ``input_shape``: ``(D, H, W)`` = (frames, height, width) of one sample.
    - ``encoder``: ``"resnet3d"`` (the paper) or ``"frames2d"`` (a per-frame 2D CNN whose
      features are pooled over time, the paper's suggested future work).
    - ``depth``: ResNet depth, one of 10, 18, 34, 50, 101, 152; ``block``: ``"basic"``,
      ``"bottleneck"`` or ``"auto"`` (the standard block for that depth).
    - ``base_width``: channels of the stem and first stage (64 in ResNet); stage ``i`` has
      ``base_width * 2**i`` (times 4 at the output of a bottleneck block).
    - ``stem_kernel``/``stem_stride``/``stem_pool``: the first convolution (7/2 in ResNet)
      and whether the 3x3x3 stride-2 max-pool follows it.
    - ``bridge``: how the encoder output becomes a ``(C, 32, 32, 32)`` hidden volume:
      ``"reshape"`` (no parameters; C = number of encoder outputs / 32^3, so C follows
      from the input shape), ``"interp"`` (1x1x1 conv to ``hidden_channels``, then
      trilinear resize) or ``"fc"`` (a fully connected layer from the whole encoder output
      to a ``hidden_channels x seed_size^3`` seed, then trilinear resize: global context).
    - ``decoder_widths``: channels of the decoder's down blocks (each halves the grid).
    - ``bottleneck``: ``"fc"`` (two linear layers through ``bottleneck_features``, as in
      Pix2Vox++), ``"conv"`` (one 3x3x3 conv) or ``"none"``.
    - ``norm``: ``"batch"`` (BatchNorm) or ``"group"`` (GroupNorm, independent of batch size).
    - ``dropout``: dropout probability before the fully connected layers.

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    input_shape: tuple[int, int, int] = (100, 64, 64)
    encoder: str = "resnet3d"
    depth: int = 10
    block: str = "auto"
    base_width: int = 8
    stem_kernel: int = 3
    stem_stride: int = 2
    stem_pool: bool = True
    bridge: str = "fc"
    hidden_channels: int = 4
    seed_size: int = 4
    decoder_widths: tuple[int, ...] = (16, 32, 64)
    bottleneck: str = "fc"
    bottleneck_features: int = 256
    norm: str = "batch"
    dropout: float = 0.0

    def __post_init__(self) -> None:
        # Accept lists (a config read back from JSON or a checkpoint) and store tuples.
        object.__setattr__(self, "input_shape", tuple(int(v) for v in self.input_shape))
        object.__setattr__(self, "decoder_widths", tuple(int(v) for v in self.decoder_widths))
        problems = []
        if len(self.input_shape) != 3 or min(self.input_shape) < 1:
            problems.append(
                f"input_shape must be 3 positive ints (D, H, W), got {self.input_shape}"
            )
        _check_choice(problems, "encoder", self.encoder, ENCODERS)
        if self.depth not in RESNET_LAYERS:
            problems.append(f"depth must be one of {sorted(RESNET_LAYERS)}, got {self.depth}")
        _check_choice(problems, "block", self.block, ("auto", "basic", "bottleneck"))
        _check_choice(problems, "bridge", self.bridge, BRIDGES)
        _check_choice(problems, "bottleneck", self.bottleneck, BOTTLENECKS)
        _check_choice(problems, "norm", self.norm, NORMS)
        for name in ("base_width", "stem_kernel", "stem_stride", "hidden_channels", "seed_size",
                     "bottleneck_features"):
            if int(getattr(self, name)) < 1:
                problems.append(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.stem_kernel % 2 == 0:
            problems.append(f"stem_kernel must be odd (centred padding), got {self.stem_kernel}")
        if not self.decoder_widths or min(self.decoder_widths) < 1:
            problems.append(f"decoder_widths must be positive ints, got {self.decoder_widths}")
        elif VOXEL_RESOLUTION % 2 ** len(self.decoder_widths):
            problems.append(
                f"{len(self.decoder_widths)} decoder levels cannot halve a {VOXEL_RESOLUTION}^3 "
                "grid evenly; use at most 5 decoder_widths"
            )
        if VOXEL_RESOLUTION % self.seed_size:
            problems.append(f"seed_size must divide {VOXEL_RESOLUTION}, got {self.seed_size}")
        if not 0.0 <= self.dropout < 1.0:
            problems.append(f"dropout must be in [0, 1), got {self.dropout}")
        if problems:
            raise ValueError("invalid E2V config: " + "; ".join(problems))

    @property
    def block_type(self) -> str:
        """The residual block actually used (``"basic"`` or ``"bottleneck"``)."""
        return RESNET_LAYERS[self.depth][0] if self.block == "auto" else self.block

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python dict (lists, ints, strs) safe for ``torch.load(weights_only=True)``."""
        d = asdict(self)
        d["input_shape"] = list(self.input_shape)
        d["decoder_widths"] = list(self.decoder_widths)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> E2VConfig:
        """Rebuild a config from :meth:`to_dict`'s output; unknown keys raise ValueError."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"unknown E2V config keys {unknown}; valid keys: {sorted(known)}")
        return cls(**d)


def _check_choice(problems: list[str], name: str, value: object, choices: tuple) -> None:
    if value not in choices:
        problems.append(f"{name} must be one of {list(choices)}, got {value!r}")


PRESETS: dict[str, E2VConfig] = {
    # The paper: 3D ResNet-152 on 100 frames of 256 x 256.
    #  - bridge "reshape": the paper says the encoder yields a C x 32^3 hidden volume with C
    #    derived from the input shape. ResNet-152 turns 1 x 100 x 256 x 256 into
    #    2048 x 4 x 8 x 8 = 524,288 = 16 x 32^3 numbers, so C = 16 with no extra weights.
    #  - decoder: the Pix2Vox++ refiner's widths 32-64-128 and its 4^3 fully connected
    #    bottleneck (128 x 4^3 = 8192 features). Pix2Vox++ uses 2048 hidden features there,
    #    which would give 151.9 M parameters (+1.8 %); the paper does not publish its
    #    decoder, so we picked 1920 (= 15 x 128), which lands at +0.4 %.
    "paper": E2VConfig(
        input_shape=(100, 256, 256),
        depth=152,
        base_width=64,
        stem_kernel=7,
        stem_stride=2,
        stem_pool=True,
        bridge="reshape",
        decoder_widths=(32, 64, 128),
        bottleneck="fc",
        bottleneck_features=1920,
        norm="batch",
    ),
    # The same family shrunk to train in minutes on 2 CPU cores with data_small's
    # 100 x 64 x 64 frames: ResNet-10 with 8 base channels and a 3x3x3 stem (a 7x7x7 stem
    # does 13x the work per output position and would be the largest single cost at this
    # size). A prototype showed the step from image-and-time space to object space needs
    # global context, so the bridge is fully connected (whole encoder output -> 4 x 4^3
    # seed); 4 hidden channels keep the work on the 32^3 grid small.
    "tiny": E2VConfig(
        input_shape=(100, 64, 64),
        depth=10,
        base_width=8,
        stem_kernel=3,
        stem_stride=2,
        stem_pool=True,
        bridge="fc",
        hidden_channels=4,
        seed_size=4,
        decoder_widths=(16, 32, 64),
        bottleneck="fc",
        bottleneck_features=256,
        norm="batch",
    ),
}
# The paper's future-work alternative at tiny size: the same 2D ResNet-10 runs on every
# frame separately (weights shared over time) and time is only max-pooled into 4 bins, so
# the lesson can compare it with 3D convolutions that mix neighbouring frames from layer 1.
PRESETS["tiny2d"] = replace(PRESETS["tiny"], encoder="frames2d")
"""Named configurations for :func:`build_e2v`."""


# --------------------------------------------------------------------------- building blocks


def _norm(kind: str, channels: int, dim: int = 3) -> nn.Module:
    if kind == "group":
        # Up to 8 groups; gcd keeps the group count a divisor of the channel count.
        return nn.GroupNorm(math.gcd(channels, 8), channels)
    return nn.BatchNorm3d(channels) if dim == 3 else nn.BatchNorm2d(channels)


def _conv(dim: int, c_in: int, c_out: int, kernel: int, stride: int = 1) -> nn.Module:
    # No bias: a normalization layer always follows and would cancel it.
    conv = nn.Conv3d if dim == 3 else nn.Conv2d
    return conv(c_in, c_out, kernel, stride=stride, padding=kernel // 2, bias=False)


def _half(n: int) -> int:
    """Length after a kernel-3 (or 1), padding-1 (or 0), stride-2 conv or pool: ceil(n/2)."""
    return (n + 1) // 2


class BasicBlock(nn.Module):
    """Two 3x3(x3) convolutions with a residual shortcut (ResNet-10/18/34); ``dim`` 2 or 3.

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    expansion = 1

    def __init__(self, c_in: int, width: int, stride: int, norm: str, dim: int = 3) -> None:
        super().__init__()
        c_out = width * self.expansion
        self.conv1, self.bn1 = _conv(dim, c_in, width, 3, stride), _norm(norm, width, dim)
        self.conv2, self.bn2 = _conv(dim, width, c_out, 3), _norm(norm, c_out, dim)
        self.shortcut = _shortcut(c_in, c_out, stride, norm, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = F.relu(self.bn1(self.conv1(x)))
        y = self.bn2(self.conv2(y))
        return F.relu(y + self.shortcut(x))


class Bottleneck(nn.Module):
    """1x1 reduce, 3x3 (strided), 1x1 expand x4, with a residual shortcut (ResNet-50+).

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    expansion = 4

    def __init__(self, c_in: int, width: int, stride: int, norm: str, dim: int = 3) -> None:
        super().__init__()
        c_out = width * self.expansion
        self.conv1, self.bn1 = _conv(dim, c_in, width, 1), _norm(norm, width, dim)
        # Stride on the 3x3 conv (as torchvision's ResNet v1.5); the counts are the same.
        self.conv2, self.bn2 = _conv(dim, width, width, 3, stride), _norm(norm, width, dim)
        self.conv3, self.bn3 = _conv(dim, width, c_out, 1), _norm(norm, c_out, dim)
        self.shortcut = _shortcut(c_in, c_out, stride, norm, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = F.relu(self.bn1(self.conv1(x)))
        y = F.relu(self.bn2(self.conv2(y)))
        y = self.bn3(self.conv3(y))
        return F.relu(y + self.shortcut(x))


def _shortcut(c_in: int, c_out: int, stride: int, norm: str, dim: int) -> nn.Module:
    # ResNet "option B": a projection only where the shape changes, identity elsewhere.
    if stride == 1 and c_in == c_out:
        return nn.Identity()
    return nn.Sequential(_conv(dim, c_in, c_out, 1, stride), _norm(norm, c_out, dim))


class ResNetEncoder(nn.Module):
    """A ResNet trunk (no classifier) in 3D (the paper: every 2D op made 3D) or in 2D.

    3D: input ``(B, 1, D, H, W)``, output ``(B, out_channels, d, h, w)`` with each of
    d, h, w shrunk about 32x (16x without the stem pool). 2D: ``(N, 1, H, W)`` ->
    ``(N, out_channels, h, w)``. Stages: ``stem``, ``layer1`` .. ``layer4``.
    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, config: E2VConfig, dim: int = 3) -> None:
        super().__init__()
        block = BasicBlock if config.block_type == "basic" else Bottleneck
        n_blocks = RESNET_LAYERS[config.depth][1]
        w = config.base_width
        stem: list[nn.Module] = [
            _conv(dim, 1, w, config.stem_kernel, config.stem_stride),
            _norm(config.norm, w, dim),
            nn.ReLU(inplace=True),
        ]
        if config.stem_pool:
            pool = nn.MaxPool3d if dim == 3 else nn.MaxPool2d
            stem.append(pool(3, stride=2, padding=1))
        self.stem = nn.Sequential(*stem)
        c_in = w
        for i, n in enumerate(n_blocks):
            width = w * 2**i
            blocks = []
            for j in range(n):
                stride = 2 if (i > 0 and j == 0) else 1
                blocks.append(block(c_in, width, stride, config.norm, dim))
                c_in = width * block.expansion
            setattr(self, f"layer{i + 1}", nn.Sequential(*blocks))
        self.out_channels = c_in
        self.config = config

    def output_shape(self, input_shape: tuple[int, ...]) -> tuple[int, ...]:
        """``(channels, *spatial)`` of the output for one unbatched input (analytic)."""
        s = self.config.stem_stride
        dims = [(n - 1) // s + 1 for n in input_shape]  # odd kernel k, padding k // 2
        if self.config.stem_pool:
            dims = [_half(n) for n in dims]
        for _ in range(3):  # layer2..layer4 each halve (rounding up)
            dims = [_half(n) for n in dims]
        return (self.out_channels, *dims)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.stem(x)
        return self.layer4(self.layer3(self.layer2(self.layer1(x))))


class Frames2dEncoder(nn.Module):
    """Per-frame 2D ResNet shared over time, then max over time: ``(B, 1, D, H, W)`` in.

    The alternative the paper names as future work: each frame is encoded on its own by a
    2D ResNet (same depth/width options as the 3D one), and time is mixed only by max
    pooling the per-frame feature maps over ``time_bins`` groups of frames, giving
    ``(B, c, time_bins, h, w)``, shaped like the 3D encoder's output. Introduced in
    notebooks/05_the_e2v_model.ipynb.
    """

    time_bins = 4

    def __init__(self, config: E2VConfig) -> None:
        super().__init__()
        self.net = ResNetEncoder(config, dim=2)
        self.out_channels = self.net.out_channels

    def output_shape(self, input_shape: tuple[int, int, int]) -> tuple[int, int, int, int]:
        """``(channels, time_bins, h, w)`` of the output for one ``(D, H, W)`` input."""
        c, h, w = self.net.output_shape(input_shape[1:])
        return (c, min(self.time_bins, input_shape[0]), h, w)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, _, d, h, w = x.shape
        y = self.net(x.reshape(b * d, 1, h, w))  # (B*D, c, h', w'): frames as a batch
        y = y.reshape(b, d, *y.shape[1:]).transpose(1, 2)  # (B, c, D, h', w')
        return F.adaptive_max_pool3d(y, (min(self.time_bins, d), *y.shape[-2:]))


# --------------------------------------------------------------------------- bridge


class Bridge(nn.Module):
    """Encoder output ``(B, c, d, h, w)`` -> hidden volume ``(B, C, 32, 32, 32)``.

    See :class:`E2VConfig` for the three kinds. Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, config: E2VConfig, encoder_shape: tuple[int, int, int, int]) -> None:
        super().__init__()
        self.kind = config.bridge
        n_in = math.prod(encoder_shape)
        r3 = VOXEL_RESOLUTION**3
        if self.kind == "reshape":
            if n_in % r3:
                raise ValueError(
                    f"bridge='reshape' needs the encoder output {encoder_shape} "
                    f"({n_in} values) to be a multiple of {VOXEL_RESOLUTION}^3 = {r3}; "
                    f"input_shape {config.input_shape} does not give that. Use an input whose "
                    "encoder output fits (as the paper preset's (100, 256, 256) does), "
                    "or bridge='interp' / bridge='fc'."
                )
            self.channels = n_in // r3
        elif self.kind == "interp":
            self.channels = config.hidden_channels
            self.project = nn.Sequential(
                _conv(3, encoder_shape[0], self.channels, 1),
                _norm(config.norm, self.channels),
                nn.ReLU(inplace=True),
            )
        else:  # "fc"
            self.channels = config.hidden_channels
            self.seed_size = config.seed_size
            self.fc = nn.Sequential(
                nn.Flatten(),
                nn.Dropout(config.dropout),
                nn.Linear(n_in, self.channels * self.seed_size**3),
                nn.ReLU(inplace=True),
            )

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        b, size = z.shape[0], (VOXEL_RESOLUTION,) * 3
        if self.kind == "reshape":
            return z.reshape(b, self.channels, *size)
        if self.kind == "interp":
            y = self.project(z)
        else:
            y = self.fc(z).view(b, self.channels, *(self.seed_size,) * 3)
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
    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, channels: int, config: E2VConfig) -> None:
        super().__init__()
        widths = (channels, *config.decoder_widths)
        self.down = nn.ModuleList(
            nn.Sequential(
                nn.MaxPool3d(2),
                _conv(3, widths[i], widths[i + 1], 3),
                _norm(config.norm, widths[i + 1]),
                nn.LeakyReLU(0.2, inplace=True),
            )
            for i in range(len(widths) - 1)
        )
        side = VOXEL_RESOLUTION // 2 ** (len(widths) - 1)
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
                _conv(3, widths[-1], widths[-1], 3),
                _norm(config.norm, widths[-1]),
                nn.ReLU(inplace=True),
            )
        else:
            self.bottleneck = nn.Identity()
        self.up = nn.ModuleList(
            nn.Sequential(
                nn.ConvTranspose3d(widths[i + 1], widths[i], 4, stride=2, padding=1, bias=False),
                _norm(config.norm, widths[i]),
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


# --------------------------------------------------------------------------- the model


class E2V(nn.Module):
    """E2V: event frames ``(B, D, H, W)`` float -> occupancy logits ``(B, 32, 32, 32)``.

    Build with :func:`build_e2v` or ``E2V(E2VConfig(...))``. ``input_shape`` is the
    ``(D, H, W)`` every input must have; ``config`` the :class:`E2VConfig` it was built
    from. Sub-modules: ``encoder``, ``bridge``, ``decoder``, ``head`` (1x1x1 conv to one
    logit per voxel). Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, config: E2VConfig) -> None:
        super().__init__()
        self.config = config
        self.input_shape: tuple[int, int, int] = config.input_shape
        if config.encoder == "resnet3d":
            self.encoder: nn.Module = ResNetEncoder(config, dim=3)
        else:
            self.encoder = Frames2dEncoder(config)
        self.encoder_shape = self.encoder.output_shape(config.input_shape)
        if min(self.encoder_shape) < 1:
            raise ValueError(f"input_shape {config.input_shape} is too small for this encoder")
        self.bridge = Bridge(config, self.encoder_shape)
        self.hidden_channels = self.bridge.channels
        self.decoder = UNetDecoder(self.hidden_channels, config)
        self.head = nn.Conv3d(self.hidden_channels, 1, 1)
        self._init_weights()

    def _init_weights(self) -> None:
        for m in self.modules():
            if isinstance(m, nn.Conv3d | nn.Conv2d | nn.ConvTranspose3d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            elif isinstance(m, nn.BatchNorm3d | nn.BatchNorm2d | nn.GroupNorm):
                nn.init.ones_(m.weight)
                nn.init.zeros_(m.bias)
        nn.init.zeros_(self.head.bias)

    def check_input(self, x: torch.Tensor) -> None:
        """Raise ValueError unless ``x`` is a float tensor ``(batch, *input_shape)``."""
        want = "(batch, " + ", ".join(str(v) for v in self.input_shape) + ")"
        if not isinstance(x, torch.Tensor):
            raise ValueError(f"E2V expects a torch.Tensor {want}, got {type(x).__name__}; "
                             "convert with torch.as_tensor(x, dtype=torch.float32)")
        got = tuple(x.shape)
        if x.ndim == 3 and got == self.input_shape:
            raise ValueError(f"E2V expects a batch {want}, got one sample {got}; "
                             "add the batch axis with x.unsqueeze(0)")
        if x.ndim != 4 or got[1:] != self.input_shape:
            raise ValueError(
                f"E2V expects input shape {want} = (batch, frames, height, width), got {got}. "
                f"Give it frames of input_shape={self.input_shape}, the number of frames and "
                "resolution it was built for (e2vlib.frames.downsample lowers the resolution), "
                "or build a model for your shape with build_e2v(preset, input_shape=...)"
            )
        if not x.is_floating_point():
            raise ValueError(f"E2V expects a float tensor, got dtype {x.dtype}; use x.float()")

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``(B, D, H, W)`` float -> logits ``(B, 32, 32, 32)`` indexed ``[b, x, y, z]``."""
        self.check_input(x)
        z = self.encoder(x.unsqueeze(1))
        h = self.bridge(z)
        return self.head(self.decoder(h)).squeeze(1)


def build_e2v(preset: str = "tiny", seed: int | None = None, **overrides: Any) -> E2V:
    """Build an :class:`E2V` from a named preset, optionally changing config fields.

    ``preset``: ``"tiny"`` (input 100 x 64 x 64, 2.8 M parameters), ``"tiny2d"`` (the same
    with a per-frame 2D encoder) or ``"paper"`` (100 x 256 x 256, 149.8 M; build it under
    ``with torch.device("meta"):`` to inspect it without allocating 600 MB).
    ``overrides``: any :class:`E2VConfig` field, e.g. ``input_shape=(20, 64, 64)``.
    ``seed``: if given, weights are initialised from ``torch.manual_seed(seed)`` without
    touching the global random state.
    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose one of {sorted(PRESETS)}")
    valid = {f.name for f in fields(E2VConfig)}
    unknown = sorted(set(overrides) - valid)
    if unknown:
        raise ValueError(f"unknown E2V config fields {unknown}; valid fields: {sorted(valid)}")
    config = replace(PRESETS[preset], **overrides)
    if seed is None:
        return E2V(config)
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        return E2V(config)


# --------------------------------------------------------------------------- inspection


def count_parameters(model: nn.Module, trainable_only: bool = False) -> int:
    """Number of (trainable) parameters; works on the meta device.

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    return sum(p.numel() for p in model.parameters() if p.requires_grad or not trainable_only)


def parameter_breakdown(model: E2V) -> dict[str, int]:
    """Parameters per part: ``encoder``, ``bridge``, ``decoder``, ``head`` (and ``total``).

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    parts = {name: count_parameters(getattr(model, name))
             for name in ("encoder", "bridge", "decoder", "head")}
    parts["total"] = sum(parts.values())
    return parts


def _stages(model: E2V) -> list[tuple[str, nn.Module]]:
    enc = model.encoder
    if isinstance(enc, ResNetEncoder):
        stages = [("encoder.stem", enc.stem)] + [
            (f"encoder.layer{i}", getattr(enc, f"layer{i}")) for i in range(1, 5)
        ]
    else:
        stages = [("encoder", enc)]
    stages.append(("bridge", model.bridge))
    n = len(model.decoder.down)
    stages += [(f"decoder.down{i + 1}", b) for i, b in enumerate(model.decoder.down)]
    stages.append(("decoder.bottleneck", model.decoder.bottleneck))
    stages += [(f"decoder.up{n - i}", b) for i, b in enumerate(model.decoder.up)]
    stages.append(("head", model.head))
    return stages


def summary(model: E2V, batch_size: int = 1) -> list[dict[str, Any]]:
    """Stage-by-stage table of an E2V for a batch of ``batch_size`` inputs.

    One dict per stage, in forward order: ``name``, ``shape`` (output shape, batch axis
    included), ``params`` and ``saved_bytes`` (bytes of the activations autograd keeps
    inside that stage for the backward pass of a training step, weights excluded). Runs on
    a meta-device copy built from ``model.config``, so it allocates nothing and takes about
    a second even for the paper preset, whatever device ``model`` lives on.
    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    rows, _ = _profile(model, batch_size)
    return rows


def activation_bytes(model: E2V, batch_size: int = 1) -> int:
    """Bytes autograd saves for the backward pass in one training-mode forward pass.

    Measured, not guessed: every tensor the forward pass stores for backward is counted
    once per storage (views and in-place results are not double counted), on a meta-device
    copy; the weights themselves are left out. The result already includes ``batch_size``.
    Weights, their gradients and optimizer state come on top.
    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    _, total = _profile(model, batch_size)
    return total


def _profile(model: E2V, batch_size: int) -> tuple[list[dict[str, Any]], int]:
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    with torch.device("meta"):
        twin = E2V(model.config)
    # Eval mode: BatchNorm then saves the same input for backward as in training, but also
    # works for one sample whose deepest feature map is 1x1x1 (train-mode BN refuses that).
    twin.eval()
    rows: dict[str, dict[str, Any]] = {}
    current = ["input"]
    saved: dict[int, tuple[str, int]] = {}
    handles = []
    for name, stage in _stages(twin):
        rows[name] = {"name": name, "shape": None, "params": count_parameters(stage),
                      "saved_bytes": 0}

        def pre_hook(_m: nn.Module, _i: Any, name: str = name) -> None:
            current[0] = name

        def post_hook(_m: nn.Module, _i: Any, out: torch.Tensor, name: str = name) -> None:
            rows[name]["shape"] = tuple(out.shape)

        handles.append(stage.register_forward_pre_hook(pre_hook))
        handles.append(stage.register_forward_hook(post_hook))

    # Meta tensors have no addresses; the storage object's C++ handle identifies a storage
    # while the graph keeps it alive (views and in-place outputs share it). Weights that
    # autograd keeps a reference to are not activations, nor are per-channel statistics
    # (1-D): count only saved tensors with a batch axis.
    weights = {p.untyped_storage()._cdata for p in twin.parameters()}

    def pack(t: torch.Tensor) -> torch.Tensor:
        key = t.untyped_storage()._cdata
        if t.ndim >= 2 and key not in saved and key not in weights:
            saved[key] = (current[0], t.untyped_storage().nbytes())
        return t

    try:
        with torch.autograd.graph.saved_tensors_hooks(pack, lambda t: t):
            out = twin(torch.empty(batch_size, *twin.input_shape, device="meta"))
    finally:
        for handle in handles:
            handle.remove()
    del out
    for stage_name, nbytes in saved.values():
        if stage_name in rows:
            rows[stage_name]["saved_bytes"] += nbytes
    return list(rows.values()), sum(nbytes for _, nbytes in saved.values())


def format_summary(rows: list[dict[str, Any]]) -> str:
    """Render :func:`summary` rows as a fixed-width text table with a total line.

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    lines = [f"{'stage':<20} {'output shape':<28} {'params':>13} {'saved MiB':>10}"]
    for r in rows:
        lines.append(f"{r['name']:<20} {str(r['shape']):<28} {r['params']:>13,} "
                     f"{r['saved_bytes'] / 2**20:>10.1f}")
    total_p = sum(r["params"] for r in rows)
    total_b = sum(r["saved_bytes"] for r in rows)
    lines.append(f"{'total':<20} {'':<28} {total_p:>13,} {total_b / 2**20:>10.1f}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- checkpoints


def save_checkpoint(path: str | os.PathLike, model: E2V, **extra: Any) -> Path:
    """Write ``{"config": dict, "model": state_dict, **extra}`` to ``path`` atomically.

    The file is written next to ``path`` under a temporary name and then renamed, so an
    existing checkpoint is never left half-written. ``extra`` may hold anything
    ``torch.load(weights_only=True)`` reads back (tensors, numbers, strings, lists, dicts:
    e.g. an optimizer state_dict, the epoch). Returns the path.
    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    model = getattr(model, "module", model)  # unwrap DistributedDataParallel/DataParallel
    if not isinstance(model, E2V):
        raise ValueError(f"save_checkpoint stores E2V models, got {type(model).__name__}; "
                         "save other modules with torch.save(module.state_dict(), path)")
    clash = {"config", "model"} & set(extra)
    if clash:
        raise ValueError(f"extra keys {sorted(clash)} are reserved for the model; rename them")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {"config": model.config.to_dict(), "model": model.state_dict(), **extra}
    _write_payload(path, payload)
    return path


def read_checkpoint(path: str | os.PathLike, map_location: str | torch.device = "cpu") -> dict:
    """Load and check a checkpoint dict (``"config"``, ``"model"`` and any extra keys).

    Uses ``torch.load(weights_only=True)``: no arbitrary code runs. Raises
    FileNotFoundError if the file is missing and :class:`CheckpointError` (a ValueError)
    naming the file if it is corrupted or lacks the keys. Introduced in
    notebooks/05_the_e2v_model.ipynb.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {path} does not exist; train one first "
                                "(python -m e2vlib train ... writes OUT/best.pt) or fix the path")
    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
    except Exception as err:  # zip/pickle errors come in many types
        raise CheckpointError(
            f"cannot read checkpoint {path}: it is corrupted, truncated or not a torch file "
            f"({type(err).__name__}: {str(err)[:200]}). Re-create it with save_checkpoint."
        ) from err
    if not isinstance(ckpt, dict) or not {"config", "model"} <= set(ckpt):
        keys = sorted(ckpt) if isinstance(ckpt, dict) else type(ckpt).__name__
        raise CheckpointError(f"checkpoint {path} must be a dict with 'config' and 'model' "
                              f"keys (as written by save_checkpoint), got {keys}")
    return ckpt


def load_checkpoint(path: str | os.PathLike, map_location: str | torch.device = "cpu") -> E2V:
    """Rebuild the :class:`E2V` stored at ``path`` (its config + weights), in eval mode.

    Accepts any dict holding ``"config"`` and ``"model"`` (extra keys such as optimizer
    state are ignored; use :func:`read_checkpoint` to get them). Errors as in
    :func:`read_checkpoint`. Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    return model_from_checkpoint(read_checkpoint(path, map_location), map_location,
                                 f"checkpoint {path}")


def model_from_checkpoint(ckpt: dict, map_location: str | torch.device = "cpu",
                          source: object = "checkpoint") -> E2V:
    """Rebuild the :class:`E2V` of a dict from :func:`read_checkpoint`, in eval mode.

    For callers that also need the checkpoint's other entries (metadata, history)
    without reading the file twice. Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    try:
        model = E2V(E2VConfig.from_dict(dict(ckpt["config"])))
        model.load_state_dict(ckpt["model"])
    except (ValueError, TypeError, RuntimeError) as err:
        raise CheckpointError(f"{source} does not match an E2V model: {err}") from err
    return model.to(map_location).eval()


def slim_checkpoint(src: str | os.PathLike, dst: str | os.PathLike, half: bool = True,
                    keep: tuple[str, ...] = ("history", "metadata", "recipe", "epoch",
                                             "best_iou", "seed")) -> Path:
    """Copy a training checkpoint without its optimizer state, for shipping.

    Keeps the config, the weights (as float16 when ``half``: ``load_checkpoint`` casts
    them back to float32) and the ``keep`` entries. The committed
    ``data_small/checkpoints/tiny.pt`` was made this way. Introduced in
    notebooks/06_training.ipynb.
    """
    ckpt = read_checkpoint(src)
    state = {k: v.half() if half and v.is_floating_point() else v
             for k, v in ckpt["model"].items()}
    config = E2VConfig.from_dict(dict(ckpt["config"]))  # validates the stored config
    extra = {k: ckpt[k] for k in keep if k in ckpt}
    path = Path(dst)
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_payload(path, {"config": config.to_dict(), "model": state, **extra})
    return path


def _write_payload(path: Path, payload: dict) -> None:
    """``torch.save`` to a temporary name next to ``path``, then rename over it."""
    from e2vlib.files import atomic_path

    with atomic_path(path) as tmp:
        torch.save(payload, tmp)
