"""E2V checkpoint files: save, read and verify, rebuild the model, slim for shipping.

A checkpoint is the dict that :func:`save_checkpoint` hands to ``torch.save``::

    "config"          E2VConfig.to_dict(): plain values that rebuild the network
    "model"           the state dict (weights and BatchNorm statistics)
    "weights_sha256"  SHA-256 of the state dict (:func:`weights_digest`), checked on read
    "data_config"     the dataset build settings it was trained on (dict), or None
    ...               anything else the caller adds (optimizer state, epoch, history)

Files are read with ``torch.load(weights_only=True)``, so no code hidden in a file can
run, and written under a temporary name that is renamed when complete
(:class:`e2vlib.files.atomic_path`). :func:`read_checkpoint` refuses a file whose weights
no longer match their digest (corrupted after writing) or hold NaN or inf. Checkpoints
written before digests existed (such as the shipped ``data_small/checkpoints/tiny.pt``)
load without the digest check. :func:`check_frames_match` refuses data whose frames were
made differently from those a checkpoint was trained on.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from e2vlib import paper
from e2vlib.files import atomic_path
from e2vlib.model.networks import E2V, E2VConfig

DIGEST_KEY = "weights_sha256"
"""Checkpoint key of the weights' SHA-256 digest (hex string)."""

DATA_CONFIG_KEY = "data_config"
"""Checkpoint key of the dataset build settings the model was trained on."""

RESERVED_KEYS = ("config", "model", DIGEST_KEY, DATA_CONFIG_KEY)
"""Keys :func:`save_checkpoint` writes itself; ``extra`` may not use them."""

FRAME_FIELDS = ("n_frames", "dt_us", "windows", "frame_size")
"""Build settings that decide how events become the model's input frames."""

LEGACY_WINDOWS = "fixed"
"""Frame grouping of configs written before ``windows`` was recorded: they all used the
fixed clock windows of ``frames.accumulate(..., windows="fixed")``."""

SLIM_KEEP = ("history", "metadata", "recipe", "epoch", "best_iou", "seed", "loss")
"""Entries :func:`slim_checkpoint` copies by default (besides config, weights, data config)."""


class CheckpointError(ValueError):
    """A checkpoint file cannot be read, is corrupted, or does not describe an E2V model.

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """


# --------------------------------------------------------------------------- digest


def weights_digest(state_dict: Mapping[str, torch.Tensor]) -> str:
    """SHA-256 (hex) of a state dict: every tensor's name, dtype, shape and raw bytes.

    Tensors are taken in sorted name order, so the digest does not depend on the order
    of the dict; each is hashed from a CPU copy, so neither does the device. Any change
    of a single byte of any weight changes the digest.

    Examples
    --------
    >>> a = {"w": torch.ones(2, 3), "b": torch.zeros(2)}
    >>> weights_digest(a) == weights_digest({"b": torch.zeros(2), "w": torch.ones(2, 3)})
    True
    >>> weights_digest(a) == weights_digest({"w": torch.ones(3, 2), "b": torch.zeros(2)})
    False
    >>> len(weights_digest(a))
    64
    """
    h = hashlib.sha256()
    for name in sorted(state_dict):
        tensor = state_dict[name]
        if not isinstance(tensor, torch.Tensor):
            raise TypeError(f"state dict entry {name!r} is a {type(tensor).__name__}, not a "
                            "tensor; weights_digest hashes tensors only")
        tensor = tensor.detach().to("cpu").contiguous()
        header = f"{name}\0{tensor.dtype}\0{tuple(tensor.shape)}\0".encode()
        data = tensor.reshape(-1).view(torch.uint8).numpy()
        # Lengths first, so that no two different (header, data) sequences hash alike.
        h.update(len(header).to_bytes(8, "little"))
        h.update(header)
        h.update(int(data.nbytes).to_bytes(8, "little"))
        h.update(memoryview(data))
    return h.hexdigest()


