"""Reading a dataset: :class:`E2VDataset` (a PyTorch ``Dataset``) and :func:`verify_dataset`.

Reads e2vlib's own layout and the authors' SynthEVox3D release
(:mod:`e2vlib.data.synthevox3d`). Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch
from torch.utils.data import Dataset

from e2vlib import paper
from e2vlib.data.checks import SPLITS, DatasetError, inside
from e2vlib.data.commands import build_command
from e2vlib.data.config import dataset_config, frame_settings
from e2vlib.data.grey import load_grey_video
from e2vlib.data.manifest import npz_digest, read_manifest
from e2vlib.data.samples import load_sample
from e2vlib.data.synthevox3d import load_synthevox3d_scan, synthevox3d_items


class E2VDataset(Dataset):
    """A split of an E2V dataset as a PyTorch ``Dataset``.

    Items are dicts ``{"frames": float32 tensor (D, H, W) of 0/1, "voxels": float32
    tensor (32, 32, 32), "category": str, "id": str}``. Reads e2vlib's own layout (a
    ``manifest.csv`` in ``root``) or the authors' SynthEVox3D release (folders by ShapeNet
    synset holding ``<scan>/events.npz`` and ``<scan>/model_normalized.npz``), whose
    events are turned into the paper's 100 frames of 5 ms and max-pooled from 512 to
    ``frame_size`` (256 in the paper). Introduced in notebooks/04_building_the_dataset.ipynb.

    The folder is untrusted input (:mod:`e2vlib.data.checks`): the manifest and
    config.json are checked on reading, only files inside ``root`` are read, and every
    item's stored shapes are checked against config.json as it loads. ``verify=True`` also
    loads every item of the split now and checks it against the ``sha256`` the manifest
    recorded (what ``python -m e2vlib verify-data`` does for all splits). Problems raise
    :class:`DatasetError` naming the file and the fix.

    Examples
    --------
    The shipped ``data_small`` (78 test samples of 100 frames of 64 px):

    >>> import e2vlib
    >>> test = E2VDataset(Path(e2vlib.__file__).parents[1] / "data_small", "test")
    >>> len(test), test.input_shape, test.layout
    (78, (100, 64, 64), 'e2vlib')
    >>> item = test[0]
    >>> item["frames"].shape, item["voxels"].dtype, item["id"] == test.ids[0]
    (torch.Size([100, 64, 64]), torch.float32, True)
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
        elif (self.root / "config.json").exists():  # our layout, its manifest lost
            raise DatasetError(
                f"{self.root} has a config.json but no manifest.csv, so it is neither a "
                "finished e2vlib dataset nor a SynthEVox3D folder; a make-data run that "
                "stopped early writes its manifest when rerun with the same command (the "
                "config.json records its settings), or restore manifest.csv")
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


class Verification(NamedTuple):
    """What :func:`verify_dataset` found: ``checked`` samples, one line per bad one in
    ``problems``, and how many of them had no ``sha256`` in the manifest (``unhashed``:
    an older build; only their shapes could be checked).

    Examples
    --------
    >>> Verification(checked=3, problems=[], unhashed=0).problems  # all sound
    []
    """

    checked: int
    problems: list[str]
    unhashed: int


def verify_dataset(root: str | os.PathLike) -> Verification:
    """Check every sample of every split of ``root`` (:meth:`E2VDataset.check_item`: it
    loads as config.json says and matches the manifest's ``sha256`` where one is
    recorded). A manifest or config.json that cannot be read raises :class:`DatasetError`.
    What ``python -m e2vlib verify-data`` runs.

    Examples
    --------
    A dataset of three empty samples written by hand, then one of them changed:

    >>> import json, tempfile
    >>> from e2vlib.data import BuildConfig, plan_samples, save_sample, write_manifest
    >>> root = Path(tempfile.mkdtemp())
    >>> config = BuildConfig(categories=("chair",), per_category=3, resolution=16,
    ...                      frame_size=8, oversample=1)
    >>> _ = (root / "config.json").write_text(json.dumps(config.to_dict()))
    >>> (root / "samples").mkdir()
    >>> frames, label = np.zeros((100, 8, 8)), np.zeros((32, 32, 32))
    >>> for spec in plan_samples(config):
    ...     save_sample(root / "samples" / f"{spec.id}.npz", frames, label, n_events=0)
    >>> _ = write_manifest(root, plan_samples(config))
    >>> verify_dataset(root)
    Verification(checked=3, problems=[], unhashed=0)
    >>> save_sample(root / "samples" / "chair_0000.npz", frames + 1, label, n_events=0)
    >>> verify_dataset(root).problems  # doctest: +ELLIPSIS
    ['...chair_0000.npz does not match the sha256 its manifest recorded ...']
    """
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
