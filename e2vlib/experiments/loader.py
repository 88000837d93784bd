"""A study protocol's splits as model inputs, kept in memory between the runs of one process.

Stored binary frames are used directly (max-pooled to a smaller frame size); every other
input is computed from the raw events or grey videos of a cache folder (:mod:`.caches`).
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from e2vlib.experiments.caches import (
    DATA_COMMANDS,
    EVENTS_COMMAND,
    EXTRA_COMMAND,
    NOISE_COMMANDS,
    STORAGE_SETTINGS,
    cache_command,
)
from e2vlib.experiments.studies import epochs_of
from e2vlib.inputs import GREY_INPUTS, TensorSet, grey_input, preload


def _needs_events(protocol: dict, stored: dict) -> bool:
    """True unless the dataset's stored frames (settings ``stored``, a dataset config) are the
    protocol's input, possibly after max-pooling to a smaller ``frame_size``."""
    return not (protocol["representation"] == "binary"
                and protocol.get("noise", "clean") == stored.get("noise", "clean")
                and protocol["n_frames"] == stored["n_frames"]
                and protocol["dt_us"] == stored["dt_us"]
                and stored["windows"] == "fixed"
                and stored["frame_size"] % protocol["frame_size"] == 0)


def events_root(protocol: dict) -> Path:
    """The folder holding the raw events (and grey videos) the protocol's inputs come from:
    ``protocol["events"]`` for clean events, ``noise_events`` with its level otherwise."""
    level = protocol.get("noise", "clean")
    if level == "clean":
        return Path(protocol["events"])
    return Path(protocol["noise_events"].format(level=level))


def _check_events_folder(protocol: dict, split: str) -> Path:
    from e2vlib.data import SPLITS, BuildConfig

    events, data = events_root(protocol), Path(protocol["data"])
    level = protocol.get("noise", "clean")
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


def _first_per_category(categories: Sequence[str], per_category: int | dict | None) -> list[int]:
    """Indices of the first ``per_category`` items of each category (all when None; a dict
    gives each category its own count).

    Examples
    --------
    >>> _first_per_category(["a", "b", "a", "a", "b"], 2)
    [0, 1, 2, 4]
    >>> _first_per_category(["a", "b", "a", "a", "b"], {"a": 1, "b": 0})
    [0]
    """
    if per_category is None:
        return list(range(len(categories)))
    seen: dict[str, int] = {}
    keep = []
    for i, category in enumerate(categories):
        limit = per_category.get(category, 0) if isinstance(per_category, dict) else per_category
        if seen.get(category, 0) < limit:
            keep.append(i)
            seen[category] = seen.get(category, 0) + 1
    return keep


def input_config(dataset_config: dict, protocol: dict) -> dict:
    """The dataset's build settings with the frame settings of ``protocol``: what a
    checkpoint trained on these inputs records (see ``e2vlib.model.check_frames_match``)."""
    return {**dataset_config, "n_frames": protocol["n_frames"], "dt_us": protocol["dt_us"],
            "frame_size": protocol["frame_size"],
            "windows": "paper" if protocol["representation"] == "binary_paper" else "fixed",
            "representation": protocol["representation"],
            **({"noise": protocol["noise"]} if protocol.get("noise", "clean") != "clean"
               else {})}


_MEMORY: dict[str, object] = {}


_MEMORY_SPLITS = 8
"""Splits :func:`load_split` keeps in memory, oldest dropped first: a noise-study run's
train, val and test plus its four noisy test sets, so the next seed reuses its train set."""