def verify_weights(ckpt: Mapping[str, Any], source: object = "checkpoint") -> None:
    """Raise :class:`CheckpointError` if ``ckpt``'s weights are damaged.

    Checks the stored :data:`DIGEST_KEY` digest when there is one (older checkpoints have
    none and skip this check), then that every floating-point tensor is finite.
    ``source`` names the file in the messages.
    """
    state = ckpt["model"]
    if not isinstance(state, Mapping):
        raise CheckpointError(f"{source}: 'model' must be a state dict, got "
                              f"{type(state).__name__}. Re-create it with save_checkpoint.")
    stored = ckpt.get(DIGEST_KEY)
    if stored is not None:
        try:
            actual = weights_digest(state)
        except TypeError as err:
            raise CheckpointError(f"{source} is corrupted: {err}") from err
        if not isinstance(stored, str) or actual != stored:
            raise CheckpointError(
                f"{source} is corrupted: its weights do not match the SHA-256 digest stored "
                f"with them (stored {str(stored)[:16]}..., computed {actual[:16]}...)"
                f"{_key_problems(ckpt)}, so the file changed after it was written (a "
                "damaged copy or disk, or an edit). Copy it again or re-create it with "
                "save_checkpoint.")
    for name, tensor in state.items():
        if isinstance(tensor, torch.Tensor) and (tensor.is_floating_point()
                                                 or tensor.is_complex()):
            finite = torch.isfinite(tensor)
            if not bool(finite.all()):
                n_nan = int(torch.isnan(tensor).sum())
                n_inf = int((~finite).sum()) - n_nan
                raise CheckpointError(
                    f"{source} holds non-finite weights: the first bad parameter is {name!r} "
                    f"({n_nan} NaN and {n_inf} inf of {tensor.numel()} values). A model with "
                    "them predicts NaN. The training run diverged (retrain with a lower "
                    "learning rate) or the file is damaged; use an earlier checkpoint such "
                    "as best.pt.")


def _key_problems(ckpt: Mapping[str, Any]) -> str:
    """Missing and unexpected state-dict names against the stored config, as a clause."""
    try:
        with torch.device("meta"):  # shapes only: nothing is allocated
            expected = set(E2V(E2VConfig.from_dict(dict(ckpt["config"]))).state_dict())
    except (ValueError, TypeError, KeyError):
        return ""
    found = set(ckpt["model"])
    missing, unexpected = sorted(expected - found), sorted(found - expected)
    parts = ([f"missing {missing[:5]}"] if missing else []) + (
        [f"unexpected {unexpected[:5]}"] if unexpected else [])
    return f"; state dict {', '.join(parts)}" if parts else ""


# --------------------------------------------------------------------------- save / read


def save_checkpoint(path: str | os.PathLike, model: E2V,
                    data_config: Mapping[str, Any] | None = None, **extra: Any) -> Path:
    """Write ``model`` (config, weights, their digest) and ``data_config`` to ``path``.

    Parameters
    ----------
    path
        The file to write; folders are created. It is written under a temporary name
        next to ``path`` and then renamed, so an existing checkpoint is never left
        half-written.
    model
        An :class:`E2V` (DataParallel/DistributedDataParallel wrappers are unwrapped).
    data_config
        The build settings of the dataset the model was trained on (a plain dict, e.g.
        ``BuildConfig.to_dict()``, or an object with ``to_dict``), stored under
        ``"data_config"`` for :func:`check_frames_match`; None if unknown.
    **extra
        Anything ``torch.load(weights_only=True)`` reads back (tensors, numbers, strings,
        lists, dicts: e.g. an optimizer state_dict, the epoch). The keys of
        :data:`RESERVED_KEYS` are refused.

    Returns
    -------
    Path
        ``path``.

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    model = getattr(model, "module", model)  # unwrap DistributedDataParallel/DataParallel
    if not isinstance(model, E2V):
        raise ValueError(f"save_checkpoint stores E2V models, got {type(model).__name__}; "
                         "save other modules with torch.save(module.state_dict(), path)")
    clash = set(RESERVED_KEYS) & set(extra)
    if clash:
        raise ValueError(f"extra keys {sorted(clash)} are reserved for the model; rename them")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_payload(path, model.config.to_dict(), model.state_dict(), data_config, extra)
    return path


def read_checkpoint(path: str | os.PathLike, map_location: str | torch.device = "cpu",
                    verify: bool = True) -> dict:
    """Load and check a checkpoint dict (``"config"``, ``"model"`` and any extra keys).

    Uses ``torch.load(weights_only=True)``: no arbitrary code runs. With ``verify`` (the
    default) the weights are checked as :func:`verify_weights` describes. Raises
    FileNotFoundError if the file is missing, and :class:`CheckpointError` (a ValueError)
    naming the file if it is corrupted, lacks the keys, or holds non-finite weights;
    ``verify=False`` reads a damaged file anyway, for inspection.
    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    path = Path(path)
    if path.is_dir():
        raise CheckpointError(f"checkpoint {path} is a directory; give the file inside it, "
                              f"e.g. {path / 'best.pt'}")
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {path} does not exist; train one first "
                                "(python -m e2vlib train ... writes OUT/best.pt) or fix the path")
    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
    except Exception as err:  # zip/pickle errors come in many types
        raise CheckpointError(
            f"cannot read checkpoint {path}: it is corrupted, truncated or not a torch file "
            f"({type(err).__name__}: {str(err)[:200]}). Re-create it with save_checkpoint."
        ) from err
    if not isinstance(ckpt, dict) or not {"config", "model"} <= set(ckpt):
        keys = sorted(ckpt) if isinstance(ckpt, dict) else type(ckpt).__name__
        raise CheckpointError(f"checkpoint {path} must be a dict with 'config' and 'model' "
                              f"keys (as written by save_checkpoint), got {keys}")
    if verify:
        verify_weights(ckpt, f"checkpoint {path}")
    return ckpt


