"""The studies: each study's question, its base protocol and its configs.

A study's protocol is a :class:`~e2vlib.experiments.protocol.Protocol` (its defaults are the
protocol every study shares) with the study's ``base`` changes; each config changes a few
settings more.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from e2vlib.experiments.caches import EXTRA_CACHE, NOISE_CACHE, RENDER_CACHE
from e2vlib.experiments.protocol import Protocol

QUICK: dict = {"epochs": 1, "per_category": 2, "frame_size": 32}
"""Quick mode (CI, live lesson demos): 2 training samples per category, 1 epoch, 32 px."""


THRESHOLDS = tuple(np.round(np.arange(0.05, 0.96, 0.05), 2).tolist())
"""Candidate voxelisation thresholds for the one picked on the validation split."""


@dataclass(frozen=True)
class Study:
    """A question and the configs that answer it (``config name -> params``, each the
    protocol settings it changes); ``base`` changes the shared protocol for every config."""

    name: str
    question: str
    configs: dict[str, dict]
    base: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        for config, params in self.configs.items():
            try:
                self.protocol().updated(params)
            except ValueError as error:
                raise ValueError(f"study {self.name!r}, config {config!r}: {error}") from None

    def protocol(self, quick: bool = False) -> Protocol:
        """The base protocol of this study: the shared one with the study's ``base`` changes
        (and :data:`QUICK`'s in quick mode)."""
        return Protocol().updated({**self.base, **(QUICK if quick else {})})


STUDIES: dict[str, Study] = {
    "representation": Study(
        "representation",
        "The paper uses binary event frames and names time surfaces and other "
        "representations as future work: which input lets the same network learn most?",
        {name: {"representation": name} for name in (
            "binary", "binary_paper", "count", "polarity", "time_surface", "voxel_grid",
            "edges")},
    ),
    "time": Study(
        "time",
        "The paper fixes 100 frames of 5 ms at 256 px: how do the number of frames over the "
        "same 0.5 s, and the frame size, change the result?",
        {
            "10x50ms": {"n_frames": 10, "dt_us": 50_000},
            "25x20ms": {"n_frames": 25, "dt_us": 20_000},
            "50x10ms": {"n_frames": 50, "dt_us": 10_000},
            "100x5ms": {},
            "200x2.5ms": {"n_frames": 200, "dt_us": 2_500},
            "32px": {"frame_size": 32},
            "128px": {"frame_size": 128},
        },
    ),
    "encoder": Study(
        "encoder",
        "The paper suggests LSTM/GRU or EfficientNet encoders instead of its 3D ResNet: "
        "does a recurrent encoder over per-frame 2D features do better at equal size?",
        {"resnet3d": {"preset": "tiny"}, "cnn_gru": {"preset": "tiny_gru"},
         "cnn_pool": {"preset": "tiny2d"}},
    ),
    "loss": Study(
        "loss",
        "The paper trains with mean binary cross-entropy; do focal or BCE + Dice losses, "
        "which weigh the rare occupied voxels more, give better grids?",
        {"bce": {"loss": "bce"}, "focal": {"loss": "focal"}, "bce_dice": {"loss": "bce_dice"}},
    ),
    "input": Study(
        "input",
        "The paper compares E2V only across papers with image methods that see grey or RGB "
        "frames: on the same objects, splits and budget, what do events buy over the grey "
        "video of the same orbit, and over a single grey view?",
        {"events": {},
         "grey_video": {"representation": "grey_video"},
         "grey_single": {"representation": "grey_single", "preset": "tiny2d", "n_frames": 1}},
    ),
    "noise": Study(
        "noise",
        "The paper trains and tests on noise-free simulated events; a real sensor adds "
        "threshold mismatch, shot noise, leak events and a refractory period. How much does "
        "noise at test time cost a clean-trained model, and does training with noise help?",
        {"train_clean": {}, "train_medium": {"noise": "medium"}},
        base={"noise": "clean", "noise_events": NOISE_CACHE,
              "test_noise": ["clean", "low", "medium", "high"]},
    ),
    "data_scale": Study(
        "data_scale",
        "The paper expects more data to close its gap to image methods: at a fixed number of "
        "training steps, how does test IoU grow with the number of training samples?",
        {f"{scale:g}x": {"train_scale": scale} for scale in (0.25, 0.5, 1, 2, 4)},
        base={"train_scale": 1, "extra": EXTRA_CACHE},
    ),
    "render": Study(
        "render",
        "The paper renders its videos in Blender and does not say how edges are smoothed; our "
        "datasets use VTK's supersampling (SSAA), about 90 % of a sample's build time. Does "
        "the network learn as well from the events of renders without anti-aliasing (4-7x "
        "faster), and does a model trained on one kind of render work on the other?",
        {"ssaa": {}, "none": {"data": RENDER_CACHE}},
        base={"test_data": {"ssaa": "data_small", "none": RENDER_CACHE}},
    ),
    "stability": Study(
        "stability",
        "Some runs of the tiny recipe collapse to a grid that hardly depends on the input "
        "(time's 128px seed 1, encoder's cnn_gru seed 1). With the learning rate set every "
        "step and warmed up over the first steps, do 8 seeds of each train without a "
        "collapse?",
        {"128px": {"frame_size": 128}, "cnn_gru": {"preset": "tiny_gru"}},
        base={"recipe": "tiny_step"},
    ),
    "stability_norm_even": Study(
        "stability_norm_even",
        "Recipe tiny_step's output prior stopped one kind of collapse (a dead bridge) but "
        "caused another: started at the labels' occupancy, time's 128px seed 2 never "
        "predicted 0.3 anywhere. With the output started at even odds (recipe "
        "tiny_step_even) and the bridge's seed volume normalised so that its units cannot "
        "all die (presets tiny_norm, tiny_gru_norm), do 8 seeds of each config train "
        "without a collapse?",
        {"128px": {"frame_size": 128, "preset": "tiny_norm"},
         "cnn_gru": {"preset": "tiny_gru_norm"}},
        base={"recipe": "tiny_step_even"},
    ),
    "capstone": Study(
        "capstone",
        "Lessons 09-12 found BCE + Dice, 128 px frames and 200 x 2.5 ms frames ahead of the "
        "base recipe, one at a time: does each hold with the per-step schedule, does a "
        "longer budget help, and how far do they carry together?",
        {"base": {},
         "bce_dice": {"loss": "bce_dice"},
         "128px": {"frame_size": 128},
         "200x2.5ms": {"n_frames": 200, "dt_us": 2_500},
         "30_epochs": {"epochs": 30},
         "bce_dice_30_epochs": {"loss": "bce_dice", "epochs": 30}},
        base={"recipe": "tiny_step_even", "preset": "tiny_norm"},
    ),
    "hybrid": Study(
        "hybrid",
        "The orbit is known and the same for every sample, yet E2V never sees it, while the "
        "visual hull uses it but needs the grey video. Does a model that also reads the "
        "event frames lifted through the known orbit (e2vlib.geometry.lift_frames) reach "
        "the hull from events alone, and where should the lifted volume enter?",
        {"e2v": {},
         "hybrid_early": {"preset": "hybrid_early"},
         "hybrid_late": {"preset": "hybrid_late"},
         "lifted_unet": {"preset": "lifted_unet"},
         # trained and validated on labels seen through orbit errors of up to 2 degrees and
         # 5 % radius (orbit_error.labels_through_orbit_error); tested on the exact labels
         "hybrid_early_pose_noise": {"preset": "hybrid_early", "pose_noise": [2.0, 0.05]}},
        base={"recipe": "tiny_step_even", "preset": "tiny_norm", "loss": "bce_dice",
              "epochs": 30},
    ),
}
"""The studies of lessons 09-13 and 15, by name."""


COLLAPSE_IOU = 0.2
"""A run whose test IoU@0.3 is below this collapsed: its grid hardly depends on the input
(collapsed runs scored 0.062; the lowest run that learned, 0.329; the mean shape, a grid
that ignores the input, 0.126)."""


def is_collapsed(record: dict) -> bool:
    """True when a run record's test IoU@0.3 is below :data:`COLLAPSE_IOU`.

    Examples
    --------
    >>> is_collapsed({"metrics": {"iou@0.3": 0.062}}), is_collapsed({"metrics": {"iou@0.3": 0.33}})
    (True, False)
    """
    return record["metrics"]["iou@0.3"] < COLLAPSE_IOU
