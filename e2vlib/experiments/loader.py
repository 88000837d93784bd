"""A study protocol's splits as model inputs, kept in memory between the runs of one process.

Stored binary frames are used directly (max-pooled to a smaller frame size); every other
input is computed from the raw events or grey videos of a cache folder (:mod:`.caches`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from e2vlib.experiments.caches import (
    DATA_COMMANDS,
    EVENTS_COMMAND,
    EXTRA_COMMAND,
    NOISE_COMMANDS,
    STORAGE_SETTINGS,
    cache_command,
)
from e2vlib.experiments.protocol import Protocol, first_per_category
from e2vlib.inputs import GREY_INPUTS

if TYPE_CHECKING:
    from e2vlib.inputs import TensorSet


def _check_events_folder(protocol: Protocol, data: Path, split: str) -> Path:
    """``protocol``'s events folder, checked to hold ``split`` of the dataset ``data``."""
    from e2vlib.data import SPLITS, BuildConfig

    events, level = protocol.events_root, protocol.noise_level
    command = EVENTS_COMMAND if level == "clean" else NOISE_COMMANDS.get(
        level, cache_command(events, raw_events_per_category=64, noise=level))
    if not (events / "config.json").exists():
        raise FileNotFoundError(
            f"this config needs the raw events of every sample, in {events}; build them "
            f"once with `{command}`")
    mine = BuildConfig.from_dict(json.loads((events / "config.json").read_text())).to_dict()
    theirs = BuildConfig.from_dict(json.loads((data / "config.json").read_text())).to_dict()
    built_splits = mine.get("splits", list(SPLITS))
    if mine.get("noise", "clean") != level:
        raise ValueError(f"{events} holds events with noise {mine.get('noise', 'clean')!r}, "
                         f"not {level!r}; rebuild it with `{command}`")
    if split not in built_splits:
        raise ValueError(f"{events} holds only the splits {built_splits}, not {split!r}; "
                         f"build it with `{command}`")
    for key in (*STORAGE_SETTINGS, "noise"):
        mine.pop(key, None)
        theirs.pop(key, None)
    if mine != theirs:
        raise ValueError(f"{events} was built with other settings than {data} "
                         f"({mine} vs {theirs}); rebuild it with `{command}`")
    return events


def protocol_data_config(dataset_config: dict, protocol: Protocol) -> dict:
    """The dataset's build settings with the frame settings of ``protocol``: the data
    config of the protocol's inputs, which a checkpoint trained on them records (see
    ``e2vlib.model.check_frames_match``)."""
    return {**dataset_config, "n_frames": protocol.n_frames, "dt_us": protocol.dt_us,
            "frame_size": protocol.frame_size,
            "windows": "paper" if protocol.representation == "binary_paper" else "fixed",
            "representation": protocol.representation,
            **({"noise": protocol.noise} if protocol.noise_level != "clean" else {})}


_MEMORY: dict[str, object] = {}


_MEMORY_SPLITS = 8
"""Splits :func:`load_split` keeps in memory, oldest dropped first: a noise-study run's
train, val and test plus its four noisy test sets, so the next seed reuses its train set."""


def _tensors(protocol: Protocol, root: str | os.PathLike, split: str,
             per_category: int | dict | None, progress: bool) -> TensorSet:
    """One split of the dataset at ``root`` as the protocol's inputs (see load_split)."""
    import torch

    from e2vlib.data import E2VDataset
    from e2vlib.frames import downsample
    from e2vlib.inputs import TensorSet, preload

    dataset = E2VDataset(root, split)
    keep = first_per_category(dataset.categories, per_category)
    if not protocol.needs_events(dataset.config):
        tensors = preload(dataset, progress=progress).subset(keep)
        factor = dataset.config["frame_size"] // protocol.frame_size
        frames = tensors.frames
        if factor > 1:
            frames = torch.from_numpy(downsample(frames.numpy(), factor))
        return TensorSet(frames, tensors.voxels, tensors.categories, tensors.ids,
                         protocol_data_config(dataset.config, protocol))
    from tqdm.auto import tqdm

    from e2vlib.data import load_grey_video
    from e2vlib.inputs import grey_input, orbit_input
    from e2vlib.io import load_events

    source = _check_events_folder(protocol, Path(root), split)
    representation = protocol.representation
    frames, voxels = [], []
    for index in tqdm(keep, desc=f"{representation} {split}", disable=not progress,
                      leave=False):
        sample_id = dataset.ids[index]
        if representation in GREY_INPUTS:
            x = grey_input(load_grey_video(source, sample_id), representation,
                           protocol.frame_size)
        else:
            events, sensor = load_events(source / "events" / f"{sample_id}.npz")
            x = orbit_input(events, sensor, protocol.frame_size, representation=representation,
                            n_frames=protocol.n_frames, dt_us=protocol.dt_us)
        frames.append(torch.from_numpy(x if x.dtype in (np.uint8, np.float16)
                                       else x.astype(np.float16)))
        voxels.append(torch.from_numpy(dataset.arrays(index)[1]))
    return TensorSet(torch.stack(frames), torch.stack(voxels),
                     [dataset.categories[i] for i in keep],
                     [dataset.ids[i] for i in keep], protocol_data_config(dataset.config, protocol))


