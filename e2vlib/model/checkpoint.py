"""E2V checkpoint files: save, read and verify, rebuild the model, slim for shipping.

A checkpoint is the dict that :func:`save_checkpoint` hands to ``torch.save``::

    "config"          E2VConfig.to_dict(): plain values that rebuild the network
    "model"           the state dict (weights and BatchNorm statistics)
    "weights_sha256"  SHA-256 of the state dict (:func:`weights_digest`), checked on read
    "data_config"     the dataset build settings it was trained on (dict), or None
    ...               anything else the caller adds (optimizer state, epoch, history)

Files are read with ``torch.load(weights_only=True)``, so no code hidden in a file can run,
and written under a temporary name that is renamed when complete
(:class:`e2vlib.files.atomic_path`). :func:`read_checkpoint` refuses a file whose weights no
longer match their digest (corrupted after writing) or hold NaN or inf
(:func:`~e2vlib.model.integrity.verify_weights`; :class:`CheckpointError`,
:data:`DIGEST_KEY` and :func:`weights_digest` live in :mod:`e2vlib.model.integrity` and are
importable from here too). Checkpoints written before digests existed (such as the shipped
``data_small/checkpoints/first_recipe.pt``) load without the digest check.
:func:`check_frames_match` refuses data whose frames were made differently from those a
checkpoint was trained on.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

import os
import pickle
import re
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from e2vlib.data.config import FRAME_FIELDS, frame_settings
from e2vlib.files import atomic_path, input_file
from e2vlib.model.config import E2VConfig
from e2vlib.model.integrity import (
    DIGEST_KEY,
    CheckpointError,
    check_state_matches,
    verify_weights,
    weights_digest,
)
from e2vlib.model.networks import E2V

DATA_CONFIG_KEY = "data_config"
"""Checkpoint key of the dataset build settings the model was trained on."""

RESERVED_KEYS = ("config", "model", DIGEST_KEY, DATA_CONFIG_KEY)
"""Keys :func:`save_checkpoint` writes itself; ``extra`` may not use them."""

MAX_INFLATION = 4
"""Most times its own size a checkpoint's zip members may declare, all together.
``torch.save`` stores them uncompressed (their sizes add up to the file's), so a member
that inflates beyond this (1.5 MB into 1.6 GB) was not written by torch and is refused
before ``torch.load`` reads it."""

SLIM_KEEP = ("history", "metadata", "recipe", "epoch", "best_iou", "seed", "loss")
"""Entries :func:`slim_checkpoint` copies by default (besides config, weights, data config)."""


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

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.model.networks import build_e2v
    >>> path = Path(tempfile.mkdtemp()) / "run" / "m.pt"  # the folder is created
    >>> model = build_e2v("tiny", input_shape=(16, 32, 32), seed=0)
    >>> save_checkpoint(path, model, data_config={"frame_size": 32}, epoch=3) == path
    True
    >>> ckpt = read_checkpoint(path)
    >>> sorted(ckpt), ckpt["epoch"], ckpt[DATA_CONFIG_KEY]
    (['config', 'data_config', 'epoch', 'model', 'weights_sha256'], 3, {'frame_size': 32})

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

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.model.networks import build_e2v
    >>> path = save_checkpoint(Path(tempfile.mkdtemp()) / "m.pt",
    ...                        build_e2v("tiny", input_shape=(16, 32, 32), seed=0))
    >>> ckpt = read_checkpoint(path)
    >>> ckpt["config"]["input_shape"], len(ckpt[DIGEST_KEY])
    ([16, 32, 32], 64)
    >>> read_checkpoint(path.parent / "none.pt")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    FileNotFoundError: checkpoint .../none.pt does not exist; train one first ...

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    path = Path(path)
    if path.is_dir():
        raise CheckpointError(f"checkpoint {path} is a directory; give the file inside it, "
                              f"e.g. {path / 'best.pt'}")
    if not path.exists() and not path.is_symlink():
        raise FileNotFoundError(f"checkpoint {path} does not exist; train one first "
                                "(python -m e2vlib train ... writes OUT/best.pt) or fix the path")
    input_file(path, "checkpoint")  # a FIFO, a device, a link loop: say what it is
    if path.stat().st_size == 0:
        raise CheckpointError(f"checkpoint {path} is empty (0 bytes): a copy or a save that "
                              "did not finish; copy it again or re-create it with "
                              "save_checkpoint")
    _check_archive(path)
    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as err:  # objects beyond tensors: never run
        if "global" not in str(err).lower():  # random bytes: no object asked for, just junk
            found = re.search(r"error:\s*(\S[^\n]*)", str(err))
            why = f": {found.group(1)[:80]}" if found else ""
            raise CheckpointError(
                f"cannot read checkpoint {path}: it is corrupted or not a torch file (its "
                f"bytes do not unpickle{why}). Re-create it with save_checkpoint or copy it "
                "again.") from None
        found = re.search(r"GLOBAL ([\w.]+)", str(err))
        what = f" (it asks for {found.group(1)})" if found else ""
        raise CheckpointError(
            f"checkpoint {path} holds Python objects besides weights and plain values{what}; "
            "e2vlib reads checkpoints with torch.load(weights_only=True), so none of it ran. "
            "It was not written by save_checkpoint: re-create it with save_checkpoint, and "
            "never load it with weights_only=False unless you trust who made it.") from None
    except Exception as err:  # zip errors come in many types
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


def _check_archive(path: Path) -> None:
    """Refuse a checkpoint whose zip members declare more than :data:`MAX_INFLATION` times
    the file's size, before ``torch.load`` inflates them (a damaged zip is left to it)."""
    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
    except (zipfile.BadZipFile, OSError, ValueError):
        return  # an older (non-zip) torch file, or a damaged one: torch.load reports it
    declared = sum(m.file_size for m in members)
    size = path.stat().st_size
    if declared > MAX_INFLATION * size:
        biggest = max(members, key=lambda m: m.file_size)
        raise CheckpointError(
            f"checkpoint {path}: its zip members declare {declared} bytes, more than "
            f"model.MAX_INFLATION = {MAX_INFLATION} times the file's {size} bytes (member "
            f"{biggest.filename!r} inflates {biggest.compress_size} bytes to "
            f"{biggest.file_size}); torch.save never compresses, so the file was not written "
            "by it: re-create it with save_checkpoint")


def load_checkpoint(checkpoint: str | os.PathLike | dict,
                    map_location: str | torch.device = "cpu", source: object = None) -> E2V:
    """Rebuild the :class:`E2V` of a checkpoint (its config + weights), in eval mode.

    ``checkpoint`` is a path, read and verified as :func:`read_checkpoint` does (errors
    raised as there), or a dict that :func:`read_checkpoint` returned, for callers that
    also need its other entries (history, metadata) without reading the file twice. Any
    dict holding ``"config"`` and ``"model"`` will do (extra keys such as optimizer state
    are ignored). ``source`` names the checkpoint in errors (default: the path).

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.model.networks import build_e2v
    >>> path = Path(tempfile.mkdtemp()) / "m.pt"
    >>> model = build_e2v("tiny", input_shape=(16, 32, 32), seed=0)
    >>> _ = save_checkpoint(path, model, data_config={"frame_size": 32})
    >>> load_checkpoint(path).config == model.config
    True
    >>> ckpt = read_checkpoint(path)   # the same from the dict, with the other entries
    >>> again = load_checkpoint(ckpt)
    >>> again.config == model.config, again.training, ckpt["data_config"]["frame_size"]
    (True, False, 32)
    >>> load_checkpoint({**ckpt, "model": {}}, source="m.pt")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.model.integrity.CheckpointError: m.pt does not match an E2V model: ...

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    if isinstance(checkpoint, dict):
        ckpt, source = checkpoint, source or "checkpoint"
    else:
        ckpt = read_checkpoint(checkpoint, map_location)
        source = source or f"checkpoint {checkpoint}"
    check_state_matches(ckpt, source)  # on the meta device: sizes, names, dtypes
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
    The source is verified first. The committed ``data_small/checkpoints/first_recipe.pt`` was
    made this way (before digests existed).

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.model.networks import build_e2v
    >>> folder = Path(tempfile.mkdtemp())
    >>> model = build_e2v("tiny", input_shape=(16, 32, 32), seed=0)
    >>> big = save_checkpoint(folder / "last.pt", model, epoch=9, optimizer={"lr": 1e-3})
    >>> small = slim_checkpoint(big, folder / "slim.pt")
    >>> sorted(read_checkpoint(small))  # the optimizer state is gone
    ['config', 'data_config', 'epoch', 'model', 'weights_sha256']
    >>> read_checkpoint(small)["model"]["head.weight"].dtype, small.stat().st_size < \
big.stat().st_size
    (torch.float16, True)
    >>> load_checkpoint(small).head.weight.dtype  # read back as float32
    torch.float32

    Introduced in notebooks/06_training.ipynb.
    """
    ckpt = read_checkpoint(src)
    check_state_matches(ckpt, f"checkpoint {src}")  # validates the stored config
    state = {k: v.half() if half and v.is_floating_point() else v
             for k, v in ckpt["model"].items()}
    config = E2VConfig.from_dict(dict(ckpt["config"]))
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

    Reads ``ckpt["data_config"]``, or for older checkpoints (the shipped ``first_recipe.pt``)
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


def _frame_settings_of(config: Any, what: str, name: object) -> dict[str, Any]:
    """:func:`frame_settings` of a config dict (or BuildConfig); ValueError names ``name``."""
    try:
        return frame_settings(_as_config_dict(config, what))
    except ValueError as err:
        raise ValueError(f"the data config of {name}: {err}") from None


def check_frames_match(ckpt_data_config: Mapping[str, Any] | None,
                       dataset_config: Mapping[str, Any] | None,
                       checkpoint_name: object = "the checkpoint",
                       dataset_name: object = "the dataset") -> None:
    """Raise :class:`CheckpointError` if a dataset's frames differ from a checkpoint's.

    Compares the frame-making settings (:data:`FRAME_FIELDS`: ``n_frames``, ``dt_us``,
    ``windows``, ``frame_size``; defaults as :func:`e2vlib.data.config.frame_settings`,
    which also refuses a malformed value with a ValueError) of the config the
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
    ours = _frame_settings_of(ckpt_data_config, "ckpt_data_config", checkpoint_name)
    theirs = _frame_settings_of(dataset_config, "dataset_config", dataset_name)
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
