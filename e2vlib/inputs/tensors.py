"""A split held in memory: :class:`TensorSet` (model inputs and labels as tensors, indexed like
a dataset), and :func:`preload`, which fills one from a dataset."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch


@dataclass
class TensorSet:
    """In memory: frames uint8 ``(N, n_frames, H, W)``, voxels bool ``(N, 32, 32, 32)``.

    Frames may also have a channel axis, ``(N, C, n_frames, H, W)`` (e.g. the polarity
    representation's OFF and ON counts, for a model with ``in_channels=C``), and any dtype
    (uint8 for binary frames, float16/float32 for counts or time surfaces): only the
    first (sample) axis is ever indexed, and batches become float32 on the fly.

    ``categories`` and ``ids`` hold one string per sample; ``config`` is the dataset's
    build settings (a dict, or None), which :func:`fit` stores in its checkpoints.
    Indexing works like a dataset: ``data[i]`` (an int) is the item dict
    ``{"frames": float32 (n_frames, H, W) (or (C, n_frames, H, W)), "voxels": float32
    (32, 32, 32), "category", "id"}`` of :class:`~e2vlib.data.E2VDataset`; a slice, a
    sequence of ints or a boolean mask gives a smaller TensorSet (:meth:`subset`).

    Examples
    --------
    >>> data = TensorSet(torch.zeros(4, 2, 8, 8, dtype=torch.uint8),
    ...                  torch.zeros(4, 32, 32, 32, dtype=torch.bool),
    ...                  ["chair", "chair", "lamp", "lamp"], ["c0", "c1", "l0", "l1"])
    >>> data[2]["id"], data[2]["frames"].dtype
    ('l0', torch.float32)
    >>> data[1:3].ids, data[[3, 0]].categories
    (['c1', 'l0'], ['lamp', 'chair'])
    """

    frames: torch.Tensor
    voxels: torch.Tensor
    categories: list[str]
    ids: list[str]
    config: dict | None = None

    def __post_init__(self) -> None:
        sizes = {"frames": len(self.frames), "voxels": len(self.voxels),
                 "categories": len(self.categories), "ids": len(self.ids)}
        if len(set(sizes.values())) != 1:
            raise ValueError(f"TensorSet parts must have one entry per sample, got {sizes}")

    def __len__(self) -> int:
        return len(self.ids)

    def __getitem__(self, key) -> dict | TensorSet:
        if _is_scalar_index(key):
            i = int(key)
            if not -len(self) <= i < len(self):
                raise IndexError(f"index {i} is out of range for a TensorSet of {len(self)} "
                                 "samples")
            i %= len(self)
            return {"frames": self.frames[i].float(), "voxels": self.voxels[i].float(),
                    "category": self.categories[i], "id": self.ids[i]}
        return self.subset(key)

    def subset(self, indices) -> TensorSet:
        """The samples at ``indices`` (a slice, ints, or a boolean mask), as a TensorSet.

        Order follows ``indices``; tensors are copied (advanced indexing), ``config`` is
        shared.
        """
        idx = self._positions(indices)
        rows = torch.from_numpy(idx)
        return TensorSet(self.frames[rows], self.voxels[rows],
                         [self.categories[i] for i in idx], [self.ids[i] for i in idx],
                         self.config)

    def _positions(self, indices) -> np.ndarray:
        n = len(self)
        if isinstance(indices, slice):
            return np.arange(n)[indices]
        if isinstance(indices, torch.Tensor):
            indices = indices.detach().cpu().numpy()
        arr = np.asarray(indices)
        if arr.size == 0:
            return np.zeros(0, dtype=np.int64)
        if arr.dtype == bool:
            if arr.shape != (n,):
                raise IndexError(f"a boolean mask must have one entry per sample ({n}), got "
                                 f"shape {arr.shape}")
            return np.flatnonzero(arr)
        if arr.ndim != 1 or not np.issubdtype(arr.dtype, np.integer):
            raise IndexError("index a TensorSet with an int, a slice, a 1-D sequence of ints "
                             f"or a boolean mask, got {type(indices).__name__} "
                             f"of dtype {arr.dtype} and shape {arr.shape}")
        if arr.min() < -n or arr.max() >= n:
            raise IndexError(f"indices must be in -{n} .. {n - 1} for a TensorSet of {n} "
                             f"samples, got {arr.min()} .. {arr.max()}")
        return arr.astype(np.int64) % n


def _is_scalar_index(key: object) -> bool:
    if isinstance(key, torch.Tensor):
        return key.ndim == 0 and not key.is_floating_point() and key.dtype != torch.bool
    return isinstance(key, int | np.integer) and not isinstance(key, bool | np.bool_)


def preload(dataset, progress: bool = False) -> TensorSet:
    """Load every item of an :class:`~e2vlib.data.E2VDataset` (or a :class:`TensorSet`) once.

    Frames stay uint8 (4x smaller than float); batches are converted on the fly. The
    dataset's ``config`` (its build settings, when it has them) goes along.

    Examples
    --------
    >>> class Two:  # anything with arrays(i), categories and ids, as E2VDataset has
    ...     categories, ids, config = ["chair", "lamp"], ["c0", "l0"], None
    ...     def __len__(self):
    ...         return 2
    ...     def arrays(self, i):
    ...         return np.full((4, 8, 8), i, np.uint8), np.zeros((32, 32, 32), bool)
    >>> data = preload(Two())
    >>> tuple(data.frames.shape), data.frames.dtype, data.ids, int(data.frames[1].max())
    ((2, 4, 8, 8), torch.uint8, ['c0', 'l0'], 1)
    >>> preload(data) is data   # a TensorSet is already in memory
    True
    """
    if isinstance(dataset, TensorSet):
        return dataset
    from tqdm.auto import tqdm

    frames, voxels = [], []
    for index in tqdm(range(len(dataset)), desc="loading", disable=not progress, leave=False):
        f, v = dataset.arrays(index)
        frames.append(torch.from_numpy(np.ascontiguousarray(f, dtype=np.uint8)))
        voxels.append(torch.from_numpy(np.ascontiguousarray(v, dtype=bool)))
    ids = getattr(dataset, "ids", None)
    if ids is None:
        ids = [item[0] for item in dataset.items]
    return TensorSet(torch.stack(frames), torch.stack(voxels), list(dataset.categories),
                     list(ids), settings_dict(getattr(dataset, "config", None)))


def settings_dict(config: object) -> dict | None:
    """A dataset's build settings as a dict (a dict, or an object with ``to_dict``)."""
    if hasattr(config, "to_dict"):
        config = config.to_dict()
    return dict(config) if isinstance(config, dict) else None

