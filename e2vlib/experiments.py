"""Experiments: the paper's open questions as studies, one recorded run per (config, seed).

A *study* is a question (which event representation? how many frames? which encoder? which
loss?) and a set of named *configs*, each a small dict of what differs from the study's base
protocol. :func:`run_study` trains and evaluates every (config, seed) with the library's own
:func:`~e2vlib.train.fit` and :func:`~e2vlib.train.evaluate`, and appends one record per run
to ``OUT/STUDY.json`` (written atomically after every run). Runs already recorded are
skipped, so an interrupted study resumes where it stopped. :func:`summarize` turns a results
file into mean, standard deviation and a 95 % interval per config.

Command line: ``python -m e2vlib experiment STUDY [--configs ...] [--seeds 0 1 2]``.
Introduced in notebooks/09_event_representations_and_time.ipynb.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from e2vlib import paper
from e2vlib.files import atomic_path
from e2vlib.metrics import interval95

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = Path("experiments/results")
EVENTS_CACHE = Path("cache/events_small")
"""Where ``make-data`` puts data_small's samples with the raw events of every sample."""

EVENTS_COMMAND = ("python -m e2vlib make-data --out cache/events_small --preset small "
                  "--raw-events-per-category 64 --grey-video --workers 2")
"""The command that builds :data:`EVENTS_CACHE` (same objects and splits as data_small, with
the raw events and the grey video of every sample; about 6 min on 2 cores)."""

STORAGE_SETTINGS = ("raw_events_per_category", "grey_video", "splits")
"""Build settings that change what a folder stores, not the events or frames of a sample."""

NOISE_CACHE = "cache/noise_{level}"
"""Where the noise study finds data_small's objects simulated with sensor noise ``level``."""

NOISE_COMMANDS = {
    "medium": ("python -m e2vlib make-data --out cache/noise_medium --preset small "
               "--raw-events-per-category 64 --noise medium --workers 2"),
    **{level: (f"python -m e2vlib make-data --out cache/noise_{level} --preset small "
               f"--raw-events-per-category 64 --noise {level} --splits test --workers 2")
       for level in ("low", "high")},
}
"""The commands that build :data:`NOISE_CACHE` per level (``medium``: every split, to train
on; the others: the test split only; about 6 and 1 min on 2 cores)."""

EXTRA_CACHE = "cache/extra_small"
EXTRA_COMMAND = ("python -m e2vlib make-data --out cache/extra_small --preset small --seed 1 "
                 "--per-category 156 --workers 2")
"""More objects of data_small's kind (another seed, so other shapes): every split of it is
extra training data for the data_scale study, up to 4 x data_small's 52 per category."""

RENDER_CACHE = "cache/render_none"
RENDER_COMMAND = ("python -m e2vlib make-data --out cache/render_none --preset small "
                  "--anti-aliasing none --workers 2")
"""data_small's objects and splits rendered without anti-aliasing (the render study; about
1.5 min on 2 cores)."""

DATA_COMMANDS = {RENDER_CACHE: RENDER_COMMAND}
"""Commands that build the dataset folders a study's ``data`` may name besides data_small."""

GREY_INPUTS: dict[str, str] = {
    "grey_video": "the rendered grey frames of the same orbit at the event frames' times",
    "grey_single": "one grey view (the orbit's first frame), for a 2D encoder",
}
"""Inputs of the input study that are not events (read from the cache's grey videos)."""

BASE: dict = {
    "data": "data_small",
    "events": str(EVENTS_CACHE),
    "representation": "binary",
    "n_frames": paper.N_EVENT_FRAMES,
    "dt_us": paper.DT_US,
    "frame_size": paper.FRAME_SIZE_PX,
    "preset": "tiny",
    "loss": "bce",
    "recipe": "tiny",
    "epochs": 12,
    "threads": 2,
}
"""The shared protocol: every config of every study changes only some of these keys."""

QUICK: dict = {"epochs": 1, "per_category": 2, "frame_size": 32}
"""Quick mode (CI, live lesson demos): 2 training samples per category, 1 epoch, 32 px."""