def load_checkpoint(path: str | os.PathLike, map_location: str | torch.device = "cpu") -> E2V:
    """Rebuild the :class:`E2V` stored at ``path`` (its config + weights), in eval mode.

    Accepts any dict holding ``"config"`` and ``"model"`` (extra keys such as optimizer
    state are ignored; use :func:`read_checkpoint` to get them). The weights are verified
    and errors raised as in :func:`read_checkpoint`.

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.model.networks import build_e2v
    >>> path = Path(tempfile.mkdtemp()) / "m.pt"
    >>> model = build_e2v("tiny", input_shape=(16, 32, 32), seed=0)
    >>> _ = save_checkpoint(path, model, data_config={"frame_size": 32})
    >>> load_checkpoint(path).config == model.config
    True

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    return model_from_checkpoint(read_checkpoint(path, map_location), map_location,
                                 f"checkpoint {path}")


def model_from_checkpoint(ckpt: dict, map_location: str | torch.device = "cpu",
                          source: object = "checkpoint") -> E2V:
    """Rebuild the :class:`E2V` of a dict from :func:`read_checkpoint`, in eval mode.

    For callers that also need the checkpoint's other entries (metadata, history)
    without reading the file twice. Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    try:
        model = E2V(E2VConfig.from_dict(dict(ckpt["config"])))
        model.load_state_dict(ckpt["model"])
    except (ValueError, TypeError, RuntimeError) as err:
        raise CheckpointError(f"{source} does not match an E2V model: {err}") from err
    return model.to(map_location).eval()


def slim_checkpoint(src: str | os.PathLike, dst: str | os.PathLike, half: bool = True,
                    keep: tuple[str, ...] = SLIM_KEEP) -> Path:
    """Copy a training checkpoint without its optimizer state, for shipping.

    Keeps the config, the weights (as float16 when ``half``: ``load_checkpoint`` casts
    them back to float32) with a new digest, the data config and the ``keep`` entries.
    The source is verified first. The committed ``data_small/checkpoints/tiny.pt`` was
    made this way (before digests existed). Introduced in notebooks/06_training.ipynb.
    """
    ckpt = read_checkpoint(src)
    state = {k: v.half() if half and v.is_floating_point() else v
             for k, v in ckpt["model"].items()}
    config = E2VConfig.from_dict(dict(ckpt["config"]))  # validates the stored config
    extra = {k: ckpt[k] for k in keep if k in ckpt and k not in RESERVED_KEYS}
    path = Path(dst)
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_payload(path, config.to_dict(), state, ckpt.get(DATA_CONFIG_KEY), extra)
    return path


def _write_payload(path: Path, config: dict, state: Mapping[str, torch.Tensor],
                   data_config: Any, extra: Mapping[str, Any]) -> None:
    """``torch.save`` the checkpoint dict to a temporary name next to ``path``, then rename."""
    payload = {"config": config, "model": state, DIGEST_KEY: weights_digest(state),
               DATA_CONFIG_KEY: _as_config_dict(data_config, "data_config"), **extra}
    with atomic_path(path) as tmp:
        torch.save(payload, tmp)


# --------------------------------------------------------------------------- data config


