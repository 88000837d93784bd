"""Datasets: build E2V samples from meshes, store them compactly, and read them back.

One sample is what the paper feeds its network: an object is rendered along the spiral
orbit (120 frames at 240 fps = 0.5 s, rendered ``oversample`` times denser for the
simulator), the video becomes events (ESIM, contrast 0.2), the events become 100 binary
frames of 5 ms, max-pooled down to ``frame_size``; the label is the object's 32^3 voxel
grid.

Layout written by :func:`build_dataset` (``data_small/`` is one)::

    ROOT/manifest.csv           id, category, split, seed, n_events (one row per sample)
    ROOT/config.json            the builder's settings (resolution, frame size, ...)
    ROOT/samples/<id>.npz       frames (bit-packed), voxels (bit-packed), n_events
    ROOT/events/<id>.npz        raw events of a few samples (e2vlib.io format)
    ROOT/grey/<id>.npz          grey video at the event frames' times (``--grey-video`` only)
    ROOT/shards/<i>-of-<n>.json which shards ran here (``--shard i/n`` builds only)

Newer manifests also carry ``sha256``, the digest of each sample file's arrays
(:func:`npz_digest`); older ones without it read as before. Shards built into separate
folders are joined and checked by :func:`e2vlib.shards.merge_datasets`
(``python -m e2vlib merge-data``).

:class:`E2VDataset` reads that layout and the authors' released SynthEVox3D layout.

Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import csv
import hashlib
import json
import multiprocessing
import os
import zipfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch
from torch.utils.data import Dataset

from e2vlib import paper
from e2vlib.dataset_checks import (
    MAX_FRAMES_PER_SAMPLE,
    SPLITS,
    DatasetError,
    check_id,
    inside,
    npz_problem,
    read_config,
    read_manifest_rows,
    rebuild_hint,
)
from e2vlib.events import EventError
from e2vlib.files import atomic_path
from e2vlib.frames import WINDOWS, accumulate, downsample
from e2vlib.io import save_events

GREY_DIR = "grey"
"""Folder of a dataset holding the grey videos (``make-data --grey-video``)."""
SPLIT_FRACTIONS = (0.8, 0.1, 0.1)  # the paper's 832 : 104 : 104 is 8 : 1 : 1


MAX_PER_CATEGORY = 10_000
"""Most objects per category a build plans (the paper's largest class has 3,057)."""
MAX_RESOLUTION = 4096
"""Largest render size in px (the paper renders 512)."""


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
                        "(dataset_checks.MAX_FRAMES_PER_SAMPLE)")
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
    :data:`e2vlib.simulate.NOISE_LEVELS` (``"clean"``: none, what data_small uses);
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
        from e2vlib.render import ANTI_ALIASING
        from e2vlib.simulate import NOISE_LEVELS

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
            from e2vlib.render import required_oversample

            object.__setattr__(self, "oversample",
                               required_oversample(paper.N_VIDEO_FRAMES, self.resolution))

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


def frame_settings(config: dict | None) -> dict | None:
    """The frame-making fields of a dataset config dict (``n_frames``, ``dt_us``,
    ``windows``, ``frame_size``), with the defaults of older configs filled in."""
    if config is None:
        return None
    return {
        "n_frames": int(config.get("n_frames", paper.N_EVENT_FRAMES)),
        "dt_us": int(config.get("dt_us", paper.DT_US)),
        "windows": str(config.get("windows", "fixed")),
        "frame_size": int(config["frame_size"]) if "frame_size" in config else None,
    }


def dataset_config(root: str | os.PathLike) -> dict:
    """ROOT/config.json, checked (:func:`e2vlib.dataset_checks.read_config`; a full build
    config also as :class:`BuildConfig`), with :func:`frame_settings` filled in. Raises
    :class:`DatasetError` naming the file and the bad value."""
    config = read_config(root)
    if {"categories", "per_category"} <= set(config):
        try:
            BuildConfig.from_dict(config)
        except (TypeError, ValueError) as err:
            raise DatasetError(f"{Path(root) / 'config.json'}: invalid build settings "
                               f"({err}); fix them or rebuild the dataset") from None
    return {**config, **frame_settings(config)}


@dataclass(frozen=True)
class SampleSpec:
    """Which object a sample shows, its split, and the seed that makes it."""

    id: str
    category: str
    index: int
    split: str
    seed: int


@dataclass
class Sample:
    """A built sample: frames (n_frames, S, S) uint8 0/1, voxels (32, 32, 32) bool.

    With ``config.grey_video``, ``grey`` is the grey video (n_frames, S, S) uint8 and
    ``grey_index`` (n_frames,) int64 the rendered frame each grey frame comes from
    (see :func:`grey_frame_indices`); otherwise both are None.
    """

    frames: np.ndarray
    voxels: np.ndarray
    events: np.ndarray
    sensor_size: tuple[int, int]
    grey: np.ndarray | None = None
    grey_index: np.ndarray | None = None


def sample_seed(seed: int, category: str, index: int) -> int:
    """A stable 31-bit seed for sample ``index`` of ``category`` (independent of order)."""
    digest = hashlib.sha256(f"{seed}/{category}/{index}".encode()).digest()
    return int.from_bytes(digest[:4], "little") & 0x7FFFFFFF