THRESHOLDS = tuple(np.round(np.arange(0.05, 0.96, 0.05), 2).tolist())
"""Candidate voxelisation thresholds for the one picked on the validation split."""


@dataclass(frozen=True)
class Study:
    """A question and the configs that answer it (``config name -> params``)."""

    name: str
    question: str
    configs: dict[str, dict]
    base: dict = field(default_factory=dict)

    def protocol(self, quick: bool = False) -> dict:
        """The base protocol of this study (``BASE`` + the study's own base + quick)."""
        return {**BASE, **self.base, **(QUICK if quick else {})}


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
        base={"recipe": "tiny_step"},
    ),
}
"""The studies of issues 12, 13, 15 and 25, by name."""

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

NEUTRAL: dict[str, tuple[object, tuple[str, ...]]] = {
    "train_scale": (1, ("train_scale", "extra")),
    "noise": ("clean", ("noise", "noise_events", "test_noise")),
}
"""Protocol keys that change nothing about training at their base value, with that value and
the keys that go with them (``train_scale`` 1 is data_small's own training set, ``noise``
"clean" its own events; ``test_noise`` only adds test scores): :func:`canonical_protocol`
drops them."""


def canonical_protocol(protocol: dict) -> dict:
    """``protocol`` without the keys that change nothing at their value (:data:`NEUTRAL`),
    so ``data_scale``'s ``1x`` is the same training run as ``representation``'s ``binary``
    or ``noise``'s ``train_clean`` (whose record only holds more test scores).

    Examples
    --------
    >>> canonical_protocol({"epochs": 12, "train_scale": 1, "extra": "cache/extra_small"})
    {'epochs': 12}
    >>> canonical_protocol({"epochs": 12, "train_scale": 2, "extra": "x"})["train_scale"]
    2
    >>> canonical_protocol({"epochs": 12, "noise": "clean", "test_noise": ["high"]})
    {'epochs': 12}
    """
    out = dict(protocol)
    for key, (base, keys) in NEUTRAL.items():
        if out.get(key, base) == base:
            for dropped in keys:
                out.pop(dropped, None)
    return out


def epochs_of(protocol: dict) -> int:
    """Epochs of a run: ``epochs`` over data_small's training set, scaled by ``1 /
    train_scale`` so that every size of the data_scale study takes the same number of
    steps (within one batch per epoch).

    Examples
    --------
    >>> [epochs_of({"epochs": 12, "train_scale": s}) for s in (0.25, 1, 4)]
    [48, 12, 3]
    """
    return max(1, round(protocol["epochs"] / protocol.get("train_scale", 1)))


# ----------------------------------------------------------------------------- data


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
        level, f"python -m e2vlib make-data --out {events} --preset small "
               f"--raw-events-per-category 64 --noise {level}")
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


def grey_input(grey: np.ndarray, representation: str, frame_size: int) -> np.ndarray:
    """The model input made from a stored grey video ``(n_frames, S, S)`` uint8: grey levels
    in [0, 1] as float16, block-averaged to ``frame_size``; ``"grey_single"`` keeps only the
    first frame, ``(1, frame_size, frame_size)``.

    Examples
    --------
    >>> grey = np.arange(2 * 4 * 4, dtype=np.uint8).reshape(2, 4, 4) * 5
    >>> x = grey_input(grey, "grey_single", 2)   # block (0, 0): (0 + 5 + 20 + 25) / 4 / 255
    >>> x.shape, x.dtype, round(float(x[0, 0, 0]), 3)
    ((1, 2, 2), dtype('float16'), 0.049)
    """
    from e2vlib.frames import downsample

    if representation not in GREY_INPUTS:
        raise ValueError(f"unknown grey input {representation!r}; choose one of "
                         f"{', '.join(GREY_INPUTS)}")
    frames = np.asarray(grey)[:1] if representation == "grey_single" else np.asarray(grey)
    factor = frames.shape[-1] // frame_size
    if factor * frame_size != frames.shape[-1]:
        raise ValueError(f"frame_size {frame_size} must divide the grey video's "
                         f"{frames.shape[-1]} px")
    means = downsample(frames.astype(np.float32), factor, "sum") / (factor * factor * 255.0)
    return means.astype(np.float16)


