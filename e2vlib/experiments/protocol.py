"""A study's protocol: every setting of one training run, typed, and what follows from them.

:class:`Protocol` holds the settings (its defaults are the protocol every study shares);
a study's config changes some of them (:meth:`Protocol.updated`). From the settings follow
the folder of raw events to read (:attr:`~Protocol.events_root`), whether stored frames can
be used (:meth:`~Protocol.needs_events`), the run's epochs and size
(:attr:`~Protocol.run_epochs`, :meth:`~Protocol.run_size`) and which protocols are the same
training run (:meth:`~Protocol.canonical`). A record stores :meth:`~Protocol.to_dict`;
:meth:`~Protocol.from_dict` reads it back and names any key it does not know.

Examples
--------
>>> p = Protocol().updated({"frame_size": 128})
>>> p.frame_size, p.run_epochs, p.to_dict()["frame_size"]
(128, 12, 128)
>>> Protocol.from_dict({"epoch": 3})
Traceback (most recent call last):
...
ValueError: unknown protocol keys ['epoch']; a protocol has data, events, representation, \
n_frames, dt_us, frame_size, preset, loss, recipe, epochs, threads, noise, noise_events, \
test_noise, train_scale, extra, test_data, per_category, pose_noise
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path

from e2vlib import paper
from e2vlib.experiments.caches import EVENTS_CACHE


@dataclass(frozen=True)
class Protocol:
    """Every setting of one training run of a study; the defaults are the shared protocol.

    The first eleven fields are always recorded. The optional ones (``None``: not set) are
    recorded only when a study sets them, so every record keeps its shape.
    """

    data: str = "data_small"  # the dataset folder trained and tested on
    events: str = str(EVENTS_CACHE)  # its raw events and grey videos (computed inputs)
    representation: str = "binary"  # the input (e2vlib.inputs), or a grey video input
    n_frames: int = paper.N_EVENT_FRAMES  # frames per sample
    dt_us: int = paper.DT_US  # frame length [us]
    frame_size: int = paper.FRAME_SIZE_PX  # frame side [px]
    preset: str = "tiny"  # model preset (e2vlib.model.build_e2v)
    loss: str = "bce"
    recipe: str = "tiny"  # training recipe (e2vlib.train.get_recipe)
    epochs: int = 12  # epochs over data_small's training set (see run_epochs)
    threads: int = 2  # torch threads
    noise: str | None = None  # sensor noise of the training events (None: clean)
    noise_events: str | None = None  # folder of noisy events, "{level}" in its name
    test_noise: tuple[str, ...] | None = None  # more noise levels the model is tested at
    train_scale: float | None = None  # training samples, times data_small's (None: 1)
    extra: str | None = None  # a dataset of more objects, for train_scale > 1
    test_data: tuple[tuple[str, str], ...] | None = None  # (name, dataset) tested on too
    per_category: int | None = None  # only the first of each category (quick mode)
    # (max camera angle error [deg], max relative radius error): each train and val label is
    # remade as its object seen through an orbit error drawn per object (pose_study)
    pose_noise: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for name in ("n_frames", "dt_us", "frame_size", "epochs", "threads"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"protocol {name} must be a positive integer, got {value!r}")
        if self.scale <= 0:
            raise ValueError(f"protocol train_scale must be above 0, got {self.train_scale}")
        if self.scale > 1 and self.extra is None:
            raise ValueError(f"train_scale {self.train_scale} needs more objects: set extra to "
                             "a dataset folder of them")
        if self.pose_noise is not None:
            if (len(self.pose_noise) != 2 or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v < 90
                    for v in self.pose_noise) or self.pose_noise[1] >= 1):
                raise ValueError(f"protocol pose_noise must be (max degrees, max relative "
                                 f"radius error), each >= 0 (radius below 1), got "
                                 f"{self.pose_noise!r}")
            if self.scale != 1:
                raise ValueError("pose_noise remakes data_small's own labels; it cannot be "
                                 "combined with train_scale")
        if self.noise_level != "clean" and self.noise_events is None:
            raise ValueError(f"noise {self.noise!r} needs noise_events, the folder of the "
                             "noisy events with '{level}' in its name")

    # --------------------------------------------------------------- reading and writing

    @classmethod
    def from_dict(cls, values: Mapping) -> Protocol:
        """The protocol of a record's dict (missing keys: the defaults); unknown keys are
        refused with the list of known ones."""
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise ValueError(f"unknown protocol keys {unknown}; a protocol has "
                             f"{', '.join(names)}")
        values = dict(values)
        if values.get("test_noise") is not None:  # a JSON list
            values["test_noise"] = tuple(values["test_noise"])
        if values.get("test_data") is not None:  # a JSON object
            values["test_data"] = tuple(dict(values["test_data"]).items())
        if values.get("pose_noise") is not None:  # a JSON list
            values["pose_noise"] = tuple(values["pose_noise"])
        return cls(**values)

    def to_dict(self) -> dict:
        """The dict a record stores: every field that is set, in field order (JSON types)."""
        out: dict = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None:
                continue
            if f.name in ("test_noise", "pose_noise"):
                value = list(value)
            elif f.name == "test_data":
                value = dict(value)
            out[f.name] = value
        return out

    def updated(self, changes: Mapping) -> Protocol:
        """This protocol with ``changes`` (a config's params: ``{key: value}``)."""
        return Protocol.from_dict({**self.to_dict(), **changes})

    # --------------------------------------------------------------- what follows from it

    @property
    def noise_level(self) -> str:
        """The training events' noise preset: ``noise``, or ``"clean"`` when not set."""
        return self.noise or "clean"

    @property
    def scale(self) -> float:
        """``train_scale``, or 1 (data_small's own training set) when not set."""
        return 1 if self.train_scale is None else self.train_scale

    @property
    def run_epochs(self) -> int:
        """Epochs of a run: ``epochs`` scaled by ``1 / train_scale``, so that every size of
        the data_scale study takes the same number of steps (within one batch per epoch).

        Examples
        --------
        >>> [Protocol(train_scale=s, extra="x").run_epochs for s in (0.25, 1, 4)]
        [48, 12, 3]
        """
        return max(1, round(self.epochs / self.scale))

    @property
    def events_root(self) -> Path:
        """The folder of the raw events (and grey videos) the inputs are computed from:
        ``events`` for clean events, ``noise_events`` at the noise level otherwise."""
        if self.noise_level == "clean":
            return Path(self.events)
        return Path(self.noise_events.format(level=self.noise_level))

    def needs_events(self, stored: Mapping) -> bool:
        """True unless a dataset's stored frames (``stored``: its config) are this input,
        possibly after max-pooling to a smaller ``frame_size``."""
        return not (self.representation == "binary"
                    and self.noise_level == stored.get("noise", "clean")
                    and self.n_frames == stored["n_frames"]
                    and self.dt_us == stored["dt_us"]
                    and stored["windows"] == "fixed"
                    and stored["frame_size"] % self.frame_size == 0)

    def input_key(self, split: str) -> str:
        """A short digest of what the inputs of ``split`` depend on (the in-memory cache key;
        ``train_scale`` and ``extra`` change the training split only)."""
        train = split == "train"
        text = json.dumps({
            "representation": self.representation, "n_frames": self.n_frames,
            "dt_us": self.dt_us, "frame_size": self.frame_size, "split": split,
            "data": self.data, "per_category": self.per_category, "noise": self.noise_level,
            "events": str(self.events_root), "train_scale": self.scale if train else 1,
            "extra": self.extra if train else None,
            "pose_noise": None if split == "test" else self.pose_noise})
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def train_counts(self) -> dict[str, int]:
        """Training samples per category: data_small's (the first ``per_category`` in quick
        mode) times ``train_scale``, rounded."""
        from e2vlib.data import E2VDataset

        base = E2VDataset(self.data, "train").categories
        counts: dict[str, int] = {}
        for i in first_per_category(base, self.per_category):
            counts[base[i]] = counts.get(base[i], 0) + 1
        return {c: int(round(n * self.scale)) for c, n in counts.items()}

    def run_size(self) -> dict:
        """``{"n_train", "epochs", "steps"}`` of a run (what a record holds)."""
        from e2vlib.train import get_recipe

        n_train = sum(self.train_counts().values())
        batch = get_recipe(self.recipe).batch_size
        return {"n_train": n_train, "epochs": self.run_epochs,
                "steps": self.run_epochs * -(-n_train // batch)}

    def canonical(self) -> Protocol:
        """This protocol without the settings that change nothing at their value
        (:data:`NEUTRAL`): two protocols are the same training run when their canonical
        forms are equal.

        Examples
        --------
        >>> Protocol(train_scale=1, extra="cache/extra_small").canonical() == Protocol()
        True
        >>> Protocol(noise="clean", noise_events="x", test_noise=("high",)).canonical() == (
        ...     Protocol())
        True
        """
        same = self
        for key, (base, keys) in NEUTRAL.items():
            if getattr(self, key) in (None, base):
                same = replace(same, **dict.fromkeys(keys))
        return same


NEUTRAL: dict[str, tuple[object, tuple[str, ...]]] = {
    "train_scale": (1, ("train_scale", "extra")),
    "noise": ("clean", ("noise", "noise_events", "test_noise")),
}
"""Protocol settings that change nothing about training at their base value, with that value
and the settings that go with them (``train_scale`` 1 is data_small's own training set,
``noise`` "clean" its own events; ``test_noise`` only adds test scores)."""


def canonical_protocol(protocol: Protocol | Mapping) -> dict:
    """The record form (a dict) of ``protocol``'s :meth:`~Protocol.canonical` form, so
    ``data_scale``'s ``1x`` is the same training run as ``representation``'s ``binary`` or
    ``noise``'s ``train_clean`` (whose record only holds more test scores).

    Examples
    --------
    >>> canonical_protocol({"train_scale": 1, "extra": "cache/extra_small"}) == (
    ...     canonical_protocol(Protocol()))
    True
    >>> canonical_protocol({"train_scale": 2, "extra": "x"})["train_scale"]
    2
    >>> "test_noise" in canonical_protocol({"noise": "clean", "test_noise": ["high"]})
    False
    """
    if not isinstance(protocol, Protocol):
        protocol = Protocol.from_dict(protocol)
    return protocol.canonical().to_dict()


def first_per_category(categories: Sequence[str], per_category: int | dict | None) -> list[int]:
    """Indices of the first ``per_category`` items of each category (all when None; a dict
    gives each category its own count).

    Examples
    --------
    >>> first_per_category(["a", "b", "a", "a", "b"], 2)
    [0, 1, 2, 4]
    >>> first_per_category(["a", "b", "a", "a", "b"], {"a": 1, "b": 0})
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
