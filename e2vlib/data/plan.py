"""Sample planning: which objects a build makes, their split and seed, and shards of it.

:func:`plan_samples` gives every :class:`SampleSpec` of a :class:`~e2vlib.data.config.BuildConfig`
(the same whatever shard or split is built); :func:`parse_shard` reads ``--shard i/n``;
:func:`raw_event_ids` says which samples keep their raw events.
Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from e2vlib.data.config import BuildConfig

SPLIT_FRACTIONS = (0.8, 0.1, 0.1)  # the paper's 832 : 104 : 104 is 8 : 1 : 1


@dataclass(frozen=True)
class SampleSpec:
    """Which object a sample shows, its split, and the seed that makes it.

    Examples
    --------
    >>> config = BuildConfig(categories=("chair",), per_category=10)
    >>> plan_samples(config)[0]
    SampleSpec(id='chair_0000', category='chair', index=0, split='test', seed=190028277)
    """

    id: str
    category: str
    index: int
    split: str
    seed: int


def sample_seed(seed: int, category: str, index: int) -> int:
    """A stable 31-bit seed for sample ``index`` of ``category`` (independent of order).

    Examples
    --------
    >>> sample_seed(0, "chair", 0), sample_seed(1, "chair", 0)  # the build seed changes it
    (190028277, 1365701724)
    """
    digest = hashlib.sha256(f"{seed}/{category}/{index}".encode()).digest()
    return int.from_bytes(digest[:4], "little") & 0x7FFFFFFF


def plan_samples(config: BuildConfig) -> list[SampleSpec]:
    """All samples of a build, with their 8:1:1 split (shuffled per category, seeded).

    Per category, ``round(0.1 n)`` samples (at least one when n >= 3) go to val and to
    test, the rest to train. Introduced in notebooks/04_building_the_dataset.ipynb.

    Examples
    --------
    >>> from collections import Counter
    >>> specs = plan_samples(BuildConfig(categories=("chair", "lamp"), per_category=10))
    >>> len(specs), Counter(s.split for s in specs)
    (20, Counter({'train': 16, 'test': 2, 'val': 2}))
    >>> specs[:2] == plan_samples(BuildConfig(categories=("chair",), per_category=10))[:2]
    True
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


def parse_shard(text: str) -> tuple[int, int]:
    """``"i/n"`` -> ``(i, n)`` with ``0 <= i < n``.

    Examples
    --------
    >>> parse_shard("1/4")
    (1, 4)
    >>> parse_shard("4/4")
    Traceback (most recent call last):
    ...
    ValueError: shard '4/4': need 0 <= i < n
    """
    try:
        i, n = (int(v) for v in text.split("/"))
    except ValueError as err:
        raise ValueError(f"shard must look like i/n (e.g. 0/4), got {text!r}") from err
    if not 0 <= i < n:
        raise ValueError(f"shard {text!r}: need 0 <= i < n")
    return i, n


def raw_event_ids(specs: Sequence[SampleSpec], per_category: int) -> set[str]:
    """Ids whose raw events are kept: the first test samples of each category.

    Examples
    --------
    >>> specs = plan_samples(BuildConfig(categories=("chair", "lamp"), per_category=10))
    >>> sorted(raw_event_ids(specs, 1))  # the first test sample of each category
    ['chair_0000', 'lamp_0008']
    """
    keep, seen = set(), {}
    for spec in sorted(specs, key=lambda s: (s.split != "test", s.index)):
        if seen.get(spec.category, 0) < per_category:
            keep.add(spec.id)
            seen[spec.category] = seen.get(spec.category, 0) + 1
    return keep