def _tensors(protocol: dict, root: str | os.PathLike, split: str,
             per_category: int | dict | None, progress: bool):
    """One split of the dataset at ``root`` as the protocol's inputs (see load_split)."""
    import torch

    from e2vlib.data import E2VDataset
    from e2vlib.frames import downsample
    from e2vlib.train import TensorSet, preload

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

    from e2vlib.train import TensorSet

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


# ----------------------------------------------------------------------------- one run


def _commit() -> str:
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, text=True,
                              capture_output=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "e2vlib"], cwd=REPO, text=True,
                               capture_output=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("-dirty" if dirty else "")


def cpu_name() -> str:
    """The CPU's model name (``/proc/cpuinfo``, else :func:`platform.processor`).

    Floating-point results of training depend on the CPU's vector kernels: the same
    protocol and seed give the same run on one CPU model, bit for bit, but not across models
    (measured: three seeds trained on an AMD EPYC and an Intel Xeon differed by 0.008-0.026
    test IoU@0.3). Records carry it, and :func:`find_same_run` copies only runs of the same
    CPU.
    """
    import platform

    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def best_threshold(probabilities, voxels, thresholds: Iterable[float] = THRESHOLDS) -> float:
    """The threshold of ``thresholds`` with the highest mean IoU (ties: the lowest).

    Examples
    --------
    >>> gt = np.zeros((1, 32, 32, 32)); gt[0, :8] = 1
    >>> p = np.where(gt > 0, 0.62, 0.58)     # only thresholds in (0.58, 0.62] separate them
    >>> best_threshold(p, gt)
    0.6
    """
    from e2vlib.metrics import iou

    scores = [float(np.mean(iou(probabilities, voxels, threshold=t))) for t in thresholds]
    return float(list(thresholds)[int(np.argmax(scores))])


def run_one(protocol: dict, seed: int, device: str = "auto", workdir: Path | None = None,
            progress: bool = False) -> dict:
    """Train and evaluate one (protocol, seed); return its record (without config name)."""
    import tempfile

    import torch

    from e2vlib.inputs import input_channels
    from e2vlib.metrics import iou
    from e2vlib.metrics import summarize as summarize_scores
    from e2vlib.model import build_e2v, load_checkpoint
    from e2vlib.train import fit, predict, resolve_device, score_predictions

    torch.set_num_threads(int(protocol["threads"]))
    train = load_split(protocol, "train", progress)
    val = load_split(protocol, "val", progress)
    test = load_split(protocol, "test", progress)
    representation = protocol["representation"]
    channels = 1 if representation in GREY_INPUTS else input_channels(representation)
    shape = tuple(train.frames.shape[-3:])
    overrides = {"in_channels": channels} if channels > 1 else {}
    model = build_e2v(protocol["preset"], seed=seed, input_shape=shape, **overrides)
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        started = time.perf_counter()
        history = fit(model, train, val, tmp, recipe=protocol["recipe"],
                      epochs=epochs_of(protocol), device=device, seed=seed,
                      loss=protocol["loss"], progress=progress)
        train_seconds = time.perf_counter() - started
        best = load_checkpoint(Path(tmp) / "best.pt")
    val_probabilities = predict(best, val.frames, device)
    threshold = best_threshold(val_probabilities, val.voxels)
    # the test predictions once, scored as evaluate() scores them
    test_probabilities = predict(best, test.frames, device)
    result = summarize_scores(score_predictions(test_probabilities, test.voxels),
                              test.categories)
    metrics = {k: float(v) for k, v in result["overall"].items()}
    metrics["val_threshold"] = threshold
    metrics["iou@val_threshold"] = float(np.mean(iou(test_probabilities, test.voxels,
                                                     threshold=threshold)))
    metrics["per_category_iou@0.3"] = {c: float(v["iou@0.3"])
                                      for c, v in result["per_category"].items()}
    def other_test(name: str, changes: dict, at_val_threshold: bool) -> None:
        """Score the same model on another test split: ``name:iou@0.3`` etc."""
        other = load_split({**protocol, **changes}, "test", progress)
        probabilities = predict(best, other.frames, device)
        scores = summarize_scores(score_predictions(probabilities, other.voxels),
                                  other.categories)["overall"]
        metrics.update({f"{name}:{k}": float(scores[k]) for k in ("iou@0.3", "fscore@1%")})
        if at_val_threshold:
            metrics[f"{name}:iou@val_threshold"] = float(np.mean(iou(
                probabilities, other.voxels, threshold=threshold)))

    for name, root in protocol.get("test_data", {}).items():  # other data, e.g. renders
        other_test(name, {"data": root}, at_val_threshold=False)
    for level in protocol.get("test_noise", ()):  # other noise levels
        other_test(level, {"noise": level}, at_val_threshold=True)
    best_epoch = max(history, key=lambda h: h["val_iou"])
    from e2vlib.model import count_parameters

    return {
        "seed": int(seed),
        "metrics": metrics,
        **run_size(protocol),
        "best_epoch": int(best_epoch["epoch"]),
        "best_val_iou@0.3": float(best_epoch["val_iou"]),
        "n_parameters": count_parameters(best),
        "train_seconds": round(train_seconds, 1),
        "device": str(resolve_device(device)),
        "cpu": cpu_name(),
        "torch": torch.__version__,
        "commit": _commit(),
    }


