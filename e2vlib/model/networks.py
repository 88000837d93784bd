"""The E2V network: configuration, building blocks, encoders, bridge, decoder, presets.

E2V (Chen et al., ICVR 2023) treats a stack of ``n_frames`` binary event frames as one 3D
volume ``(n_frames, H, W)`` (the first axis is the frame axis, i.e. time) and maps it to
32^3 occupancy logits in three parts:

1. **encoder** -- a ResNet whose 2D convolutions are all replaced by 3D ones (the paper
   uses ResNet-152), so a 3x3x3 kernel sees 3 consecutive frames of a 3x3 patch
   (``"resnet3d"``). Two alternatives the paper names as future work use a 2D ResNet on
   every frame separately (weights shared over time) and mix time afterwards: by max
   pooling the frames' feature maps into a few time bins (``"frames2d"``,
   :class:`Frames2dEncoder`), or with a GRU that reads one feature vector per frame in time
   order (``"frames2d_gru"``, :class:`Frames2dGRUEncoder`: the paper's "LSTM or GRU
   variants");
2. **bridge** -- brings the encoder's ``(c, t, h, w)`` output (``t``: the frame axis after
   striding) to a hidden volume ``(C, 32, 32, 32)``;
3. **decoder** -- a UNet-like 3D network inspired by the Pix2Vox++ refiner (3D conv down
   blocks, a bottleneck, transposed-conv up blocks with skip connections) ending in one
   logit per voxel.

Shapes: input ``(batch, n_frames, H, W)`` float, output ``(batch, 32, 32, 32)`` logits
indexed ``[b, x, y, z]``; probabilities are ``sigmoid(logits)``. ``E2V.input_shape`` is
the ``(D, H, W)`` of the design note with ``D = n_frames``. Inputs of several channels
per pixel and time step (``in_channels = C > 1``, e.g. the OFF and ON counts of the
``polarity`` representation) are ``(batch, C, n_frames, H, W)`` and enter the same network
with only its first convolution widened to ``C`` input channels; ``E2V.sample_shape`` is
``(C, D, H, W)`` then (``(D, H, W)`` for one channel). Two different "depths" appear
here and must not be confused: the frame axis (time, ``n_frames`` long) and the ResNet
depth (number of layers, :attr:`E2VConfig.depth`, alias :attr:`E2VConfig.resnet_depth`).

The paper gives the encoder, the hidden-volume idea, the decoder style and the total of
:data:`e2vlib.paper.N_PARAMETERS` parameters, but not the decoder's widths; every choice
made here is written next to the code that makes it. Presets: ``"paper"`` (149.8 M
parameters, input 100 x 256 x 256), ``"tiny"`` (2.8 M, input 100 x 64 x 64, trains on a
laptop CPU), and two of the paper's suggested future-work encoders at tiny size:
``"tiny2d"`` (per-frame 2D CNN, temporal max pooling; 2.7 M) and ``"tiny_gru"`` (per-frame
2D CNN + GRU; 2.7 M).

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from e2vlib import paper

GRID_SIDE = paper.GRID_SIDE
"""Side of the output occupancy grid (the paper's 32^3)."""

VOXEL_RESOLUTION = GRID_SIDE
"""Older name of :data:`GRID_SIDE`, kept for callers that import it."""

PAPER_PARAMETERS = paper.N_PARAMETERS
"""Total parameter count the paper reports for E2V (:data:`e2vlib.paper.N_PARAMETERS`)."""

RESNET_LAYERS: dict[int, tuple[str, tuple[int, int, int, int]]] = {
    10: ("basic", (1, 1, 1, 1)),
    18: ("basic", (2, 2, 2, 2)),
    34: ("basic", (3, 4, 6, 3)),
    50: ("bottleneck", (3, 4, 6, 3)),
    101: ("bottleneck", (3, 4, 23, 3)),
    152: ("bottleneck", (3, 8, 36, 3)),
}
"""ResNet depth -> (default block type, residual blocks per stage), as in He et al. 2016."""

ENCODERS = ("resnet3d", "frames2d", "frames2d_gru")
BRIDGES = ("reshape", "interp", "fc")
BOTTLENECKS = ("fc", "conv", "none")
NORMS = ("batch", "group")


# --------------------------------------------------------------------------- config


@dataclass(frozen=True)
class E2VConfig:
    """Everything needed to rebuild an :class:`E2V` (stored in checkpoints as a plain dict).

    - ``input_shape``: ``(n_frames, height, width)`` of one sample; the first axis is the
      frame axis (time), the ``D`` of the design note's ``(D, H, W)``.
    - ``encoder``: ``"resnet3d"`` (the paper), ``"frames2d"`` (a per-frame 2D CNN whose
      feature maps are max-pooled over time) or ``"frames2d_gru"`` (the same per-frame 2D
      CNN, each frame's feature map average-pooled to ``gru_pool x gru_pool`` and
      flattened into one vector, read in time order by a one-layer GRU of ``gru_hidden``
      units whose final hidden state goes to the bridge); the last two are the paper's
      suggested future work.
    - ``depth``: the **ResNet depth** (number of layers: 10, 18, 34, 50, 101 or 152), not
      the frame axis; also readable as :attr:`resnet_depth`. ``block``: ``"basic"``,
      ``"bottleneck"`` or ``"auto"`` (the standard block for that ResNet depth).
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
    - ``in_channels``: values per pixel and time step of the input (1: binary or count
      frames, input ``(B, n_frames, H, W)``; 2: the polarity representation's OFF and ON
      counts, input ``(B, 2, n_frames, H, W)``). Only the first convolution depends on it
      (``in_channels`` times its weights); everything else is unchanged.
    - ``gru_hidden``, ``gru_pool``: hidden units of the GRU and side of the average pool of
      each frame's 2D feature map (1: global average pool, ``c`` features per frame;
      2: a 2x2 pool flattened, ``4c``); used by ``encoder="frames2d_gru"`` only. With
      another encoder they are stored as their defaults whatever is given, so two configs
      are equal exactly when they build the same network.

    The field is called ``depth`` because checkpoints store it under that key; old
    checkpoints keep loading. :meth:`from_dict` also accepts ``resnet_depth``. Fields added
    later (``in_channels``, ``gru_hidden``, ``gru_pool``) take their defaults when a stored
    config lacks them, so older checkpoints load as one-channel models.

    Examples
    --------
    >>> config = E2VConfig(input_shape=(20, 32, 32), depth=18)
    >>> config.resnet_depth, config.n_frames, config.block_type
    (18, 20, 'basic')
    >>> E2VConfig.from_dict(config.to_dict()) == config
    True

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    input_shape: tuple[int, int, int] = (
        paper.N_EVENT_FRAMES, paper.FRAME_SIZE_PX, paper.FRAME_SIZE_PX)
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
    in_channels: int = 1
    gru_hidden: int = 256
    gru_pool: int = 1

    def __post_init__(self) -> None:
        # Accept lists (a config read back from JSON or a checkpoint) and store tuples.
        object.__setattr__(self, "input_shape", tuple(int(v) for v in self.input_shape))
        object.__setattr__(self, "decoder_widths", tuple(int(v) for v in self.decoder_widths))
        if self.encoder != "frames2d_gru":  # unused: keep the defaults (see the docstring)
            for f in fields(self):
                if f.name in _GRU_FIELDS:
                    object.__setattr__(self, f.name, f.default)
        problems = []
        if len(self.input_shape) != 3 or min(self.input_shape) < 1:
            problems.append(
                "input_shape must be 3 positive ints (n_frames, height, width), "
                f"got {self.input_shape}"
            )
        _check_choice(problems, "encoder", self.encoder, ENCODERS)
        if self.depth not in RESNET_LAYERS:
            problems.append(f"depth must be one of {sorted(RESNET_LAYERS)} (the ResNet depth, "
                            f"not the frame axis), got {self.depth}")
        _check_choice(problems, "block", self.block, ("auto", "basic", "bottleneck"))
        _check_choice(problems, "bridge", self.bridge, BRIDGES)
        _check_choice(problems, "bottleneck", self.bottleneck, BOTTLENECKS)
        _check_choice(problems, "norm", self.norm, NORMS)
        for name in ("base_width", "stem_kernel", "stem_stride", "hidden_channels", "seed_size",
                     "bottleneck_features", "in_channels", "gru_hidden", "gru_pool"):
            if int(getattr(self, name)) < 1:
                problems.append(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.stem_kernel % 2 == 0:
            problems.append(f"stem_kernel must be odd (centred padding), got {self.stem_kernel}")
        if not self.decoder_widths or min(self.decoder_widths) < 1:
            problems.append(f"decoder_widths must be positive ints, got {self.decoder_widths}")
        elif GRID_SIDE % 2 ** len(self.decoder_widths):
            problems.append(
                f"{len(self.decoder_widths)} decoder levels cannot halve a {GRID_SIDE}^3 "
                "grid evenly; use at most 5 decoder_widths"
            )
        if GRID_SIDE % self.seed_size:
            problems.append(f"seed_size must divide {GRID_SIDE}, got {self.seed_size}")
        if not 0.0 <= self.dropout < 1.0:
            problems.append(f"dropout must be in [0, 1), got {self.dropout}")
        if problems:
            raise ValueError("invalid E2V config: " + "; ".join(problems))

    @property
    def resnet_depth(self) -> int:
        """The ResNet depth (number of layers), the same as :attr:`depth`."""
        return self.depth

    @property
    def n_frames(self) -> int:
        """Length of the frame axis (time) of the input, ``input_shape[0]``."""
        return self.input_shape[0]

    @property
    def sample_shape(self) -> tuple[int, ...]:
        """Shape of one input sample: ``input_shape``, with ``in_channels`` first if > 1."""
        if self.in_channels == 1:
            return self.input_shape
        return (self.in_channels, *self.input_shape)

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
        """Rebuild a config from :meth:`to_dict`'s output; unknown keys raise ValueError.

        ``resnet_depth`` is accepted as another name for ``depth``.
        """
        d = _resnet_depth_alias(dict(d), "E2V config")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"unknown E2V config keys {unknown}; valid keys: {sorted(known)}")
        return cls(**d)


_GRU_FIELDS = ("gru_hidden", "gru_pool")
"""Fields only ``encoder="frames2d_gru"`` uses."""


def _check_choice(problems: list[str], name: str, value: object, choices: tuple) -> None:
    if value not in choices:
        problems.append(f"{name} must be one of {list(choices)}, got {value!r}")


def _resnet_depth_alias(d: dict[str, Any], what: str) -> dict[str, Any]:
    """Rename a ``resnet_depth`` key to the stored field name ``depth``."""
    if "resnet_depth" in d:
        if "depth" in d and d["depth"] != d["resnet_depth"]:
            raise ValueError(f"{what}: depth={d['depth']} and resnet_depth={d['resnet_depth']} "
                             "name the same field; give only one")
        d["depth"] = d.pop("resnet_depth")
    return d


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
        input_shape=(paper.N_EVENT_FRAMES, paper.INPUT_SIZE_PX, paper.INPUT_SIZE_PX),
        depth=paper.RESNET_DEPTH,
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
        input_shape=(paper.N_EVENT_FRAMES, paper.FRAME_SIZE_PX, paper.FRAME_SIZE_PX),
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
# The paper's "LSTM or GRU variants" at tiny size: the same per-frame 2D ResNet-10; each
# frame's 64 x 2 x 2 feature map (at 64 x 64 px) is globally average-pooled into 64
# features, a GRU of 256 units reads the 100 vectors in time order, and its final state
# goes through the same fully connected bridge (256 -> 4 x 4^3). In a quick check (one
# seed, 8 training samples per category, 6 epochs of the tiny recipe) this learned (train
# BCE 0.76 -> 0.27, val IoU@0.3 up to 0.14) while a 2x2 pool (256 features, gru_pool=2)
# stayed at the trivial solution (train BCE ~0.70, val IoU 0.099 throughout).
# 2.73 M parameters, 0.97x tiny's.
PRESETS["tiny_gru"] = replace(PRESETS["tiny"], encoder="frames2d_gru", gru_hidden=256,
                              gru_pool=1)
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

    3D: input ``(B, C, n_frames, H, W)``, output ``(B, out_channels, t, h, w)`` with each
    of t (the frame axis), h, w shrunk about 32x (16x without the stem pool). 2D:
    ``(N, C, H, W)`` -> ``(N, out_channels, h, w)``. ``C`` is ``config.in_channels``: only
    the stem's convolution depends on it. Stages: ``stem``, ``layer1`` .. ``layer4``.
    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, config: E2VConfig, dim: int = 3) -> None:
        super().__init__()
        block = BasicBlock if config.block_type == "basic" else Bottleneck
        n_blocks = RESNET_LAYERS[config.depth][1]
        w = config.base_width
        stem: list[nn.Module] = [
            _conv(dim, config.in_channels, w, config.stem_kernel, config.stem_stride),
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


def _per_frame(net: nn.Module, x: torch.Tensor) -> torch.Tensor:
    """Run a 2D ``net`` on every frame of ``x`` ``(B, C, n_frames, H, W)``.

    Returns ``(B, n_frames, c, h, w)``: every frame is one item of the 2D network's batch.
    """
    b, c, n_frames, h, w = x.shape
    y = net(x.transpose(1, 2).reshape(b * n_frames, c, h, w))
    return y.reshape(b, n_frames, *y.shape[1:])


class Frames2dEncoder(nn.Module):
    """Per-frame 2D ResNet shared over time, then max over time: ``(B, C, n_frames, H, W)`` in.

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
        """``(channels, time_bins, h, w)`` of the output for one ``(n_frames, H, W)`` input."""
        c, h, w = self.net.output_shape(input_shape[1:])
        return (c, min(self.time_bins, input_shape[0]), h, w)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        n_frames = x.shape[2]
        y = _per_frame(self.net, x).transpose(1, 2)  # (B, c, n_frames, h', w')
        return F.adaptive_max_pool3d(y, (min(self.time_bins, n_frames), *y.shape[-2:]))


class Frames2dGRUEncoder(nn.Module):
    """Per-frame 2D ResNet shared over time, then a GRU over time: ``(B, C, n_frames, H, W)`` in.

    The paper's suggested "LSTM or GRU variants": each frame is encoded on its own by the
    2D ResNet of :class:`Frames2dEncoder`; its feature map ``(c, h, w)`` is average-pooled
    to ``gru_pool x gru_pool`` and flattened into ``features = c * gru_pool**2`` numbers; a
    one-layer GRU with ``gru_hidden`` units reads these vectors in time order (frame 0
    first), and its final hidden state is the output, ``(B, gru_hidden, 1, 1, 1)`` (shaped
    like the other encoders' ``(B, c, t, h, w)`` for the bridge). Time is mixed only by the
    recurrence, so the order of the frames matters, unlike max pooling.
    Introduced in notebooks/10_architectures_and_losses.ipynb.
    """

    def __init__(self, config: E2VConfig) -> None:
        super().__init__()
        self.net = ResNetEncoder(config, dim=2)
        self.pool = config.gru_pool
        self.features = self.net.out_channels * self.pool**2
        self.gru = nn.GRU(self.features, config.gru_hidden, num_layers=1, batch_first=True)
        self.out_channels = config.gru_hidden

    def output_shape(self, input_shape: tuple[int, int, int]) -> tuple[int, int, int, int]:
        """``(gru_hidden, 1, 1, 1)``: the final hidden state, for any ``(n_frames, H, W)``."""
        return (self.out_channels, 1, 1, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = _per_frame(self.net, x)  # (B, n_frames, c, h', w')
        b, n_frames = y.shape[:2]
        y = F.adaptive_avg_pool2d(y.flatten(0, 1), self.pool).reshape(b, n_frames, -1)
        _, last = self.gru(y)  # last: (num_layers = 1, B, gru_hidden)
        return last[-1].reshape(b, self.out_channels, 1, 1, 1)


# --------------------------------------------------------------------------- bridge


class Bridge(nn.Module):
    """Encoder output ``(B, c, t, h, w)`` -> hidden volume ``(B, C, 32, 32, 32)``.

    See :class:`E2VConfig` for the three kinds. Introduced in notebooks/05_the_e2v_model.ipynb.
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
        b, size = z.shape[0], (GRID_SIDE,) * 3
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
    """E2V: event frames ``(B, n_frames, H, W)`` float -> occupancy logits ``(B, 32, 32, 32)``.

    Build with :func:`build_e2v` or ``E2V(E2VConfig(...))``. ``input_shape`` is the
    ``(D, H, W)`` = ``(n_frames, height, width)`` every input must have (``D`` is the frame
    axis, time; the ResNet depth is ``config.resnet_depth``); ``config`` the
    :class:`E2VConfig` it was built from. With ``in_channels = C > 1`` inputs are
    ``(B, C, n_frames, H, W)``; ``sample_shape`` is the shape of one sample either way.
    Sub-modules: ``encoder``, ``bridge``, ``decoder``, ``head`` (1x1x1 conv to one logit
    per voxel).

    Examples
    --------
    >>> model = E2V(E2VConfig(input_shape=(16, 32, 32)))
    >>> model.input_shape, model.n_frames
    ((16, 32, 32), 16)
    >>> model.eval()(torch.zeros(1, 16, 32, 32)).shape
    torch.Size([1, 32, 32, 32])
    >>> two = E2V(E2VConfig(input_shape=(16, 32, 32), in_channels=2))  # e.g. OFF and ON
    >>> two.sample_shape, two.eval()(torch.zeros(1, 2, 16, 32, 32)).shape
    ((2, 16, 32, 32), torch.Size([1, 32, 32, 32]))

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, config: E2VConfig) -> None:
        super().__init__()
        self.config = config
        self.input_shape: tuple[int, int, int] = config.input_shape
        self.in_channels: int = config.in_channels
        if config.encoder == "resnet3d":
            self.encoder: nn.Module = ResNetEncoder(config, dim=3)
        elif config.encoder == "frames2d":
            self.encoder = Frames2dEncoder(config)
        else:
            self.encoder = Frames2dGRUEncoder(config)
        self.encoder_shape = self.encoder.output_shape(config.input_shape)
        if min(self.encoder_shape) < 1:
            raise ValueError(f"input_shape {config.input_shape} is too small for this encoder")
        self.bridge = Bridge(config, self.encoder_shape)
        self.hidden_channels = self.bridge.channels
        self.decoder = UNetDecoder(self.hidden_channels, config)
        self.head = nn.Conv3d(self.hidden_channels, 1, 1)
        self._init_weights()

    @property
    def n_frames(self) -> int:
        """Length of the frame axis (time) of the input, ``input_shape[0]``."""
        return self.input_shape[0]

    @property
    def sample_shape(self) -> tuple[int, ...]:
        """Shape of one input sample: ``input_shape``, or ``(in_channels, *input_shape)``."""
        return self.config.sample_shape

    def _init_weights(self) -> None:
        for m in self.modules():
            if isinstance(m, nn.Conv3d | nn.Conv2d | nn.ConvTranspose3d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            elif isinstance(m, nn.BatchNorm3d | nn.BatchNorm2d | nn.GroupNorm):
                nn.init.ones_(m.weight)
                nn.init.zeros_(m.bias)
        nn.init.zeros_(self.head.bias)

    def check_input(self, x: torch.Tensor) -> None:
        """Raise ValueError unless ``x`` is a float tensor ``(batch, *sample_shape)``.

        The message names the expected and the given shape, and how to fix the mismatch.
        """
        shape = self.sample_shape
        want = "(batch, " + ", ".join(str(v) for v in shape) + ")"
        if not isinstance(x, torch.Tensor):
            raise ValueError(f"E2V expects a torch.Tensor {want}, got {type(x).__name__}; "
                             "convert with torch.as_tensor(x, dtype=torch.float32)")
        got = tuple(x.shape)
        if x.ndim == len(shape) and got == shape:
            also = ("" if self.in_channels == 1 else
                    f" (if these are {got[0]} one-channel samples instead: this model was "
                    f"built for {self.in_channels} input channels, in_channels="
                    f"{self.in_channels})")
            raise ValueError(f"E2V expects a batch {want}, got one sample {got}; "
                             f"add the batch axis with x.unsqueeze(0){also}")
        if x.ndim != len(shape) + 1 or got[1:] != shape:
            c = self.in_channels
            axes = ("(batch, n_frames, height, width)" if c == 1
                    else "(batch, channels, n_frames, height, width)")
            if c == 1 and x.ndim == 5:
                channels = (f" This model takes one channel (in_channels=1, no channel "
                            f"axis); for inputs of {got[1]} channels build one with "
                            f"in_channels={got[1]}.")
            elif c > 1 and (x.ndim == 4 or got[1] != c):
                channels = (f" This model was built for {c} input channels "
                            f"(in_channels={c}), given as the axis after the batch.")
            else:
                channels = ""
            raise ValueError(
                f"E2V expects input shape {want} = {axes}, got {got}.{channels} Give it "
                f"frames of input_shape={self.input_shape}, the number of frames (the frame "
                "axis, time) and "
                "resolution it was built for (e2vlib.frames.downsample lowers the resolution), "
                "or build a model for your shape with build_e2v(preset, input_shape=..., "
                "in_channels=...)"
            )
        if not x.is_floating_point():
            raise ValueError(f"E2V expects a float tensor, got dtype {x.dtype}; use x.float()")

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``(B, n_frames, H, W)`` (or ``(B, C, n_frames, H, W)`` for ``in_channels`` C > 1)
        float -> logits ``(B, 32, 32, 32)`` indexed ``[b, x, y, z]``."""
        self.check_input(x)
        z = self.encoder(x.unsqueeze(1) if self.in_channels == 1 else x)
        h = self.bridge(z)
        return self.head(self.decoder(h)).squeeze(1)


def build_e2v(preset: str = "tiny", seed: int | None = None, **overrides: Any) -> E2V:
    """Build an :class:`E2V` from a named preset, optionally changing config fields.

    Parameters
    ----------
    preset
        ``"tiny"`` (input 100 x 64 x 64, 2.8 M parameters), ``"tiny2d"`` (the same with a
        per-frame 2D encoder and temporal max pooling, 2.7 M), ``"tiny_gru"`` (per-frame
        2D encoder and a GRU over time, 2.7 M) or ``"paper"`` (100 x 256 x 256, 149.8 M;
        build it under ``with torch.device("meta"):`` to inspect it without allocating
        600 MB).
    seed
        If given, weights are initialised from ``torch.manual_seed(seed)`` without
        touching the global random state.
    **overrides
        Any :class:`E2VConfig` field, e.g. ``input_shape=(20, 64, 64)`` (``(n_frames,
        height, width)``) or ``in_channels=2`` (inputs ``(B, 2, n_frames, H, W)``);
        ``resnet_depth=`` is accepted for ``depth=``.

    Returns
    -------
    E2V
        A new model in training mode, on the current default device.

    Examples
    --------
    >>> model = build_e2v("tiny", seed=0)
    >>> model.input_shape
    (100, 64, 64)
    >>> count_parameters(model)
    2827829
    >>> small = build_e2v("tiny", input_shape=(20, 32, 32), resnet_depth=18)
    >>> small.config.resnet_depth, small(torch.zeros(2, 20, 32, 32)).shape
    (18, torch.Size([2, 32, 32, 32]))
    >>> gru = build_e2v("tiny_gru", input_shape=(20, 32, 32), seed=0)
    >>> gru.encoder_shape, gru(torch.zeros(2, 20, 32, 32)).shape
    ((256, 1, 1, 1), torch.Size([2, 32, 32, 32]))

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose one of {sorted(PRESETS)}")
    overrides = _resnet_depth_alias(dict(overrides), "build_e2v")
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


def count_parameters(model: nn.Module, trainable_only: bool = False) -> int:
    """Number of parameters of ``model`` (only those with ``requires_grad`` if asked).

    Works on the meta device (shapes only), so the paper preset can be counted without
    allocating its weights.

    Examples
    --------
    >>> layer = torch.nn.Linear(3, 2)  # 3 x 2 weights + 2 biases
    >>> count_parameters(layer)
    8
    >>> _ = layer.bias.requires_grad_(False)  # freeze the biases
    >>> count_parameters(layer, trainable_only=True)
    6

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    return sum(p.numel() for p in model.parameters() if p.requires_grad or not trainable_only)
