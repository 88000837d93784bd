"""E2V's encoders: ResNet trunks in 3D (the paper) or per frame in 2D, and their blocks.

- :class:`ResNetEncoder`: a ResNet without its classifier, every convolution 3D (``dim=3``,
  the paper's encoder: a 3x3x3 kernel sees 3 consecutive frames of a 3x3 patch) or 2D
  (``dim=2``, used per frame by the two encoders below); built from :class:`BasicBlock`
  (ResNet-10/18/34) or :class:`Bottleneck` (ResNet-50/101/152) residual blocks.
- :class:`Frames2dEncoder` (``encoder="frames2d"``): the 2D trunk on every frame (weights
  shared over time), the frames' feature maps max-pooled into a few time bins.
- :class:`Frames2dGRUEncoder` (``encoder="frames2d_gru"``): the same per-frame trunk, one
  feature vector per frame read in time order by a GRU (the paper's "LSTM or GRU
  variants").

Every encoder maps ``(B, C, n_frames, H, W)`` to ``(B, c, t, h, w)`` (its
``output_shape`` gives ``(c, t, h, w)`` without running it), the input of
:class:`~e2vlib.model.decoder.Bridge`. The helpers ``conv_layer`` and ``norm_layer`` (a
convolution without bias, the normalization after it) are shared with
:mod:`e2vlib.model.decoder`.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from e2vlib.model.config import RESNET_LAYERS, E2VConfig

# --------------------------------------------------------------------------- building blocks


def norm_layer(kind: str, channels: int, dim: int = 3) -> nn.Module:
    if kind == "group":
        # Up to 8 groups; gcd keeps the group count a divisor of the channel count.
        return nn.GroupNorm(math.gcd(channels, 8), channels)
    return nn.BatchNorm3d(channels) if dim == 3 else nn.BatchNorm2d(channels)


def conv_layer(dim: int, c_in: int, c_out: int, kernel: int, stride: int = 1) -> nn.Module:
    # No bias: a normalization layer always follows and would cancel it.
    conv = nn.Conv3d if dim == 3 else nn.Conv2d
    return conv(c_in, c_out, kernel, stride=stride, padding=kernel // 2, bias=False)


def _half(n: int) -> int:
    """Length after a kernel-3 (or 1), padding-1 (or 0), stride-2 conv or pool: ceil(n/2)."""
    return (n + 1) // 2


class BasicBlock(nn.Module):
    """Two 3x3(x3) convolutions with a residual shortcut (ResNet-10/18/34); ``dim`` 2 or 3.

    Examples
    --------
    Stride 2 halves every axis; the shortcut becomes a 1x1x1 projection to the new width:
    ``8*16*27 + 16*16*27`` conv weights, ``8*16`` projection weights, ``3 * 2*16`` norm
    weights and biases:

    >>> block = BasicBlock(8, 16, stride=2, norm="batch")
    >>> block(torch.zeros(1, 8, 4, 8, 8)).shape, sum(p.numel() for p in block.parameters())
    (torch.Size([1, 16, 2, 4, 4]), 10592)
    >>> type(BasicBlock(8, 8, stride=1, norm="batch", dim=2).shortcut).__name__  # same shape
    'Identity'

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    expansion = 1

    def __init__(self, c_in: int, width: int, stride: int, norm: str, dim: int = 3) -> None:
        super().__init__()
        c_out = width * self.expansion
        self.conv1, self.bn1 = conv_layer(dim, c_in, width, 3, stride), norm_layer(norm, width, dim)
        self.conv2, self.bn2 = conv_layer(dim, width, c_out, 3), norm_layer(norm, c_out, dim)
        self.shortcut = _shortcut(c_in, c_out, stride, norm, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = F.relu(self.bn1(self.conv1(x)))
        y = self.bn2(self.conv2(y))
        return F.relu(y + self.shortcut(x))


class Bottleneck(nn.Module):
    """1x1 reduce, 3x3 (strided), 1x1 expand x4, with a residual shortcut (ResNet-50+).

    Examples
    --------
    >>> block = Bottleneck(16, 4, stride=1, norm="batch")  # width 4, output 4 * 4 = 16
    >>> block(torch.zeros(1, 16, 4, 8, 8)).shape
    torch.Size([1, 16, 4, 8, 8])

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    expansion = 4

    def __init__(self, c_in: int, width: int, stride: int, norm: str, dim: int = 3) -> None:
        super().__init__()
        c_out = width * self.expansion
        self.conv1, self.bn1 = conv_layer(dim, c_in, width, 1), norm_layer(norm, width, dim)
        # Stride on the 3x3 conv (as torchvision's ResNet v1.5); the counts are the same.
        self.conv2 = conv_layer(dim, width, width, 3, stride)
        self.bn2 = norm_layer(norm, width, dim)
        self.conv3, self.bn3 = conv_layer(dim, width, c_out, 1), norm_layer(norm, c_out, dim)
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
    return nn.Sequential(conv_layer(dim, c_in, c_out, 1, stride), norm_layer(norm, c_out, dim))


class ResNetEncoder(nn.Module):
    """A ResNet trunk (no classifier) in 3D (the paper: every 2D op made 3D) or in 2D.

    3D: input ``(B, C, n_frames, H, W)``, output ``(B, out_channels, t, h, w)`` with each
    of t (the frame axis), h, w shrunk about 32x (16x without the stem pool). 2D:
    ``(N, C, H, W)`` -> ``(N, out_channels, h, w)``. ``C`` is ``config.in_channels``: only
    the stem's convolution depends on it. Stages: ``stem``, ``layer1`` .. ``layer4``.

    Examples
    --------
    16 frames of 32 x 32 px: the stride-2 stem and its pool give 4 x 8 x 8, the three
    strided stages 1 x 1 x 1, with ``8 * 2**3 = 64`` channels:

    >>> from e2vlib.model.config import E2VConfig
    >>> config = E2VConfig(input_shape=(16, 32, 32))
    >>> encoder = ResNetEncoder(config).eval()
    >>> encoder.output_shape((16, 32, 32)), encoder(torch.zeros(1, 1, 16, 32, 32)).shape
    ((64, 1, 1, 1), torch.Size([1, 64, 1, 1, 1]))
    >>> ResNetEncoder(config, dim=2).eval()(torch.zeros(3, 1, 32, 32)).shape  # 3 images
    torch.Size([3, 64, 1, 1])

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """

    def __init__(self, config: E2VConfig, dim: int = 3) -> None:
        super().__init__()
        block = BasicBlock if config.block_type == "basic" else Bottleneck
        n_blocks = RESNET_LAYERS[config.depth][1]
        w = config.base_width
        stem: list[nn.Module] = [
            conv_layer(dim, config.in_channels, w, config.stem_kernel, config.stem_stride),
            norm_layer(config.norm, w, dim),
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
    ``(B, c, time_bins, h, w)``, shaped like the 3D encoder's output.

    Examples
    --------
    >>> from e2vlib.model.config import E2VConfig
    >>> encoder = Frames2dEncoder(E2VConfig(input_shape=(16, 32, 32), encoder="frames2d"))
    >>> encoder.output_shape((16, 32, 32)), encoder.eval()(torch.zeros(2, 1, 16, 32, 32)).shape
    ((64, 4, 1, 1), torch.Size([2, 64, 4, 1, 1]))

    Introduced in notebooks/05_the_e2v_model.ipynb.
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

    Examples
    --------
    >>> from e2vlib.model.config import E2VConfig
    >>> config = E2VConfig(input_shape=(16, 32, 32), encoder="frames2d_gru", gru_hidden=32)
    >>> encoder = Frames2dGRUEncoder(config).eval()
    >>> encoder.features, encoder(torch.zeros(2, 1, 16, 32, 32)).shape  # 64 per frame in
    (64, torch.Size([2, 32, 1, 1, 1]))

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
