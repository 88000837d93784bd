"""The E2V model: a 3D ResNet encoder, a bridge to a 32^3 hidden volume, a UNet decoder.

Input ``(batch, n_frames, H, W)`` float event frames (the frame axis is time), output
``(batch, 32, 32, 32)`` occupancy logits indexed ``[b, x, y, z]``; probabilities are
``sigmoid(logits)``; inputs of ``C > 1`` channels (``in_channels``, e.g. polarity) are
``(batch, C, n_frames, H, W)``. Encoders: the paper's 3D ResNet (preset ``"tiny"``), and a
per-frame 2D ResNet with temporal max pooling (``"tiny2d"``) or a GRU over time
(``"tiny_gru"``). The names a lesson or a user calls are importable from here
(``from e2vlib.model import E2V, build_e2v, load_checkpoint``); limits and checks' helpers
from their modules. The code lives in seven modules, each with one job:

=========================  =================================================================
``model.config``           what a model is made of, as numbers: :class:`E2VConfig`, the
                           named :data:`PRESETS` (``"paper"``, ``"tiny"``, ``"tiny2d"``,
                           ``"tiny_gru"``) with the reasons for their choices, the choices
                           a config takes (:data:`ENCODERS`, :data:`BRIDGES`,
                           :data:`BOTTLENECKS`, :data:`NORMS`, :data:`RESNET_LAYERS`) and
                           :data:`GRID_SIDE`; no torch
``model.encoders``         frames -> features: residual blocks (:class:`BasicBlock`,
                           :class:`Bottleneck`), :class:`ResNetEncoder` (3D, the paper's,
                           or 2D), the per-frame :class:`Frames2dEncoder` (max over time)
                           and :class:`Frames2dGRUEncoder` (a GRU over time)
``model.decoder``          features -> voxel features: :class:`Bridge` (to the 32^3
                           hidden volume), :class:`UNetDecoder` (Pix2Vox++-like)
``model.lifting``          a hybrid's second input: :class:`Lifting` (the frames
                           back-projected through the known orbit, as
                           :func:`e2vlib.geometry.lift_frames`) and :class:`LiftStem`
``model.networks``         the whole network: :class:`E2V`, :func:`build_e2v`,
                           :func:`count_parameters`
``model.integrity``        is a checkpoint intact: :func:`weights_digest`,
                           :func:`verify_weights` (digest and NaN checks), what a config's
                           weights must be (:func:`expected_state`, built on the meta
                           device; :func:`check_state_matches`, :data:`MAX_PARAMETERS`),
                           :class:`CheckpointError`, :data:`DIGEST_KEY`
``model.checkpoint``       checkpoint files: :func:`save_checkpoint`,
                           :func:`read_checkpoint` (verified on read),
                           :func:`load_checkpoint` (from a path or a read dict),
                           :func:`slim_checkpoint`, and the data config a model was
                           trained on (:func:`checkpoint_data_config`,
                           :func:`check_frames_match`)
``model.summary``          size and memory: :func:`parameter_breakdown`,
                           :func:`layer_table`, :func:`format_layer_table`,
                           :func:`activation_bytes`
=========================  =================================================================

Imports run one way: ``config`` imports only ``e2vlib.paper``; ``encoders`` imports
``config``; ``decoder`` imports ``config`` and ``encoders`` (their convolution and
normalization helpers); ``networks`` those three; ``integrity``, ``checkpoint`` and
``summary`` import ``networks`` (``checkpoint`` also ``integrity`` and ``e2vlib.files``);
none imports this package's ``__init__``. Importing the package loads no torch: a name loads
its module on first use, so ``from e2vlib.model import PRESETS`` stays torch-free.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "checkpoint": [
            "check_frames_match", "checkpoint_data_config", "load_checkpoint", "read_checkpoint",
            "save_checkpoint", "slim_checkpoint",
        ],
        "config": [
            "BOTTLENECKS", "BRIDGES", "ENCODERS", "LIFTS", "NORMS", "PAPER_PARAMETERS",
            "PRESETS", "E2VConfig",
        ],
        "decoder": ["Bridge", "UNetDecoder"],
        "encoders": [
            "BasicBlock", "Bottleneck", "Frames2dEncoder", "Frames2dGRUEncoder", "ResNetEncoder",
        ],
        "integrity": ["DIGEST_KEY", "CheckpointError", "verify_weights", "weights_digest"],
        "lifting": ["LiftStem", "Lifting"],
        "networks": ["E2V", "build_e2v", "count_parameters"],
        "summary": ["activation_bytes", "format_layer_table", "layer_table", "parameter_breakdown"],
    },
)
