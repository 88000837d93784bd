"""E2V's configuration: :class:`E2VConfig`, the named :data:`PRESETS` and the choices they take.

An :class:`E2VConfig` holds everything needed to rebuild an :class:`~e2vlib.model.E2V` (it is
stored in checkpoints as a plain dict, :meth:`E2VConfig.to_dict`); :data:`PRESETS` names the
paper's configuration (``"paper"``: 3D ResNet-152 on 100 x 256 x 256, 149.8 M parameters) and
the laptop-sized ones (``"tiny"``, ``"tiny2d"``, ``"tiny_gru"``), each with the reasons for
its choices written beside it. The choice tuples (:data:`ENCODERS`, :data:`BRIDGES`,
:data:`BOTTLENECKS`, :data:`NORMS`, :data:`RESNET_LAYERS`) are what the config accepts.
Numbers only: this module imports no torch.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from e2vlib import paper

GRID_SIDE = paper.GRID_SIDE
"""Side of the output occupancy grid (the paper's 32^3)."""

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
LIFTS = ("none", "early", "late", "alone")
"""Where a hybrid's lifted volume (:class:`e2vlib.model.lifting.Lifting`) enters: nowhere
(E2V), at the decoder's input beside the bridge's hidden volume, before the head beside the
decoder's output, or alone (no encoder: the lifted volume through the 3D UNet)."""


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
      the frame axis. ``block``: ``"basic"``,
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
    - ``bridge_norm``: with ``bridge="fc"``, normalise the seed volume (``norm``, per
      channel) before its ReLU. The fully connected layer sums its whole input, so under
      AdamW its output can move in proportion to the input's size (1,024 values at 64 px,
      4,096 at 128 px); normalised, its scale stays put (experiments/collapse_probe.py).
      Stored as False with the other bridges.
    - ``lift``: one of :data:`LIFTS`. A hybrid also reads the frames lifted into the grid
      through the known orbit (two channels, :data:`e2vlib.geometry.LIFTED_CHANNELS`),
      made ``lift_width`` channels by one 3x3x3 convolution. ``lift_dt_us``: the window
      length (us) of the input frames on the orbit's clock, which fixes the camera of
      each frame (frame ``k`` is seen at ``(k + 1/2) dt``). Both are stored as their
      defaults when ``lift="none"``; a hybrid takes one-channel square frames.
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
    checkpoints keep loading. Fields added
    later (``in_channels``, ``gru_hidden``, ``gru_pool``, ``bridge_norm``) take their
    defaults when a stored config lacks them, so older checkpoints load as one-channel
    models with the bridge they were trained with.

    Examples
    --------
    >>> config = E2VConfig(input_shape=(20, 32, 32), depth=18)
    >>> config.depth, config.n_frames, config.block_type
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
    bridge_norm: bool = False
    lift: str = "none"
    lift_width: int = 8
    lift_dt_us: int = paper.DT_US

    def __post_init__(self) -> None:
        # Accept lists (a config read back from JSON or a checkpoint) and store tuples.
        object.__setattr__(self, "input_shape", tuple(int(v) for v in self.input_shape))
        object.__setattr__(self, "decoder_widths", tuple(int(v) for v in self.decoder_widths))
        if self.encoder != "frames2d_gru":  # unused: keep the defaults (see the docstring)
            for f in fields(self):
                if f.name in _GRU_FIELDS:
                    object.__setattr__(self, f.name, f.default)
        if self.bridge != "fc":  # only the fully connected bridge has an unnormalised output
            object.__setattr__(self, "bridge_norm", False)
        if self.lift == "none":  # unused: keep the defaults, as for the GRU fields
            for f in fields(self):
                if f.name in _LIFT_FIELDS:
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
        _check_choice(problems, "lift", self.lift, LIFTS)
        if self.lift != "none" and (self.in_channels != 1 or len(self.input_shape) != 3
                                    or self.input_shape[1:2] != self.input_shape[2:3]):
            problems.append("a hybrid (lift other than 'none') takes one-channel square "
                            f"frames, got in_channels={self.in_channels}, "
                            f"input_shape={self.input_shape}")
        for name in ("base_width", "stem_kernel", "stem_stride", "hidden_channels", "seed_size",
                     "bottleneck_features", "in_channels", "gru_hidden", "gru_pool",
                     "lift_width", "lift_dt_us"):
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
        if not isinstance(self.bridge_norm, bool):
            problems.append(f"bridge_norm must be True or False, got {self.bridge_norm!r}")
        if problems:
            raise ValueError("invalid E2V config: " + "; ".join(problems))

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
        """Rebuild a config from :meth:`to_dict`'s output; unknown keys raise ValueError."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"unknown E2V config keys {unknown}; valid keys: {sorted(known)}")
        return cls(**d)


_GRU_FIELDS = ("gru_hidden", "gru_pool")
"""Fields only ``encoder="frames2d_gru"`` uses."""
_LIFT_FIELDS = ("lift_width", "lift_dt_us")
"""Fields only a hybrid (``lift`` other than ``"none"``) uses."""


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
# "tiny" and "tiny_gru" with the bridge's seed volume normalised (bridge_norm), so that its
# units cannot all die: under recipe "tiny" the first steps killed every bridge unit of some
# seeds (time's 128px seed 1, encoder's cnn_gru seed 1) and the network learned one grid for
# every input. With the output started at even odds (recipe "tiny_step_even") these presets
# are the stability_norm_even study's (experiments/records/collapse_probe.json).
# 8 more parameters: the norm's scale and shift of 4 channels.
PRESETS["tiny_norm"] = replace(PRESETS["tiny"], bridge_norm=True)
PRESETS["tiny_gru_norm"] = replace(PRESETS["tiny_gru"], bridge_norm=True)
# Hybrids: tiny_norm (the capstone's best recipe's preset) that also reads the frames lifted
# through the known orbit (e2vlib.geometry.lift_frames; lesson 15), in three places:
# at the decoder's input beside the bridge's 4 hidden channels (8 + 4 = 12 channels on the
# 32^3 grid), before the head beside the decoder's output, or alone through the same 3D
# UNet with no encoder (the event frames reach it only through the lifting).
PRESETS["hybrid_early"] = replace(PRESETS["tiny_norm"], lift="early")
PRESETS["hybrid_late"] = replace(PRESETS["tiny_norm"], lift="late")
PRESETS["lifted_unet"] = replace(PRESETS["tiny_norm"], lift="alone")
"""Named configurations for :func:`build_e2v`."""