def load_split(protocol: Protocol, split: str, progress: bool = False) -> TensorSet:
    """The ``split`` of the protocol's data as a :class:`~e2vlib.inputs.TensorSet` whose
    frames are the protocol's input, ``(N, D, S, S)`` or ``(N, C, D, S, S)``.

    Stored binary frames are used directly (max-pooled to a smaller ``frame_size``);
    every other input is computed from the raw events (or grey videos) in
    :attr:`Protocol.events_root` and kept in memory for the next run of the same process.
    With ``train_scale`` s, the training split holds s x data_small's samples per category:
    its first ones for s <= 1, all of them plus objects of ``protocol.extra`` (every split)
    for s > 1. With ``pose_noise``, the training and validation labels are remade through
    an orbit error per object
    (:func:`~e2vlib.experiments.orbit_error.labels_through_orbit_error`); the test split keeps
    its own.
    """
    import torch

    from e2vlib.inputs import TensorSet

    key = protocol.input_key(split)
    if key in _MEMORY:
        return _MEMORY[key]
    data = protocol.data
    if data in DATA_COMMANDS and not (Path(data) / "manifest.csv").exists():
        raise FileNotFoundError(f"this config trains on {data}; build it once with "
                                f"`{DATA_COMMANDS[data]}`")
    if split != "train" or protocol.scale == 1:
        tensors = _tensors(protocol, data, split, protocol.per_category, progress)
    else:
        wanted = protocol.train_counts()
        parts = [_tensors(protocol, data, "train", wanted, progress)]
        have = {c: parts[0].categories.count(c) for c in wanted}
        for extra_split in ("train", "val", "test"):
            more = {c: wanted[c] - have[c] for c in wanted}
            if not any(n > 0 for n in more.values()):
                break
            parts.append(_tensors(protocol, _extra_root(protocol), extra_split, more,
                                  progress))
            for c in parts[-1].categories:
                have[c] += 1
        short = {c: wanted[c] - have[c] for c in wanted if have[c] < wanted[c]}
        if short:
            raise ValueError(f"{protocol.extra} holds too few objects for train_scale "
                             f"{protocol.scale} (missing per category: {short}); build more "
                             f"with `{EXTRA_COMMAND}`")
        extra_name = Path(protocol.extra).name  # ids restart in every build: name them
        ids = parts[0].ids + [f"{extra_name}/{i}" for t in parts[1:] for i in t.ids]
        tensors = TensorSet(torch.cat([t.frames for t in parts]),
                            torch.cat([t.voxels for t in parts]),
                            [c for t in parts for c in t.categories], ids, parts[0].config)
    if protocol.pose_noise is not None and split != "test":  # labels seen through orbit errors
        from e2vlib.experiments.orbit_error import labels_through_orbit_error

        labels = labels_through_orbit_error(data, tensors.ids, protocol.pose_noise, progress)
        tensors = TensorSet(tensors.frames, torch.from_numpy(labels), tensors.categories,
                            tensors.ids, tensors.config)
    while len(_MEMORY) >= _MEMORY_SPLITS:
        del _MEMORY[next(iter(_MEMORY))]
    _MEMORY[key] = tensors
    return tensors


def _extra_root(protocol: Protocol) -> Path:
    root = Path(protocol.extra)
    if not (root / "manifest.csv").exists():
        raise FileNotFoundError(f"train_scale {protocol.train_scale} needs more objects, "
                                f"in {root}; build them once with `{EXTRA_COMMAND}`")
    return root