def _as_config_dict(config: Any, what: str) -> dict | None:
    if config is None:
        return None
    if hasattr(config, "to_dict"):
        config = config.to_dict()
    if not isinstance(config, Mapping):
        raise ValueError(f"{what} must be a dict (e.g. BuildConfig.to_dict()) or None, "
                         f"got {type(config).__name__}")
    return dict(config)


def checkpoint_data_config(ckpt: Mapping[str, Any]) -> dict | None:
    """The dataset build settings a checkpoint was trained on, or None if it has none.

    Reads ``ckpt["data_config"]``, or for older checkpoints (the shipped ``tiny.pt``)
    ``ckpt["metadata"]["data_config"]``.

    Examples
    --------
    >>> checkpoint_data_config({"data_config": {"frame_size": 64}})
    {'frame_size': 64}
    >>> checkpoint_data_config({"metadata": {"data_config": {"frame_size": 32}}})
    {'frame_size': 32}
    >>> checkpoint_data_config({"config": {}}) is None
    True
    """
    value = ckpt.get(DATA_CONFIG_KEY)
    if value is None:
        metadata = ckpt.get("metadata")
        value = metadata.get(DATA_CONFIG_KEY) if isinstance(metadata, Mapping) else None
    return dict(value) if isinstance(value, Mapping) else None


def frame_settings(config: Mapping[str, Any]) -> dict[str, Any]:
    """The :data:`FRAME_FIELDS` of a build config, with the defaults of older configs.

    A missing ``n_frames``/``dt_us`` means the paper's :data:`e2vlib.paper.N_EVENT_FRAMES`
    frames of :data:`e2vlib.paper.DT_US`; a missing ``windows`` means ``"fixed"``; a
    missing ``frame_size`` stays None (unknown).

    Examples
    --------
    >>> frame_settings({"frame_size": 64})
    {'n_frames': 100, 'dt_us': 5000, 'windows': 'fixed', 'frame_size': 64}
    """
    defaults = {"n_frames": paper.N_EVENT_FRAMES, "dt_us": paper.DT_US,
                "windows": LEGACY_WINDOWS, "frame_size": None}
    return {key: default if config.get(key) is None else config[key]
            for key, default in defaults.items()}


def check_frames_match(ckpt_data_config: Mapping[str, Any] | None,
                       dataset_config: Mapping[str, Any] | None,
                       checkpoint_name: object = "the checkpoint",
                       dataset_name: object = "the dataset") -> None:
    """Raise :class:`CheckpointError` if a dataset's frames differ from a checkpoint's.

    Compares the frame-making settings (:data:`FRAME_FIELDS`: ``n_frames``, ``dt_us``,
    ``windows``, ``frame_size``; defaults as :func:`frame_settings`) of the config the
    checkpoint was trained on (:func:`checkpoint_data_config`) and of the dataset. A
    model only works on frames made the way it was trained on. No check when either
    config is None; a ``frame_size`` known on one side only is not compared. The message
    names both values and both sources.

    Examples
    --------
    >>> check_frames_match({"frame_size": 64}, {"frame_size": 64, "dt_us": 5000})
    >>> check_frames_match({"frame_size": 64}, None)
    >>> try:
    ...     check_frames_match({"dt_us": 5000}, {"dt_us": 2500}, "tiny.pt", "data_fast")
    ... except CheckpointError as err:
    ...     print(str(err).split(": ")[1].split(". ")[0])
    dt_us is 5000 in tiny.pt but 2500 in data_fast
    """
    if ckpt_data_config is None or dataset_config is None:
        return
    ours = frame_settings(_as_config_dict(ckpt_data_config, "ckpt_data_config"))
    theirs = frame_settings(_as_config_dict(dataset_config, "dataset_config"))
    differ = [key for key in FRAME_FIELDS
              if ours[key] is not None and theirs[key] is not None and ours[key] != theirs[key]]
    if differ:
        details = "; ".join(f"{key} is {ours[key]!r} in {checkpoint_name} but {theirs[key]!r} "
                            f"in {dataset_name}" for key in differ)
        raise CheckpointError(
            f"the frames of {dataset_name} differ from those {checkpoint_name} was trained "
            f"on: {details}. The model only works on frames made the same way: rebuild the "
            f"data with {checkpoint_name}'s settings (python -m e2vlib make-data), or use a "
            f"checkpoint trained on {dataset_name}.")
