"""The E2V network: encoder, bridge and decoder put together (:class:`E2V`), and its builder.

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
depth (number of layers, :attr:`E2VConfig.depth`).

The paper gives the encoder, the hidden-volume idea, the decoder style and the total of
:data:`e2vlib.paper.N_PARAMETERS` parameters, but not the decoder's widths; every choice
made here is written next to the code that makes it. Presets: ``"paper"`` (149.8 M
parameters, input 100 x 256 x 256), ``"tiny"`` (2.8 M, input 100 x 64 x 64, trains on a
laptop CPU), and two of the paper's suggested future-work encoders at tiny size:
``"tiny2d"`` (per-frame 2D CNN, temporal max pooling; 2.7 M) and ``"tiny_gru"`` (per-frame
2D CNN + GRU; 2.7 M).

This module holds :class:`E2V`, :func:`build_e2v` and :func:`count_parameters`; the parts
live in their own modules: :mod:`e2vlib.model.config` (:class:`E2VConfig`, :data:`PRESETS`
and the reasons for their numbers), :mod:`e2vlib.model.encoders` (the ResNet trunks and
blocks, the two per-frame encoders) and :mod:`e2vlib.model.decoder` (:class:`Bridge`,
:class:`UNetDecoder`); :mod:`e2vlib.model` lists every name.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import Any

import torch
from torch import nn

from e2vlib.model.config import PRESETS, E2VConfig
from e2vlib.model.decoder import Bridge, UNetDecoder
from e2vlib.model.encoders import Frames2dEncoder, Frames2dGRUEncoder, ResNetEncoder
from e2vlib.model.lifting import Lifting, LiftStem

__all__ = ["E2V", "build_e2v", "count_parameters"]


# --------------------------------------------------------------------------- the model


class E2V(nn.Module):
    """E2V: event frames ``(B, n_frames, H, W)`` float -> occupancy logits ``(B, 32, 32, 32)``.

    Build with :func:`build_e2v` or ``E2V(E2VConfig(...))``. ``input_shape`` is the
    ``(D, H, W)`` = ``(n_frames, height, width)`` every input must have (``D`` is the frame
    axis, time; the ResNet depth is ``config.depth``); ``config`` the
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
        self.lift = config.lift
        self.hidden_channels = 0  # channels the decoder reads on the 32^3 grid
        if self.lift != "alone":
            if config.encoder == "resnet3d":
                self.encoder: nn.Module = ResNetEncoder(config, dim=3)
            elif config.encoder == "frames2d":
                self.encoder = Frames2dEncoder(config)
            else:
                self.encoder = Frames2dGRUEncoder(config)
            self.encoder_shape = self.encoder.output_shape(config.input_shape)
            if min(self.encoder_shape) < 1:
                raise ValueError(f"input_shape {config.input_shape} is too small for this "
                                 "encoder")
            self.bridge = Bridge(config, self.encoder_shape)
            self.hidden_channels = self.bridge.channels
        if self.lift != "none":  # a hybrid: the frames lifted through the known orbit too
            n_frames, size, _ = config.input_shape
            self.lifting = Lifting(n_frames, size, config.lift_dt_us)
            self.lift_stem = LiftStem(config)
        if self.lift in ("early", "alone"):
            self.hidden_channels += config.lift_width
        self.decoder = UNetDecoder(self.hidden_channels, config)
        head_in = self.hidden_channels + (config.lift_width if self.lift == "late" else 0)
        self.head = nn.Conv3d(head_in, 1, 1)
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
        if self.lift == "none":
            h = self.bridge(self.encoder(x.unsqueeze(1) if self.in_channels == 1 else x))
            return self.head(self.decoder(h)).squeeze(1)
        lifted = self.lift_stem(self.lifting(x))  # the hybrids: (B, lift_width, 32, 32, 32)
        if self.lift == "alone":
            return self.head(self.decoder(lifted)).squeeze(1)
        h = self.bridge(self.encoder(x.unsqueeze(1)))
        if self.lift == "early":
            return self.head(self.decoder(torch.cat([h, lifted], 1))).squeeze(1)
        return self.head(torch.cat([self.decoder(h), lifted], 1)).squeeze(1)  # "late"


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
        height, width)``) or ``in_channels=2`` (inputs ``(B, 2, n_frames, H, W)``).

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
    >>> small = build_e2v("tiny", input_shape=(20, 32, 32), depth=18)
    >>> small.config.depth, small(torch.zeros(2, 20, 32, 32)).shape
    (18, torch.Size([2, 32, 32, 32]))
    >>> gru = build_e2v("tiny_gru", input_shape=(20, 32, 32), seed=0)
    >>> gru.encoder_shape, gru(torch.zeros(2, 20, 32, 32)).shape
    ((256, 1, 1, 1), torch.Size([2, 32, 32, 32]))

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