# ----------------------------------------------------------------------------- a study


def _read(path: Path) -> dict | None:
    if not path.exists():
        return None
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise ValueError(f"{path} is not valid JSON ({err}); move it away to start the "
                         "study afresh") from err


def _write(path: Path, results: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(results, indent=1) + "\n")


def command_line(study: str, configs: Sequence[str] | None, seeds: Sequence[int],
                 quick: bool, reuse: bool = True) -> str:
    """The command that reproduces (or resumes) a study."""
    parts = ["python -m e2vlib experiment", study]
    if configs:
        parts += ["--configs", *configs]
    parts += ["--seeds", *map(str, seeds)]
    if quick:
        parts.append("--quick")
    if not reuse:
        parts.append("--no-reuse")
    return " ".join(parts)


def find_same_run(out: Path, protocol: dict, seed: int, device: str,
                  exclude: Path | None = None, cpu: str | None = None) -> dict | None:
    """A run recorded in another study file of ``out`` with exactly this full ``protocol``
    (its study's protocol + its params), ``seed``, ``device`` and CPU model (``cpu``,
    default :func:`cpu_name`), or None.

    Training on one CPU model is deterministic for a protocol and seed (same threads), so
    such a run is the run this one would be; the encoder study's ``resnet3d`` runs, made
    afresh with ``--no-reuse``, check that against the representation study's ``binary``
    runs. Records that do not name their CPU (made before records carried it) are never
    copied. The returned record names its origin in ``reused_from`` (``"study/config"``).
    """
    cpu = cpu_name() if cpu is None else cpu
    for other in sorted(Path(out).glob("*.json")):
        if exclude is not None and other.resolve() == exclude.resolve():
            continue
        try:
            results = json.loads(other.read_text())
        except (OSError, json.JSONDecodeError):
            continue
        if not isinstance(results, dict) or "protocol" not in results:
            continue
        for run in results.get("runs", []):
            if (run.get("seed") == seed and run.get("device") == device
                    and run.get("cpu") == cpu
                    and canonical_protocol({**results["protocol"], **run.get("params", {})})
                    == canonical_protocol(protocol)):
                origin = run.get("reused_from", f"{results.get('study', other.stem)}/"
                                                f"{run['config']}")
                kept = {k: v for k, v in run.items() if k not in ("config", "params")}
                return {**kept, "reused_from": origin}
    return None