def _input_key(protocol: dict, split: str) -> str:
    keys = ("representation", "n_frames", "dt_us", "frame_size")
    text = json.dumps({k: protocol[k] for k in keys} | {
        "split": split, "data": protocol["data"], "per_category": protocol.get("per_category"),
        "noise": protocol.get("noise", "clean"), "events": str(events_root(protocol)),
        "train_scale": protocol.get("train_scale", 1) if split == "train" else 1,
        "extra": protocol.get("extra")})
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _tensors(protocol: dict, root: str | os.PathLike, split: str,
             per_category: int | dict | None, progress: bool):
    """One split of the dataset at ``root`` as the protocol's inputs (see load_split)."""
    import torch

    from e2vlib.data import E2VDataset
    from e2vlib.frames import downsample

    dataset = E2VDataset(root, split)
    keep = _first_per_category(dataset.categories, per_category)
    if not _needs_events(protocol, dataset.config):
        tensors = preload(dataset, progress=progress).subset(keep)
        factor = dataset.config["frame_size"] // protocol["frame_size"]
        frames = tensors.frames
        if factor > 1:
            frames = torch.from_numpy(downsample(frames.numpy(), factor))
        return TensorSet(frames, tensors.voxels, tensors.categories, tensors.ids,
                         input_config(dataset.config, protocol))
    from tqdm.auto import tqdm

    from e2vlib.data import load_grey_video
    from e2vlib.inputs import events_to_input
    from e2vlib.io import load_events

    source = _check_events_folder({**protocol, "data": str(root)}, split)
    representation = protocol["representation"]
    frames, voxels = [], []
    for index in tqdm(keep, desc=f"{representation} {split}", disable=not progress,
                      leave=False):
        sample_id = dataset.ids[index]
        if representation in GREY_INPUTS:
            x = grey_input(load_grey_video(source, sample_id), representation,
                           protocol["frame_size"])
        else:
            events, sensor = load_events(source / "events" / f"{sample_id}.npz")
            x = events_to_input(events, sensor, representation, protocol["frame_size"],
                                protocol["n_frames"], protocol["dt_us"])
        frames.append(torch.from_numpy(x if x.dtype in (np.uint8, np.float16)
                                       else x.astype(np.float16)))
        voxels.append(torch.from_numpy(dataset.arrays(index)[1]))
    return TensorSet(torch.stack(frames), torch.stack(voxels),
                     [dataset.categories[i] for i in keep],
                     [dataset.ids[i] for i in keep], input_config(dataset.config, protocol))


def train_counts(protocol: dict) -> dict[str, int]:
    """Training samples per category of a protocol: data_small's (the first
    ``per_category`` in quick mode) times ``train_scale``, rounded."""
    from e2vlib.data import E2VDataset

    base = E2VDataset(protocol["data"], "train").categories
    counts: dict[str, int] = {}
    for i in _first_per_category(base, protocol.get("per_category")):
        counts[base[i]] = counts.get(base[i], 0) + 1
    scale = protocol.get("train_scale", 1)
    return {c: int(round(n * scale)) for c, n in counts.items()}


def run_size(protocol: dict) -> dict:
    """``{"n_train", "epochs", "steps"}`` of a run of ``protocol`` (what :func:`run_one`
    records), from the training split's size per category."""
    from e2vlib.train import get_recipe

    n_train = sum(train_counts(protocol).values())
    batch = get_recipe(protocol["recipe"]).batch_size
    return {"n_train": n_train, "epochs": epochs_of(protocol),
            "steps": epochs_of(protocol) * -(-n_train // batch)}


def load_split(protocol: dict, split: str, progress: bool = False):
    """The ``split`` of the protocol's data as a :class:`~e2vlib.train.TensorSet` whose
    frames are the protocol's input, ``(N, D, S, S)`` or ``(N, C, D, S, S)``.

    Stored binary frames are used directly (max-pooled to a smaller ``frame_size``);
    every other input is computed from the raw events (or grey videos) in
    :func:`events_root` and kept in memory for the next run of the same process. With
    ``train_scale`` s, the training split holds s x data_small's samples per category: its
    first ones for s <= 1, all of them plus objects of ``protocol["extra"]`` (every split)
    for s > 1.
    """
    import torch


    key = _input_key(protocol, split)
    if key in _MEMORY:
        return _MEMORY[key]
    data = protocol["data"]
    if data in DATA_COMMANDS and not (Path(data) / "manifest.csv").exists():
        raise FileNotFoundError(f"this config trains on {data}; build it once with "
                                f"`{DATA_COMMANDS[data]}`")
    scale = protocol.get("train_scale", 1)
    if split != "train" or scale == 1:
        tensors = _tensors(protocol, protocol["data"], split, protocol.get("per_category"),
                           progress)
    else:
        wanted = train_counts(protocol)
        parts = [_tensors(protocol, protocol["data"], "train", wanted, progress)]
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
            raise ValueError(f"{protocol['extra']} holds too few objects for train_scale "
                             f"{scale} (missing per category: {short}); build more with "
                             f"`{EXTRA_COMMAND}`")
        extra_name = Path(protocol["extra"]).name  # ids restart in every build: name them
        ids = parts[0].ids + [f"{extra_name}/{i}" for t in parts[1:] for i in t.ids]
        tensors = TensorSet(torch.cat([t.frames for t in parts]),
                            torch.cat([t.voxels for t in parts]),
                            [c for t in parts for c in t.categories], ids, parts[0].config)
    while len(_MEMORY) >= _MEMORY_SPLITS:
        del _MEMORY[next(iter(_MEMORY))]
    _MEMORY[key] = tensors
    return tensors


def _extra_root(protocol: dict) -> Path:
    root = Path(protocol["extra"])
    if not (root / "manifest.csv").exists():
        raise FileNotFoundError(f"train_scale {protocol['train_scale']} needs more objects, "
                                f"in {root}; build them once with `{EXTRA_COMMAND}`")
    return root