def plan_samples(config: BuildConfig) -> list[SampleSpec]:
    """All samples of a build, with their 8:1:1 split (shuffled per category, seeded).

    Per category, ``round(0.1 n)`` samples (at least one when n >= 3) go to val and to
    test, the rest to train. Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    specs = []
    n = config.per_category
    n_held = max(1, round(SPLIT_FRACTIONS[2] * n)) if n >= 3 else 0
    for category in config.categories:
        order = np.random.default_rng(sample_seed(config.seed, category, -1)).permutation(n)
        split_of = {}
        for rank, index in enumerate(order):
            split_of[int(index)] = (
                "test" if rank < n_held else "val" if rank < 2 * n_held else "train"
            )
        for index in range(n):
            specs.append(SampleSpec(
                id=f"{category}_{index:04d}", category=category, index=index,
                split=split_of[index], seed=sample_seed(config.seed, category, index),
            ))
    return specs


def events_to_frames(events: np.ndarray, sensor_size: tuple[int, int], frame_size: int,
                     t0_us: int = 0, n_frames: int = paper.N_EVENT_FRAMES,
                     dt_us: int = paper.DT_US,
                     windows: str = paper.FRAME_WINDOWS) -> np.ndarray:
    """The model's input: ``n_frames`` binary frames of ``dt_us`` from ``t0_us``, max-pooled
    to ``frame_size`` (defaults: the paper's 100 frames of 5 ms, our fixed windows).

    Returns uint8 ``(n_frames, frame_size, frame_size)``; ``sensor_size`` must be square and
    a multiple of ``frame_size``. Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    width, height = sensor_size
    if width != height or width % frame_size:
        raise ValueError(
            f"sensor {width}x{height} must be square and a multiple of frame_size {frame_size}"
        )
    frames = accumulate(events, sensor_size, dt_us=dt_us, t0_us=t0_us, n_frames=n_frames,
                        windows=windows)
    return downsample(frames, width // frame_size)


def events_to_model_input(events: np.ndarray, sensor_size: tuple[int, int],
                          frame_size: int, n_frames: int = paper.N_EVENT_FRAMES,
                          dt_us: int = paper.DT_US,
                          windows: str = paper.FRAME_WINDOWS) -> np.ndarray:
    """``n_frames`` binary frames of ``dt_us`` from the first event, fitted to ``frame_size``.

    For recordings of any sensor size: the frames are centre-cropped to the largest
    square whose side is a multiple of ``frame_size`` and max-pooled down to it. Returns
    uint8 ``(n_frames, frame_size, frame_size)``. Fewer than ``n_frames`` events raise
    EventError: some frames would be empty by construction, and the model would give a
    confident-looking grid from next to no evidence. Introduced in
    notebooks/07_evaluation.ipynb.
    """
    if len(events) < n_frames:
        raise EventError(f"{len(events)} event(s) cannot make the model's input: its "
                         f"{n_frames} frames of {dt_us} us need at least {n_frames} events "
                         "(one per frame; with fewer, frames are empty by construction and "
                         "the model would answer from next to no evidence); give a recording "
                         "of the whole orbit")
    width, height = sensor_size
    factor = min(width, height) // frame_size
    if factor < 1:
        raise ValueError(f"a {width}x{height} sensor is smaller than frame_size {frame_size}")
    t0 = int(events["t"][0]) if len(events) else 0
    frames = accumulate(events, sensor_size, dt_us=dt_us, t0_us=t0, n_frames=n_frames,
                        windows=windows)
    side = factor * frame_size
    top, left = (height - side) // 2, (width - side) // 2
    return downsample(frames[:, top:top + side, left:left + side], factor)


# --- grey video at the event frames' times ---------------------------------------------


def rendered_times_us(config: BuildConfig) -> np.ndarray:
    """Time stamps (int64 us, shape ``(n_rendered,)``) of the video frames that
    :func:`mesh_to_sample` renders for ``config``: ``n_rendered = oversample * (120 - 1)
    + 1`` frames at ``oversample * 240`` fps, as :func:`e2vlib.render.render_orbit`
    stamps them (frame ``i`` at ``round(i * 1e6 / (oversample * 240))``)."""
    k = int(config.oversample)
    n = k * (paper.N_VIDEO_FRAMES - 1) + 1
    return np.round(np.arange(n) * 1e6 / (k * float(paper.VIDEO_FPS))).astype(np.int64)


def _nearest_frames(t_us: np.ndarray, n_frames: int, dt_us: int) -> np.ndarray:
    """Index into ``t_us`` (sorted int64 us) of the frame nearest the centre
    ``(k + 1/2) dt_us`` of each window ``k < n_frames``; ties go to the earlier frame."""
    twice = 2 * np.asarray(t_us, dtype=np.int64)
    centre2 = (2 * np.arange(n_frames, dtype=np.int64) + 1) * int(dt_us)  # 2 x centre (exact)
    right = np.clip(np.searchsorted(twice, centre2), 1, len(twice) - 1)
    left = right - 1
    return np.where(centre2 - twice[left] <= twice[right] - centre2, left, right)


def grey_frame_indices(config: BuildConfig) -> np.ndarray:
    """Which rendered video frame becomes grey frame ``k``: shape ``(n_frames,)`` int64.

    Grey frame ``k`` is the rendered frame (of the ``oversample``-times dense orbit that
    fed the simulator, :func:`rendered_times_us`) nearest the centre ``(k + 1/2) dt_us``
    of event window ``k`` (ties to the earlier frame). Windows past the end of the 0.5 s
    video get its last frame. With ``windows="paper"`` the Eq. 5 groups start at events
    and so vary per sample; the grey video keeps to the clock windows of ``dt_us``.
    """
    return _nearest_frames(rendered_times_us(config), config.n_frames, config.dt_us)


def grey_frame_cameras(config: BuildConfig) -> np.ndarray:
    """Camera position (m) of every grey frame, shape ``(n_frames, 3)``.

    The orbit is fixed by the config alone (no per-sample randomness), so row ``k`` is
    ``e2vlib.render.orbit_cameras(n_rendered)[grey_frame_indices(config)[k]]``; the camera
    looks at the origin with +z up (see :func:`e2vlib.render.project_points`).
    """
    from e2vlib.render import orbit_cameras

    return orbit_cameras(len(rendered_times_us(config)))[grey_frame_indices(config)]


def video_to_grey(video: np.ndarray, indices: np.ndarray, frame_size: int) -> np.ndarray:
    """Frames ``indices`` of a rendered ``video`` (n, R, R) float in [0, 1], area-averaged
    down to ``frame_size`` (which must divide R), as uint8 grey levels
    ``(len(indices), frame_size, frame_size)``: each pixel is the mean of an
    ``R/frame_size``-square block of the 8-bit levels ``round(255 v)``, rounded half up
    (exact integer arithmetic)."""
    _, height, width = video.shape
    if height != width or width % frame_size:
        raise ValueError(f"video frames {width}x{height} must be square and a multiple of "
                         f"frame_size {frame_size}")
    f = width // frame_size
    frames = np.clip(np.asarray(video[np.asarray(indices)], dtype=np.float64), 0.0, 1.0)
    levels = np.rint(frames * 255.0).astype(np.int64)
    sums = levels.reshape(len(levels), frame_size, f, frame_size, f).sum(axis=(2, 4))
    return ((sums + (f * f) // 2) // (f * f)).astype(np.uint8)


def save_grey_video(path: Path, grey: np.ndarray, frame_index: np.ndarray,
                    t_us: np.ndarray) -> None:
    """Write ROOT/grey/<id>.npz: ``grey`` uint8 (n_frames, S, S), ``frame_index`` int64
    (n_frames,) into the rendered video, ``t_us`` int64 (n_frames,) their time stamps (us)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, grey=np.asarray(grey, dtype=np.uint8),
                            frame_index=np.asarray(frame_index, dtype=np.int64),
                            t_us=np.asarray(t_us, dtype=np.int64))


def load_grey_video(root: str | os.PathLike, sample_id: str) -> np.ndarray:
    """Grey video of sample ``sample_id``: uint8 ``(n_frames, frame_size, frame_size)``.

    Frame ``k`` shows the object at the centre of event window ``k``
    (:func:`grey_frame_indices`), seen from ``grey_frame_cameras(config)[k]``. Raises a
    ValueError naming the make-data command to run when ``root`` was built without
    ``--grey-video`` or the file is missing or damaged.
    """
    root = Path(root)
    config_path = root / "config.json"
    if not config_path.is_file():
        raise FileNotFoundError(f"{config_path} not found: {root} is not a dataset made by "
                                f"`python -m e2vlib make-data --out {root} --grey-video`")
    sample_id = check_id(sample_id, f"load_grey_video({str(root)!r}, ...)")
    stored = read_config(root)
    if not stored.get("grey_video", False):
        try:
            command = make_data_command(
                BuildConfig.from_dict({**stored, "grey_video": True}), f"{root}_grey")
        except (TypeError, ValueError):
            command = "python -m e2vlib make-data --grey-video --out NEW_FOLDER ..."
        raise ValueError(f"{root} was built without --grey-video, so it stores no grey "
                         f"frames; build the same samples with them: `{command}`")
    path = inside(root, root / GREY_DIR / f"{sample_id}.npz")
    sample = inside(root, root / "samples" / f"{sample_id}.npz")
    if not path.is_file():
        if not sample.is_file():
            raise ValueError(f"{root} has no sample {sample_id!r}; ids are listed in "
                             f"{root / 'manifest.csv'}")
        raise ValueError(f"{path} is missing; delete {sample} and finish the build with "
                         f"make-data --out {root} (resumable)")
    try:
        with np.load(path, allow_pickle=False) as data:
            grey = np.asarray(data["grey"])
    except (zipfile.BadZipFile, EOFError, OSError, KeyError, ValueError) as err:
        raise ValueError(f"{path}: corrupted or truncated grey video ({err}); delete it and "
                         f"its sample file and rerun make-data --out {root}") from err
    settings = frame_settings(stored)
    expected = (settings["n_frames"], settings["frame_size"], settings["frame_size"])
    if grey.dtype != np.uint8 or grey.shape != expected:
        raise ValueError(f"{path}: expected uint8 grey frames of shape {expected}, got "
                         f"{grey.dtype} {grey.shape}; rebuild it with make-data --out {root}")
    return grey


def mesh_to_sample(mesh, config: BuildConfig, seed: int = 0) -> Sample:
    """Run one mesh through the whole pipeline: voxels, orbit video, events, frames.

    The mesh is normalized first (bbox centred, longest side 1). This is exactly what
    the dataset builder and ``python -m e2vlib reconstruct --mesh`` do. With
    ``config.grey_video`` the same rendered video also gives ``sample.grey``
    (:func:`grey_frame_indices`, :func:`video_to_grey`); nothing is rendered twice.
    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    from e2vlib.render import render_orbit
    from e2vlib.shapes import normalize_mesh
    from e2vlib.simulate import NOISE_LEVELS, simulate_events
    from e2vlib.voxels import voxelize

    mesh = normalize_mesh(mesh)
    voxels = voxelize(mesh, paper.GRID_SIDE)
    video, t_us = render_orbit(mesh, n_video_frames=paper.N_VIDEO_FRAMES, fps=paper.VIDEO_FPS,
                               resolution=config.resolution, oversample=config.oversample,
                               anti_aliasing=config.anti_aliasing)
    events = simulate_events(video, t_us, contrast_pos=config.contrast,
                             contrast_neg=config.contrast, seed=seed,
                             **NOISE_LEVELS[config.noise])
    sensor_size = (config.resolution, config.resolution)
    frames = events_to_frames(events, sensor_size, config.frame_size, n_frames=config.n_frames,
                              dt_us=config.dt_us, windows=config.windows)
    grey = grey_index = None
    if config.grey_video:
        grey_index = _nearest_frames(t_us, config.n_frames, config.dt_us)
        grey = video_to_grey(video, grey_index, config.frame_size)
    return Sample(frames=frames, voxels=voxels, events=events, sensor_size=sensor_size,
                  grey=grey, grey_index=grey_index)


def save_sample(path: Path, frames: np.ndarray, voxels: np.ndarray, n_events: int) -> None:
    """Write one sample as bit-packed, compressed arrays (temp file, then rename)."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(
            f,
            frames=np.packbits(frames.astype(bool), axis=None),
            frames_shape=np.asarray(frames.shape, dtype=np.int64),
            voxels=np.packbits(voxels.astype(bool), axis=None),
            voxels_shape=np.asarray(voxels.shape, dtype=np.int64),
            n_events=np.int64(n_events),
        )


def _member(data, name: str, path: Path, max_bytes: int) -> np.ndarray:
    """Array ``name`` of an open ``.npz``, refused unread when its stored size exceeds
    ``max_bytes`` (so a small file cannot ask for gigabytes)."""
    try:
        size = data.zip.getinfo(f"{name}.npy").file_size
    except KeyError:
        raise DatasetError(f"{path} has no array {name!r}; it is not a sample file: delete "
                           f"it and rebuild it with make-data") from None
    if size > max_bytes + 4096:  # 4096: room for the .npy header
        raise DatasetError(f"{path}: array {name!r} takes {size} bytes, more than its shape "
                           f"allows ({max_bytes}); delete it and rebuild it with make-data")
    return data[name]


def _stored_shape(data, name: str, path: Path) -> tuple[int, ...]:
    shape = _member(data, f"{name}_shape", path, 64)
    if shape.dtype.kind not in "iu" or shape.shape != (3,) or (shape < 0).any():
        raise DatasetError(f"{path}: {name}_shape must be 3 whole numbers >= 0, got "
                           f"{shape.tolist()!r}; delete it and rebuild it with make-data")
    shape = tuple(int(v) for v in shape)
    if np.prod(shape, dtype=np.float64) > MAX_FRAMES_PER_SAMPLE:
        raise DatasetError(f"{path}: {name}_shape {list(shape)} holds more than "
                           f"{MAX_FRAMES_PER_SAMPLE} values; delete it and rebuild it with "
                           "make-data")
    return shape


def _unpacked(data, name: str, shape: tuple[int, ...], path: Path) -> np.ndarray:
    count = int(np.prod(shape))
    packed = _member(data, name, path, (count + 7) // 8)
    if packed.dtype != np.uint8 or packed.shape != ((count + 7) // 8,):
        raise DatasetError(f"{path}: {name} holds {packed.dtype} {packed.shape}, not the "
                           f"{(count + 7) // 8} packed bytes of shape {list(shape)} (a "
                           "truncated or edited file); delete it and rebuild it with make-data")
    return np.unpackbits(packed, count=count).reshape(shape)


def load_sample(path: str | os.PathLike, frames_shape: Sequence[int] | None = None,
                voxels_shape: Sequence[int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Read a sample file; return ``(frames uint8 (D, S, S), voxels bool (32, 32, 32))``.

    The stored shapes, dtypes and packed lengths are checked before anything is unpacked,
    and against ``frames_shape`` / ``voxels_shape`` when given (what config.json says);
    any mismatch or damage is a :class:`DatasetError` naming the file. A missing file
    raises FileNotFoundError.
    """
    path = Path(path)
    try:
        data = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as err:
        raise DatasetError(f"{path}: corrupted or truncated sample file ({npz_problem(err)}); "
                           "delete it and rebuild it with `python -m e2vlib make-data`") from err
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise DatasetError(f"{path} is a single .npy array, not a sample file (.npz); delete "
                           "it and rebuild it with `python -m e2vlib make-data`")
    out = []
    try:
        with data:
            for name, expected in (("frames", frames_shape), ("voxels", voxels_shape)):
                shape = _stored_shape(data, name, path)
                if expected is not None and shape != tuple(expected):
                    raise DatasetError(
                        f"{path}: {name} of shape {shape}, but the dataset's config.json "
                        f"makes {tuple(expected)}; the sample comes from another build: "
                        "delete it and rebuild it with make-data")
                out.append(_unpacked(data, name, shape, path))
    except DatasetError:
        raise
    except (zipfile.BadZipFile, EOFError, OSError, KeyError, ValueError) as err:
        raise DatasetError(f"{path}: corrupted or truncated sample file ({err}); delete it "
                           "and rebuild it with `python -m e2vlib make-data`") from err
    return out[0], out[1].astype(bool)


def _build_one(args: tuple[BuildConfig, SampleSpec, str, bool]) -> dict:
    config, spec, root, keep_events = args
    from e2vlib.shapes import make_shape

    sample = mesh_to_sample(make_shape(spec.category, spec.seed), config, seed=spec.seed)
    root_path = Path(root)
    if keep_events:
        save_events(root_path / "events" / f"{spec.id}.npz", sample.events, sample.sensor_size)
    if sample.grey is not None:  # written before the sample file, which marks it done
        save_grey_video(root_path / GREY_DIR / f"{spec.id}.npz", sample.grey, sample.grey_index,
                        rendered_times_us(config)[sample.grey_index])
    save_sample(root_path / "samples" / f"{spec.id}.npz", sample.frames, sample.voxels,
                len(sample.events))
    return {**asdict(spec), "n_events": len(sample.events)}


def parse_shard(text: str) -> tuple[int, int]:
    """``"i/n"`` -> ``(i, n)`` with ``0 <= i < n``."""
    try:
        i, n = (int(v) for v in text.split("/"))
    except ValueError as err:
        raise ValueError(f"shard must look like i/n (e.g. 0/4), got {text!r}") from err
    if not 0 <= i < n:
        raise ValueError(f"shard {text!r}: need 0 <= i < n")
    return i, n


DATASET_ENTRIES = ("samples", "events", GREY_DIR, "shards", "manifest.csv", "config.json")
"""What a folder being built holds; make-data refuses a folder holding anything else
before its config.json is written."""


def check_build_folder(root: str | os.PathLike, config: BuildConfig) -> None:
    """Refuse to build ``config`` into ``root`` (DatasetError, before anything is written)
    when ``root`` is a file, a dataset of other settings, or a non-empty folder of files
    that are not a dataset's (:data:`DATASET_ENTRIES`), as ``merge-data`` refuses."""
    root = Path(root)
    if root.exists() and not root.is_dir():
        raise DatasetError(f"{root} is a file; give make-data a folder (new or empty)")
    config_path = root / "config.json"
    if config_path.exists():
        try:
            stored = BuildConfig.from_dict(read_config(root)).to_dict()
        except (TypeError, ValueError) as err:
            raise DatasetError(f"{config_path} holds no valid build settings "
                               f"({' '.join(str(err).split())}); use another --out folder or "
                               "delete it to rebuild") from None
        if stored != config.to_dict():
            raise DatasetError(f"{config_path} was built with different settings {stored}; "
                               "use another --out folder or delete it to rebuild")
        return
    if not root.is_dir():
        return
    foreign = sorted(p.name for p in root.iterdir() if p.name not in DATASET_ENTRIES
                     and not p.name.startswith(".config.json."))
    if foreign:
        listed = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more"
                                           if len(foreign) > 3 else "")
        raise DatasetError(f"{root} exists and is not a dataset (no config.json; it holds "
                           f"{listed}); make-data builds into a new or empty folder, or "
                           "finishes a dataset of the same settings: choose another --out")


def describe_build(root: str | os.PathLike, config: BuildConfig,
                   shard: tuple[int, int] = (0, 1)) -> str:
    """One line: how many samples the build of ``config`` (shard ``i/n``) into ``root``
    plans, how many are there already and how many it will make.

    >>> import tempfile
    >>> config = BuildConfig(categories=("chair", "lamp"), per_category=5, resolution=32,
    ...                      frame_size=16)
    >>> line = describe_build(Path(tempfile.mkdtemp()), config)
    >>> line[:49], line[-28:]
    ('plan: 10 samples (2 categories x 5 objects; split', '0 already built, 10 to build')
    """
    root = Path(root)
    index, count = shard
    mine = [s for k, s in enumerate(plan_samples(config))
            if k % count == index and s.split in config.splits]
    done = sum(_sample_done(root, s.id, config) for s in mine)
    where = f"; shard {index}/{count}" if count > 1 else ""
    return (f"plan: {len(mine)} samples ({len(config.categories)} categories x "
            f"{config.per_category} objects; splits {', '.join(config.splits)}{where}): "
            f"{done} already built, {len(mine) - done} to build")


def build_dataset(
    root: str | os.PathLike,
    config: BuildConfig,
    workers: int = 1,
    shard: tuple[int, int] = (0, 1),
    progress: bool = True,
) -> Path:
    """Build (or finish building) a dataset in ``root``; return the manifest path.

    Deterministic for a config; resumable: samples whose file exists are skipped, and
    every file is written under a temporary name, then renamed. ``shard=(i, n)`` builds
    every n-th sample starting at i, so n processes or cluster jobs can share the work
    (into one shared folder or one folder each, joined by :func:`e2vlib.shards.merge_datasets`); it
    leaves ROOT/shards/<i>-of-<n>.json so a merge can name a missing shard. Each run
    rewrites the manifest from the sample files present.
    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    root = Path(root)
    check_build_folder(root, config)
    (root / "samples").mkdir(parents=True, exist_ok=True)
    (root / "events").mkdir(exist_ok=True)
    config_path = root / "config.json"
    if not config_path.exists():
        with atomic_path(config_path) as tmp:
            tmp.write_text(json.dumps(config.to_dict(), indent=2) + "\n")

    specs = plan_samples(config)
    keep = _raw_event_ids(specs, config.raw_events_per_category)
    index, count = shard
    if count > 1:
        marker = root / SHARDS_DIR / f"{index}-of-{count}.json"
        marker.parent.mkdir(exist_ok=True)
        with atomic_path(marker) as tmp:
            tmp.write_text(json.dumps({"shard": f"{index}/{count}"}) + "\n")
    todo = [s for k, s in enumerate(specs) if k % count == index and s.split in config.splits
            and not _sample_done(root, s.id, config)]
    jobs = [(config, s, str(root), s.id in keep) for s in todo]
    run_jobs(_build_one, jobs, workers, f"building {root.name}", "sample", progress)
    return write_manifest(root, specs)


def run_jobs(work, jobs: list, workers: int, desc: str, unit: str, progress: bool) -> None:
    """Run ``work(job)`` for every job, in ``workers`` processes when more than one, with a
    progress bar of ``unit``s."""
    from tqdm.auto import tqdm

    bar = tqdm(total=len(jobs), desc=desc, unit=unit, disable=not progress)
    if workers > 1 and len(jobs) > 1:
        # "spawn": each worker starts a fresh interpreter with its own VTK/OpenGL state.
        with multiprocessing.get_context("spawn").Pool(workers) as pool:
            for _ in pool.imap_unordered(work, jobs):
                bar.update()
    else:
        for job in jobs:
            work(job)
            bar.update()
    bar.close()


def _sample_done(root: Path, sample_id: str, config: BuildConfig) -> bool:
    """True when the sample file exists (and its grey video, if the build stores one)."""
    return (root / "samples" / f"{sample_id}.npz").exists() and (
        not config.grey_video or (root / GREY_DIR / f"{sample_id}.npz").exists())


def _raw_event_ids(specs: Sequence[SampleSpec], per_category: int) -> set[str]:
    """Ids whose raw events are kept: the first test samples of each category."""
    keep, seen = set(), {}
    for spec in sorted(specs, key=lambda s: (s.split != "test", s.index)):
        if seen.get(spec.category, 0) < per_category:
            keep.add(spec.id)
            seen[spec.category] = seen.get(spec.category, 0) + 1
    return keep


MANIFEST_FIELDS = ("id", "category", "split", "seed", "n_events", "sha256")
SHARDS_DIR = "shards"
"""Folder of a dataset holding one ``<i>-of-<n>.json`` per ``--shard i/n`` run."""


def npz_digest(path: str | os.PathLike) -> str:
    """SHA-256 (hex) of an ``.npz`` file's arrays: every member's name and ``.npy`` bytes,
    in name order. Unlike the file's own bytes it leaves out the write times that
    ``np.savez`` puts in the zip, so two builds of one sample give the same digest.
    Raises ValueError naming the file when it is not a readable zip (CRCs are checked)."""
    h = hashlib.sha256()
    try:
        with zipfile.ZipFile(path) as zf:
            for name in sorted(zf.namelist()):
                encoded = name.encode()
                h.update(len(encoded).to_bytes(8, "little") + encoded)
                h.update(zf.getinfo(name).file_size.to_bytes(8, "little"))
                with zf.open(name) as member:
                    for block in iter(lambda: member.read(1 << 20), b""):
                        h.update(block)
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as err:
        raise ValueError(f"{path}: corrupted or truncated file ({err})") from err
    return h.hexdigest()


def _manifest_digests(root: Path) -> dict[str, str]:
    """``{id: sha256}`` recorded in ROOT/manifest.csv (empty for old or unreadable ones)."""
    try:
        rows = read_manifest(root)
    except (OSError, ValueError, KeyError):
        return {}
    return {r["id"]: r["sha256"] for r in rows if r.get("sha256")}


def write_manifest(root: Path, specs: Iterable[SampleSpec],
                   digests: Mapping[str, str] | None = None) -> Path:
    """Write ROOT/manifest.csv for every planned sample whose file exists.

    ``sha256`` is :func:`npz_digest` of the sample file, taken from ``digests``, else from
    the manifest already there (the digest recorded when it was built), else computed.
    """
    root = Path(root)
    known = {**_manifest_digests(root), **(digests or {})}
    rows = []
    for spec in specs:
        path = root / "samples" / f"{spec.id}.npz"
        if path.exists():
            with np.load(path, allow_pickle=False) as data:
                n_events = int(data["n_events"])
            rows.append({"id": spec.id, "category": spec.category, "split": spec.split,
                         "seed": spec.seed, "n_events": n_events,
                         "sha256": known.get(spec.id) or npz_digest(path)})
    manifest = root / "manifest.csv"
    with atomic_path(manifest) as tmp, open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=MANIFEST_FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    return manifest


def read_manifest(root: str | os.PathLike) -> list[dict]:
    """Rows of ROOT/manifest.csv as dicts (``seed``, ``n_events`` as int; ``sha256`` as
    written, and absent from manifests older than it). Every row is checked
    (:func:`e2vlib.dataset_checks.read_manifest_rows`): a bad one is a :class:`DatasetError`
    naming its line."""
    return read_manifest_rows(root)


# --- sharded builds: command lines, merging, verifying ------------------------------------


def make_data_command(config: BuildConfig, out: str | os.PathLike,
                      shard: str | None = None) -> str:
    """The ``python -m e2vlib make-data`` command line that builds ``config`` into ``out``
    (only shard ``"i/n"`` of it when given); every setting is spelled out, so the command
    gives this exact config whatever the defaults."""
    parts = ["python", "-m", "e2vlib", "make-data", "--out", str(out)]
    if tuple(config.categories) != tuple(paper.CATEGORIES):
        parts += ["--categories", ",".join(config.categories)]
    parts += ["--per-category", str(config.per_category), "--resolution", str(config.resolution),
              "--frame-size", str(config.frame_size), "--oversample", str(config.oversample)]
    if config.contrast != paper.CONTRAST_THRESHOLD:
        parts += ["--contrast", repr(float(config.contrast))]
    parts += ["--seed", str(config.seed),
              "--raw-events-per-category", str(config.raw_events_per_category),
              "--n-frames", str(config.n_frames), "--dt-us", str(config.dt_us),
              "--windows", config.windows]
    if config.grey_video:
        parts.append("--grey-video")
    if config.noise != "clean":
        parts += ["--noise", config.noise]
    if tuple(config.splits) != SPLITS:
        parts += ["--splits", *config.splits]
    if config.anti_aliasing != "ssaa":
        parts += ["--anti-aliasing", config.anti_aliasing]
    if shard is not None:
        parts += ["--shard", shard]
    return " ".join(parts)


# --- reading -----------------------------------------------------------------------------


class E2VDataset(Dataset):
    """A split of an E2V dataset as a PyTorch ``Dataset``.

    Items are dicts ``{"frames": float32 tensor (D, H, W) of 0/1, "voxels": float32
    tensor (32, 32, 32), "category": str, "id": str}``. Reads e2vlib's own layout (a
    ``manifest.csv`` in ``root``) or the authors' SynthEVox3D release (folders by ShapeNet
    synset holding ``<scan>/events.npz`` and ``<scan>/model_normalized.npz``), whose
    events are turned into the paper's 100 frames of 5 ms and max-pooled from 512 to
    ``frame_size`` (256 in the paper). Introduced in notebooks/04_building_the_dataset.ipynb.

    The folder is untrusted input (:mod:`e2vlib.dataset_checks`): the manifest and
    config.json are checked on reading, only files inside ``root`` are read, and every
    item's stored shapes are checked against config.json as it loads. ``verify=True`` also
    loads every item of the split now and checks it against the ``sha256`` the manifest
    recorded (what ``python -m e2vlib verify-data`` does for all splits). Problems raise
    :class:`DatasetError` naming the file and the fix.
    """

    def __init__(self, root: str | os.PathLike, split: str = "train",
                 frame_size: int | None = None, categories: Sequence[str] | None = None,
                 verify: bool = False):
        if split not in SPLITS:
            raise ValueError(f"split must be one of {SPLITS}, got {split!r}")
        self.root = Path(root)
        self.split = split
        if not self.root.is_dir():
            raise FileNotFoundError(f"dataset folder {self.root} does not exist")
        self.digests: dict[str, str] = {}
        if (self.root / "manifest.csv").exists():
            self.layout = "e2vlib"
            self.config = dataset_config(self.root)
            rows = read_manifest(self.root)
            allowed = self.config.get("categories")
            for row in rows:
                if allowed is not None and row["category"] not in allowed:
                    raise DatasetError(
                        f"{self.root / 'manifest.csv'}: sample {row['id']!r} is a "
                        f"{row['category']}, which config.json's categories ({', '.join(allowed)})"
                        " do not include; fix or remove the row")
            rows = [r for r in rows if r["split"] == split]
            self.items = [(r["id"], r["category"], self.root / "samples" / f"{r['id']}.npz")
                          for r in rows]
            self.digests = {r["id"]: r["sha256"] for r in rows if r.get("sha256")}
            stored = self.config["frame_size"]
            if frame_size not in (None, stored):
                raise ValueError(f"{self.root} stores {stored}px frames; frame_size={frame_size}"
                                 " would need a rebuild with --frame-size")
            self.frame_size = stored
        else:
            self.layout = "synthevox3d"
            self.items = [(sample_id, category, scan) for sample_id, category, scan, s
                          in synthevox3d_items(self.root) if s == split]
            self.frame_size = frame_size or paper.INPUT_SIZE_PX
            self.config = {"layout": "synthevox3d",
                           **frame_settings({"frame_size": self.frame_size})}
        if categories is not None:
            self.items = [it for it in self.items if it[1] in set(categories)]
        if not self.items:
            raise DatasetError(f"{self.root}: no samples in split {split!r}")
        if verify:
            unhashed = [i for i, (sample_id, _, _) in enumerate(self.items)
                        if self.layout == "e2vlib" and sample_id not in self.digests]
            if unhashed:
                raise DatasetError(
                    f"{self.root / 'manifest.csv'} records no sha256 for {len(unhashed)} of "
                    f"{len(self.items)} {split} samples (an older build), so verify=True cannot "
                    f"check them; record them with {build_command(self.root)} (it adds only "
                    "what is missing), or load without verify")
            problems = [p for i in range(len(self.items)) if (p := self.check_item(i))]
            if problems:
                raise DatasetError(f"{len(problems)} of {len(self.items)} {split} samples of "
                                   f"{self.root} are bad: " + "; ".join(problems[:5])
                                   + ("; ..." if len(problems) > 5 else ""))

    def check_item(self, index: int) -> str | None:
        """What is wrong with item ``index`` (it does not load as config.json says, or its
        arrays differ from the ``sha256`` the manifest recorded, where it recorded one), or
        None when it is sound."""
        try:
            self.arrays(index)
            sample_id, _, path = self.items[index]
            recorded = self.digests.get(sample_id)
            if recorded is not None and npz_digest(path) != recorded:
                return (f"{path} does not match the sha256 its manifest recorded (changed or "
                        "damaged since it was built); delete it and rebuild it with "
                        f"{build_command(self.root)}")
        except (DatasetError, ValueError) as err:
            return " ".join(str(err).split())
        return None

    def __len__(self) -> int:
        return len(self.items)

    @property
    def categories(self) -> list[str]:
        """Category of every item, in order."""
        return [category for _, category, _ in self.items]

    @property
    def ids(self) -> list[str]:
        """Sample id of every item, in item order: ``dataset.ids[i] == dataset[i]["id"]``.

        Introduced in notebooks/08_visualizing_in_3d.ipynb.
        """
        return [sample_id for sample_id, _, _ in self.items]

    def category_indices(self) -> dict[str, list[int]]:
        """``{category: [item indices of its samples, ascending]}``, categories in first-seen order.

        Introduced in notebooks/08_visualizing_in_3d.ipynb.
        """
        out: dict[str, list[int]] = {}
        for i, category in enumerate(self.categories):
            out.setdefault(category, []).append(i)
        return out

    def raw_events_path(self, index: int) -> Path | None:
        """Path of the raw events kept for item ``index`` (``root/events/<id>.npz``), or None.

        The builder keeps raw events (``e2vlib.io`` format) for only a few samples per
        category (one in ``data_small``); the others store frames only. SynthEVox3D scans
        give None: their ``events.npz`` is the release's own format, which :meth:`arrays`
        reads. Introduced in notebooks/08_visualizing_in_3d.ipynb.
        """
        if not 0 <= index < len(self.items):
            raise IndexError(f"index {index} is out of range for {len(self.items)} items; "
                             f"use 0..{len(self.items) - 1}")
        path = self.root / "events" / f"{self.items[index][0]}.npz"
        if self.layout != "e2vlib" or not path.is_file():
            return None
        return inside(self.root, path)

    @property
    def input_shape(self) -> tuple[int, int, int]:
        """``(D, H, W)`` of the frames."""
        return (self.config["n_frames"], self.frame_size, self.frame_size)

    def arrays(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(frames uint8 (D, H, W), voxels bool (32, 32, 32))`` of item ``index``,
        checked against :attr:`input_shape` (DatasetError naming the file otherwise)."""
        sample_id, _, path = self.items[index]
        if self.layout != "e2vlib":
            for name in ("events.npz", "model_normalized.npz"):
                inside(self.root, path / name)
            return load_synthevox3d_scan(path, self.frame_size)
        inside(self.root, path)
        try:
            return load_sample(path, self.input_shape, (paper.GRID_SIDE,) * 3)
        except FileNotFoundError:
            raise DatasetError(f"sample {sample_id!r} listed in {self.root / 'manifest.csv'} "
                               f"is missing on disk ({path}); rebuild it with "
                               f"{build_command(self.root)}") from None

    def grey_video(self, index: int) -> np.ndarray:
        """Grey video of item ``index``, uint8 ``(D, H, W)`` (:func:`load_grey_video`);
        only for datasets built with ``make-data --grey-video``."""
        if self.layout != "e2vlib":
            raise ValueError(f"{self.root} is a SynthEVox3D folder, which has no grey video; "
                             "build a dataset with `python -m e2vlib make-data --grey-video`")
        if not 0 <= index < len(self.items):
            raise IndexError(f"index {index} is out of range for {len(self.items)} items; "
                             f"use 0..{len(self.items) - 1}")
        return load_grey_video(self.root, self.items[index][0])

    def __getitem__(self, index: int) -> dict:
        frames, voxels = self.arrays(index)
        sample_id, category, _ = self.items[index]
        return {
            "frames": torch.from_numpy(frames.astype(np.float32)),
            "voxels": torch.from_numpy(voxels.astype(np.float32)),
            "category": category,
            "id": sample_id,
        }


def build_command(root: str | os.PathLike) -> str:
    """The make-data command (quoted) that finishes the build of ``root``, spelled out from
    its config.json where that is a full build config; a generic one otherwise."""
    try:
        return f"`{make_data_command(BuildConfig.from_dict(read_config(root)), root)}`"
    except (TypeError, ValueError):
        return rebuild_hint(root)


class Verification(NamedTuple):
    """What :func:`verify_dataset` found: ``checked`` samples, one line per bad one in
    ``problems``, and how many of them had no ``sha256`` in the manifest (``unhashed``:
    an older build; only their shapes could be checked)."""

    checked: int
    problems: list[str]
    unhashed: int


def verify_dataset(root: str | os.PathLike) -> Verification:
    """Check every sample of every split of ``root`` (:meth:`E2VDataset.check_item`: it
    loads as config.json says and matches the manifest's ``sha256`` where one is
    recorded). A manifest or config.json that cannot be read raises :class:`DatasetError`.
    What ``python -m e2vlib verify-data`` runs."""
    root = Path(root)
    if (root / "manifest.csv").exists():
        rows = read_manifest(root)
        present = {row["split"] for row in rows}
        unhashed = sum(not row.get("sha256") for row in rows)
    elif root.is_dir():
        present, unhashed = {split for *_, split in synthevox3d_items(root)}, 0
    else:
        raise FileNotFoundError(f"dataset folder {root} does not exist")
    if not present:
        raise DatasetError(f"{root / 'manifest.csv'} lists no samples; build them with "
                           f"{build_command(root)}")
    checked, problems = 0, []
    for split in (s for s in SPLITS if s in present):
        dataset = E2VDataset(root, split)
        checked += len(dataset)
        problems += [p for i in range(len(dataset)) if (p := dataset.check_item(i))]
    return Verification(checked, problems, unhashed)


def synthevox3d_items(root: Path) -> list[tuple[str, str, Path, str]]:
    """``(id, category, scan folder, split)`` for every scan of a SynthEVox3D folder.

    Scans sit in ``root/<synset>/<scan>/`` (synset ids as in ShapeNet). The release has no
    split file that we rely on, so scans are split 8:1:1 by a hash of their id (stable
    under adding or removing other scans).
    """
    from e2vlib.paper import SHAPENET_SYNSETS

    items = []
    for synset_dir in sorted(p for p in root.iterdir() if p.is_dir()):
        category = SHAPENET_SYNSETS.get(synset_dir.name, synset_dir.name)
        for scan in sorted(p for p in synset_dir.iterdir() if (p / "events.npz").exists()):
            sample_id = f"{synset_dir.name}/{scan.name}"
            bucket = int.from_bytes(hashlib.sha256(sample_id.encode()).digest()[:2], "little")
            fraction = bucket / 65536
            split = "train" if fraction < 0.8 else "val" if fraction < 0.9 else "test"
            items.append((sample_id, category, scan, split))
    if not items:
        raise ValueError(
            f"{root}: neither an e2vlib dataset (manifest.csv) nor a SynthEVox3D folder "
            "(<synset>/<scan>/events.npz)"
        )
    return items


SYNTHEVOX3D_SENSOR = 512  # the paper rendered 512 x 512 and scaled to 256 x 256


def synthevox3d_time_scale(t: np.ndarray) -> float:
    """Microseconds per unit of a SynthEVox3D time column, settled by its value range.

    An orbit lasts 0.5 s, so the last time stamp tells the unit: below 10 -> seconds,
    below 1e4 -> milliseconds, below 1e7 -> microseconds, else nanoseconds.
    """
    span = float(np.max(t)) if len(t) else 0.0
    if span < 10:
        return 1e6
    if span < 1e4:
        return 1e3
    if span < 1e7:
        return 1.0
    return 1e-3


def load_synthevox3d_scan(scan: Path, frame_size: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Frames ``(100, S, S)`` uint8 and voxels ``(32, 32, 32)`` bool of one released scan.

    ``events.npz``'s ``arr_0`` is an ``(N, 4)`` float array of t, x, y, p; the voxel file's
    ``arr_0`` is the 32^3 grid.
    """
    from e2vlib.events import make_events, sort_events

    try:
        with np.load(scan / "events.npz", allow_pickle=False) as data:
            table = data["arr_0"]
        with np.load(scan / "model_normalized.npz", allow_pickle=False) as data:
            voxels = np.asarray(data["arr_0"]).astype(bool)
    except (zipfile.BadZipFile, EOFError, OSError, KeyError, ValueError) as err:
        raise DatasetError(f"{scan}: unreadable SynthEVox3D scan ({npz_problem(err)})") from err
    if table.ndim != 2 or table.shape[1] != 4:
        raise ValueError(f"{scan}/events.npz: expected an (N, 4) array t, x, y, p, "
                         f"got {table.shape}")
    if voxels.shape != (paper.GRID_SIDE,) * 3:
        raise ValueError(f"{scan}/model_normalized.npz: expected 32^3 voxels, got {voxels.shape}")
    t, x, y, p = table.T
    scale = synthevox3d_time_scale(t)
    try:
        events = sort_events(make_events(x, y, np.round(t * scale), p))
    except EventError as err:
        raise ValueError(f"{scan}/events.npz: {err}") from err
    size = SYNTHEVOX3D_SENSOR
    return events_to_frames(events, (size, size), frame_size, t0_us=0), voxels