def run_study(study: str, configs: Sequence[str] | None = None,
              seeds: Sequence[int] = (0, 1, 2), out: str | os.PathLike = DEFAULT_OUT,
              device: str = "auto", quick: bool = False, progress: bool = True,
              base_overrides: dict | None = None, reuse: bool = True) -> Path:
    """Run every (config, seed) of ``study`` not yet in ``OUT/STUDY.json``; return the path.

    ``base_overrides`` changes the shared protocol (for example ``{"data": ...}`` in tests);
    a results file whose protocol differs from this one is refused, so results made under
    different protocols never mix. With ``reuse``, a (config, seed) whose full protocol was
    already run by another study in ``out`` (``100x5ms`` of ``time`` is ``binary`` of
    ``representation``) is copied from there (:func:`find_same_run`) instead of trained again.
    The file's ``command`` is the latest invocation, ``commands`` every one that added runs.
    """
    from tqdm.auto import tqdm

    if study not in STUDIES:
        raise ValueError(f"unknown study {study!r}; choose one of {', '.join(STUDIES)}")
    spec = STUDIES[study]
    names = list(configs) if configs else list(spec.configs)
    unknown = [n for n in names if n not in spec.configs]
    if unknown:
        raise ValueError(f"study {study!r} has no configs {unknown}; it has "
                         f"{', '.join(spec.configs)}")
    if not seeds:
        raise ValueError("give at least one seed")
    protocol = {**spec.protocol(quick), **(base_overrides or {})}
    path = Path(out) / f"{study}.json"
    results = _read(path) or {"study": study, "question": spec.question,
                              "protocol": protocol, "runs": []}
    if results["protocol"] != protocol:
        raise ValueError(f"{path} holds runs of another protocol ({results['protocol']}); "
                         f"use another --out folder to run this one ({protocol})")
    results["command"] = command_line(study, configs, seeds, quick, reuse)
    commands = results.setdefault("commands", [])  # every invocation that added runs, in order
    if results["command"] not in commands:
        commands.append(results["command"])
    done = {(r["config"], r["seed"]) for r in results["runs"]}
    todo = [(n, s) for n in names for s in seeds if (n, int(s)) not in done]
    bar = tqdm(todo, desc=f"{study} runs", unit="run", disable=not progress)
    for name, seed in bar:
        bar.set_postfix(config=name, seed=seed)
        params = spec.configs[name]
        record = None
        if reuse:
            from e2vlib.train import resolve_device

            record = find_same_run(path.parent, {**protocol, **params}, int(seed),
                                   str(resolve_device(device)), exclude=path)
        if record is None:
            record = run_one({**protocol, **params}, int(seed), device=device,
                             progress=progress)
        else:  # records made before runs noted their size get it from the protocol
            record = {**run_size({**protocol, **params}), **record}
        results["runs"].append({"config": name, "params": params, **record})
        _write(path, results)
        if progress:
            origin = f", copied from {record['reused_from']}" if "reused_from" in record else ""
            tqdm.write(f"{study}/{name} seed {seed}: test IoU@0.3 "
                       f"{record['metrics']['iou@0.3']:.3f} ({record['train_seconds']:.0f} s"
                       f"{origin})")
    if not todo:
        _write(path, results)
    return path


# ----------------------------------------------------------------------------- summaries


def summarize(results: dict | str | os.PathLike, metric: str = "iou@0.3") -> list[dict]:
    """Mean, standard deviation and 95 % interval of ``metric`` per config, in study order.

    Each row: ``{"config", "params", "n", "mean", "std", "ci95": (low, high), "values"}``;
    the interval is Student's t over the seeds (``std`` with ``ddof=1``; NaN for one seed).

    Examples
    --------
    >>> runs = [{"config": "a", "params": {}, "seed": s, "metrics": {"iou@0.3": v}}
    ...         for s, v in enumerate([0.40, 0.42, 0.44])]
    >>> row = summarize({"runs": runs})[0]
    >>> row["n"], round(row["mean"], 3), round(row["std"], 3)
    (3, 0.42, 0.02)
    >>> [round(v, 3) for v in row["ci95"]]   # 0.42 -+ 4.303 * 0.02 / sqrt(3)
    [0.37, 0.47]
    """

    if not isinstance(results, dict):
        results = json.loads(Path(results).read_text())
    rows: dict[str, dict] = {}
    for run in results["runs"]:
        row = rows.setdefault(run["config"], {"config": run["config"],
                                              "params": run.get("params", {}), "values": []})
        row["values"].append(float(run["metrics"][metric]))
    for row in rows.values():
        values = np.asarray(row["values"])
        row["n"] = len(values)
        row["mean"] = float(values.mean())
        row["std"] = float(values.std(ddof=1)) if len(values) > 1 else float("nan")
        row["ci95"] = interval95(values)
    return list(rows.values())


