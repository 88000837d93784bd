"""Build settings: :class:`BuildConfig` (ROOT/config.json) and the frame settings of a dataset.

:func:`frame_settings` fills in the defaults of older configs; :func:`dataset_config` reads
and checks a dataset's config.json. Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from e2vlib import paper
from e2vlib.data.checks import MAX_FRAMES_PER_SAMPLE, SPLITS, DatasetError, read_config
from e2vlib.frames import WINDOWS

MAX_PER_CATEGORY = 10_000
"""Most objects per category a build plans (the paper's largest class has 3,057)."""
MAX_RESOLUTION = 4096
"""Largest render size in px (the paper renders 512); :data:`MAX_VIDEO_BYTES` bounds the
video that a size and its oversampling make."""
MAX_VIDEO_BYTES = 4 * 2**30
"""Most bytes (4 GiB) of one sample's rendered float32 video: ``paper.N_VIDEO_FRAMES x
oversample`` frames of ``resolution^2`` px. The paper's 512 px (oversample 11) takes 1.3 GiB;
1024 px (oversample 21) would take 9.8 GiB and 4096 px at oversample 3, 22.5 GiB."""


def _video_problem(config: BuildConfig) -> str | None:
    """Why ``config``'s rendered video is too large for memory, or None."""
    frames = paper.N_VIDEO_FRAMES * int(config.oversample or 1)
    size = frames * config.resolution ** 2 * 4
    if size <= MAX_VIDEO_BYTES:
        return None
    return (f"resolution {config.resolution} px with oversample {config.oversample} renders "
            f"{frames} video frames of {size / 2**30:.3g} GiB per sample (float32), more than "
            f"data.MAX_VIDEO_BYTES = {MAX_VIDEO_BYTES / 2**30:.0f} GiB; lower the resolution "
            "or the oversampling (the paper renders 512 px)")


def _size_problems(config: BuildConfig) -> list[str]:
    """The settings of ``config`` beyond the bounds a build can meet."""
    problems = []
    if config.per_category > MAX_PER_CATEGORY:
        problems.append(f"per_category {config.per_category} is more than {MAX_PER_CATEGORY} "
                        "(data.MAX_PER_CATEGORY; the paper's largest category has 3057): "
                        "build at most that many objects per category")
    if config.resolution > MAX_RESOLUTION:
        problems.append(f"resolution {config.resolution} is more than {MAX_RESOLUTION} px "
                        "(data.MAX_RESOLUTION; the paper renders 512)")
    if config.n_frames * config.frame_size ** 2 > MAX_FRAMES_PER_SAMPLE:
        problems.append(f"{config.n_frames} frames of {config.frame_size} px are more than "
                        f"{MAX_FRAMES_PER_SAMPLE} values per sample "
                        "(data.MAX_FRAMES_PER_SAMPLE)")
    return problems


@dataclass(frozen=True)
class BuildConfig:
    """Settings of one dataset build; stored as ROOT/config.json.

    ``resolution``: rendered and simulated image size in px; ``frame_size``: side of the
    stored frames after max-pooling (must divide ``resolution``); ``oversample``: render
    this many times more video frames than the paper's 240 fps so the object moves at
    most about a pixel between frames (default: the smallest such factor, 3 at 128 px;
    see lesson 03); ``contrast``: the simulator's threshold C (our choice, the paper gives
    none); ``n_frames`` event frames of ``dt_us`` microseconds, grouped by ``windows``
    (``"fixed"`` clock windows or the paper's Eq. 5 ``"paper"``, see
    :func:`e2vlib.frames.accumulate`); ``grey_video``: also store every sample's grey
    video at the event frames' times (:func:`grey_frame_indices`), in ROOT/grey/;
    ``noise``: the simulator's sensor noise, a key of
    :data:`e2vlib.noise.NOISE_LEVELS` (``"clean"``: none, what data_small uses);
    ``splits``: build only these splits (the plan, and so every sample's split and seed, is
    the full build's); ``anti_aliasing``: the renderer's edge smoothing, a mode of
    :data:`e2vlib.render.ANTI_ALIASING` (``"ssaa"``, what data_small uses; ``"none"`` renders
    about 4x (128 px) to 7x (256 px) faster and changes the events at moving edges, see
    bench/RESULTS.md). These four are written to config.json only when they differ from
    their defaults, so older configs keep their exact form.

    Examples
    --------
    >>> config = BuildConfig(categories=("chair",), per_category=2, oversample=3)
    >>> config.n_frames, config.dt_us, config.windows
    (100, 5000, 'fixed')
    >>> BuildConfig.from_dict(config.to_dict()) == config
    True
    """

    categories: tuple[str, ...]
    per_category: int
    resolution: int = paper.RESOLUTION_PX
    frame_size: int = paper.FRAME_SIZE_PX
    oversample: int | None = None  # None: the smallest keeping motion <= 1 px per frame
    contrast: float = paper.CONTRAST_THRESHOLD
    seed: int = 0
    raw_events_per_category: int = 1
    n_frames: int = paper.N_EVENT_FRAMES
    dt_us: int = paper.DT_US
    windows: str = paper.FRAME_WINDOWS
    grey_video: bool = False
    noise: str = "clean"
    splits: tuple[str, ...] = SPLITS
    anti_aliasing: str = "ssaa"

    def __post_init__(self):
        from e2vlib.noise import NOISE_LEVELS
        from e2vlib.render import ANTI_ALIASING

        object.__setattr__(self, "categories", tuple(self.categories))
        object.__setattr__(self, "splits", tuple(self.splits))
        problems = []
        unknown = [c for c in self.categories if c not in paper.CATEGORIES]
        if unknown or not self.categories:
            problems.append(f"categories must be some of {', '.join(paper.CATEGORIES)}, got "
                            f"{list(self.categories) if not unknown else unknown}")
        for name in ("per_category", "resolution", "frame_size", "n_frames", "dt_us"):
            value = getattr(self, name)
            if not (isinstance(value, (int, np.integer)) and not isinstance(value, bool)
                    and value >= 1):
                problems.append(f"{name} must be a positive integer, got {value!r}")
        if not (isinstance(self.raw_events_per_category, (int, np.integer))
                and self.raw_events_per_category >= 0):
            problems.append("raw_events_per_category must be a non-negative integer, got "
                            f"{self.raw_events_per_category!r}")
        if self.oversample is not None and not (
                isinstance(self.oversample, (int, np.integer)) and self.oversample >= 1):
            problems.append(f"oversample must be a positive integer, got {self.oversample!r}")
        if not (isinstance(self.contrast, (int, float)) and np.isfinite(self.contrast)
                and self.contrast > 0):
            problems.append(f"contrast must be a positive number, got {self.contrast!r}")
        if self.windows not in WINDOWS:
            problems.append(f"windows must be one of {WINDOWS}, got {self.windows!r}")
        if not isinstance(self.grey_video, (bool, np.bool_)):
            problems.append(f"grey_video must be True or False, got {self.grey_video!r}")
        if self.noise not in NOISE_LEVELS:
            problems.append(f"noise must be one of {', '.join(NOISE_LEVELS)}, got "
                            f"{self.noise!r}")
        if self.anti_aliasing not in ANTI_ALIASING:
            problems.append(f"anti_aliasing must be one of {', '.join(ANTI_ALIASING)}, got "
                            f"{self.anti_aliasing!r}")
        if not self.splits or any(x not in SPLITS for x in self.splits) or len(
                set(self.splits)) != len(self.splits):
            problems.append(f"splits must be some of {', '.join(SPLITS)} (each once), got "
                            f"{list(self.splits)}")
        if not problems and self.resolution % self.frame_size:
            problems.append(f"frame_size {self.frame_size} must divide resolution "
                            f"{self.resolution}")
        if not problems:
            problems += _size_problems(self)
        if problems:
            raise ValueError("; ".join(problems))
        if self.oversample is None:
            from e2vlib.orbit import required_oversample

            object.__setattr__(self, "oversample",
                               required_oversample(paper.N_VIDEO_FRAMES, self.resolution))
        video = _video_problem(self)
        if video:
            raise ValueError(video)

    def to_dict(self) -> dict:
        """A JSON-ready dict of every field (categories as a list); ``grey_video``,
        ``noise``, ``splits`` and ``anti_aliasing`` only when not their defaults, so configs
        without them keep their exact old form."""
        d = asdict(self)
        d["categories"] = list(self.categories)
        if not self.grey_video:
            del d["grey_video"]
        else:
            d["grey_video"] = True
        if self.noise == "clean":
            del d["noise"]
        if self.anti_aliasing == "ssaa":
            del d["anti_aliasing"]
        if tuple(self.splits) == SPLITS:
            del d["splits"]
        else:
            d["splits"] = list(self.splits)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> BuildConfig:
        """Inverse of :meth:`to_dict`. Keys missing from configs written before the frame
        settings were recorded get the values those builds used (100 fixed 5 ms windows,
        no grey video)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"unknown build settings {unknown}; known: {sorted(known)}")
        return cls(**d)


FRAME_FIELDS = ("n_frames", "dt_us", "windows", "frame_size")
"""Build settings that decide how events become the model's input frames."""

LEGACY_WINDOWS = "fixed"
"""Frame grouping of configs written before ``windows`` was recorded: they all used the
fixed clock windows of ``frames.accumulate(..., windows="fixed")``."""


def frame_settings(config: Mapping[str, Any]) -> dict[str, Any]:
    """The :data:`FRAME_FIELDS` of a build config dict, with the defaults of older configs.

    A missing ``n_frames`` / ``dt_us`` means the paper's :data:`e2vlib.paper.N_EVENT_FRAMES`
    frames of :data:`e2vlib.paper.DT_US` microseconds, a missing ``windows``
    :data:`LEGACY_WINDOWS`; a missing (or None) ``frame_size`` stays None: unknown. Any other
    value must be what a build writes: ``n_frames``, ``dt_us``, ``frame_size`` whole
    numbers >= 1 (not strings such as ``"20"``) making at most
    :data:`~e2vlib.data.checks.MAX_FRAMES_PER_SAMPLE` values, ``windows`` one of
    :data:`e2vlib.frames.WINDOWS`; else ValueError naming the field and the fix.

    Examples
    --------
    >>> frame_settings({"frame_size": 64})  # an older config: the settings it was built with
    {'n_frames': 100, 'dt_us': 5000, 'windows': 'fixed', 'frame_size': 64}
    >>> frame_settings({"n_frames": 20, "dt_us": 25000})["frame_size"] is None
    True
    >>> frame_settings({"n_frames": "20"})
    Traceback (most recent call last):
    ...
    ValueError: n_frames must be a whole number >= 1, got '20' (str); write it as a number, \
or leave it out for the default 100
    """
    defaults = {"n_frames": paper.N_EVENT_FRAMES, "dt_us": paper.DT_US,
                "windows": LEGACY_WINDOWS, "frame_size": None}
    settings = {key: config.get(key, default) for key, default in defaults.items()}
    for key in ("n_frames", "dt_us", "frame_size"):
        value = settings[key]
        if value is None and key == "frame_size":
            continue
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            leave_out = "if unknown" if key == "frame_size" else f"for the default {defaults[key]}"
            raise ValueError(f"{key} must be a whole number >= 1, got {value!r} "
                             f"({type(value).__name__}); write it as a number, or leave it "
                             f"out {leave_out}")
        settings[key] = int(value)
    if settings["frame_size"] and (settings["n_frames"] * settings["frame_size"] ** 2
                                   > MAX_FRAMES_PER_SAMPLE):
        raise ValueError(f"{settings['n_frames']} frames of {settings['frame_size']} px are "
                         f"more than {MAX_FRAMES_PER_SAMPLE} values per sample "
                         "(data.MAX_FRAMES_PER_SAMPLE); the paper uses 100 frames of 256 px")
    if settings["windows"] not in WINDOWS:
        raise ValueError(f"windows must be one of {', '.join(WINDOWS)}, got "
                         f"{settings['windows']!r}; or leave it out for {LEGACY_WINDOWS!r}")
    return settings


def dataset_config(root: str | os.PathLike) -> dict:
    """ROOT/config.json, checked (:func:`e2vlib.data.checks.read_config`; a full build
    config also as :class:`BuildConfig`), with :func:`frame_settings` filled in. Raises
    :class:`DatasetError` naming the file and the bad value.

    Examples
    --------
    >>> import json, tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> _ = (root / "config.json").write_text(json.dumps({"frame_size": 32}))
    >>> dataset_config(root)
    {'frame_size': 32, 'n_frames': 100, 'dt_us': 5000, 'windows': 'fixed'}
    """
    config = read_config(root)
    if {"categories", "per_category"} <= set(config):
        try:
            BuildConfig.from_dict(config)
        except (TypeError, ValueError) as err:
            raise DatasetError(f"{Path(root) / 'config.json'}: invalid build settings "
                               f"({err}); fix them or rebuild the dataset") from None
    return {**config, **frame_settings(config)}