def format_summary(rows: list[dict], metric: str = "iou@0.3") -> str:
    """A markdown table of :func:`summarize` rows."""
    lines = [f"| config | n | {metric} mean ± std | 95 % interval |", "| --- | --- | --- | --- |"]
    for row in rows:
        lines.append(f"| {row['config']} | {row['n']} | {row['mean']:.3f} ± {row['std']:.3f} | "
                     f"{row['ci95'][0]:.3f}–{row['ci95'][1]:.3f} |")
    return "\n".join(lines)


def plot_summary(rows: list[dict], ax=None, metric: str = "iou@0.3",
                 reference: float | None = None,
                 title: str | None = None):
    """Bar chart of :func:`summarize` rows: mean with 95 % interval error bars, seeds as dots.

    ``reference`` draws a dashed line (e.g. the base config's mean). Returns the axes.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(1.1 * len(rows) + 2, 3.2))
    x = np.arange(len(rows))
    means = [r["mean"] for r in rows]
    errors = np.array([[r["mean"] - r["ci95"][0], r["ci95"][1] - r["mean"]] for r in rows]).T
    ax.bar(x, means, color="#8fa8c8", width=0.6, yerr=np.nan_to_num(errors), capsize=4,
           label="mean, 95 % interval")
    for i, row in enumerate(rows):
        ax.plot(np.full(len(row["values"]), i) + np.linspace(-0.12, 0.12, len(row["values"])),
                row["values"], "o", color="#333333", markersize=3.5,
                label="one seed" if i == 0 else None)
    if reference is not None:
        ax.axhline(reference, color="#d62728", linestyle="--", linewidth=1)
    ax.set_xticks(x, [r["config"] for r in rows], rotation=20, ha="right")
    ax.set_ylabel(f"test {metric}")
    low = min(min(r["values"]) for r in rows)
    ax.set_ylim(max(0.0, low - 0.1), min(1.0, max(max(r["values"]) for r in rows) + 0.06))
    if title:
        ax.set_title(title)
    ax.legend(loc="lower right", fontsize=8)
    return ax


def is_real_difference(row: dict, base: dict) -> bool:
    """True when the 95 % intervals of two :func:`summarize` rows do not overlap (the one
    rule every study lesson uses for "a real difference"); False when either has one seed."""
    low, high = row["ci95"]
    base_low, base_high = base["ci95"]
    if not all(np.isfinite([low, high, base_low, base_high])):
        return False
    return bool(low > base_high or high < base_low)


def compare(rows: list[dict], baseline: str) -> list[dict]:
    """Each config's difference from ``baseline``, with Welch's t-test p-value over seeds.

    Returns ``[{"config", "difference", "p_value", "clear"}]`` where ``clear`` is
    :func:`is_real_difference` (a conservative reading with 3 seeds).
    """
    from scipy import stats

    base = next((r for r in rows if r["config"] == baseline), None)
    if base is None:
        raise ValueError(f"no config {baseline!r} among {[r['config'] for r in rows]}")
    out = []
    for row in rows:
        if row is base:
            continue
        p = (float(stats.ttest_ind(row["values"], base["values"], equal_var=False).pvalue)
             if row["n"] > 1 and base["n"] > 1 else float("nan"))
        out.append({"config": row["config"], "difference": row["mean"] - base["mean"],
                    "p_value": p, "clear": is_real_difference(row, base)})
    return out
