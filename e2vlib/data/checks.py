"""A dataset folder is untrusted input: checks of its manifest, config.json, ids and files.

Users point :class:`e2vlib.data.E2VDataset`, ``train`` and ``evaluate`` at folders they
downloaded or built elsewhere, so nothing read from one is trusted: ids must be plain file
names, every file read must lie inside the folder (symlinks are resolved), the manifest's
rows and config.json's values are checked on read, and every problem is a
:class:`DatasetError` naming the file, the row or sample, and the fix.

Introduced in notebooks/04_building_the_dataset.ipynb (the builder writes what this reads).
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from e2vlib import paper
from e2vlib.frames import WINDOWS

SPLITS = ("train", "val", "test")
MAX_CONFIG_BYTES = 2**20
"""Largest config.json read (1 MiB; a real one is under 1 KiB)."""
MAX_FRAMES_PER_SAMPLE = 2**30
"""Most frame values (n_frames x frame_size^2) one sample may hold: 1 GiB unpacked (the
paper's 100 x 256 x 256 is 6.5 M)."""
MAX_ID_LENGTH = 128
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")


class DatasetError(ValueError):
    """A dataset folder that cannot be read as it is: the message names the file, the
    sample or row, and the fix.

    Examples
    --------
    >>> issubclass(DatasetError, ValueError)  # callers that catch ValueError catch it too
    True
    """


def npz_problem(err: Exception) -> str:
    """What ``np.load`` found wrong, without its advice to unpickle: it calls any file that
    is not a zip or ``.npy`` "pickled data", and e2vlib never unpickles.

    Examples
    --------
    >>> npz_problem(ValueError("Cannot load file containing pickled data"))
    'neither a zip of arrays nor a .npy file'
    >>> npz_problem(OSError("disk error"))
    'disk error'
    """
    return "neither a zip of arrays nor a .npy file" if "pickle" in str(err) else str(err)


def rebuild_hint(root: str | os.PathLike) -> str:
    """The command that finishes (resumably) the build of the dataset in ``root``.

    Examples
    --------
    >>> rebuild_hint("data_chairs")
    '`python -m e2vlib make-data --out data_chairs ...` with its settings (resumable)'
    """
    return f"`python -m e2vlib make-data --out {root} ...` with its settings (resumable)"


def check_id(sample_id: object, where: str) -> str:
    """``sample_id`` if it is a plain file name (letters, digits, ``_ . -``, not starting
    with a dot, at most 128 characters), else a DatasetError: ids are joined into paths,
    so ``../x``, ``/etc/x`` or ``a/b`` would read outside the dataset.

    Examples
    --------
    >>> check_id("chair_0003", "manifest.csv")
    'chair_0003'
    >>> check_id("../../x", "manifest.csv")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.data.checks.DatasetError: manifest.csv: sample id '../../x' is not a plain ...
    """
    if not (isinstance(sample_id, str) and len(sample_id) <= MAX_ID_LENGTH
            and _ID.fullmatch(sample_id)):
        raise DatasetError(f"{where}: sample id {sample_id!r} is not a plain file name "
                           "(letters, digits, '_', '.', '-', not starting with '.'); ids are "
                           "joined into paths inside the dataset, so fix or remove the row")
    return sample_id


def inside(root: Path, path: Path) -> Path:
    """``path`` if it resolves (symlinks followed) to a place inside ``root``, else a
    DatasetError: a dataset only ever reads files in its own folder.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> inside(root, root / "samples" / "chair_0000.npz") == root / "samples" / "chair_0000.npz"
    True
    >>> inside(root, root / ".." / "elsewhere.npz")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.data.checks.DatasetError: ... points outside the dataset ...
    """
    real = path.resolve()
    if not real.is_relative_to(root.resolve()):
        raise DatasetError(f"{path} points outside the dataset {root} (to {real}); a dataset "
                           "reads only its own files: replace the link with the file itself")
    return path


def read_capped_text(path: Path, limit: int, what: str) -> str:
    """The UTF-8 text of ``path`` (at most ``limit`` bytes), or a DatasetError naming it."""
    if path.is_dir():
        raise DatasetError(f"{path} is a folder, not a {what} file; remove it and rebuild "
                           f"the dataset with {rebuild_hint(path.parent)}")
    if not path.is_file():
        raise DatasetError(f"{path} is missing: {path.parent} is not a complete dataset; "
                           f"rebuild it with {rebuild_hint(path.parent)}")
    size = path.stat().st_size
    if size > limit:
        raise DatasetError(f"{path} is {size} bytes, more than a {what} can be "
                           f"({limit} bytes); it is not one: rebuild the dataset with "
                           f"{rebuild_hint(path.parent)}")
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise DatasetError(f"{path} is not a text {what} (binary content at byte "
                           f"{err.start}); rebuild the dataset with "
                           f"{rebuild_hint(path.parent)}") from None
    if "\x00" in text:
        raise DatasetError(f"{path} is not a text {what} (it holds NUL bytes); rebuild the "
                           f"dataset with {rebuild_hint(path.parent)}")
    return text


def _positive(config: dict, name: str, path: Path, maximum: int | None = None,
              required: bool = False) -> None:
    if name not in config:
        if required:
            raise DatasetError(f"{path} has no {name}; it is not a dataset config: rebuild "
                               f"the dataset with {rebuild_hint(path.parent)}")
        return
    value = config[name]
    if isinstance(value, bool) or not isinstance(value, int) or value < 1 or (
            maximum is not None and value > maximum):
        bound = f" at most {maximum}" if maximum is not None else ""
        raise DatasetError(f"{path}: {name} must be a whole number >= 1{bound}, got "
                           f"{value!r} ({type(value).__name__}); fix it or rebuild the dataset")


def read_config(root: str | os.PathLike) -> dict:
    """ROOT/config.json as a dict, its values checked: ``frame_size`` (required),
    ``resolution``, ``n_frames``, ``dt_us``, ``per_category`` positive whole numbers (JSON
    numbers, not strings), ``windows`` fixed or paper, ``categories`` a list of known
    names, and a frame stack of at most :data:`MAX_FRAMES_PER_SAMPLE` values. Raises
    DatasetError naming the file, the value and the fix.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> _ = (root / "config.json").write_text('{"frame_size": 64, "n_frames": 100}')
    >>> read_config(root)
    {'frame_size': 64, 'n_frames': 100}
    >>> _ = (root / "config.json").write_text('{"frame_size": "64"}')  # a string, not a number
    >>> read_config(root)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.data.checks.DatasetError: ...config.json: frame_size must be a whole number >= 1 ...
    """
    path = Path(root) / "config.json"
    text = read_capped_text(path, MAX_CONFIG_BYTES, "config")
    try:
        config = json.loads(text)
    except json.JSONDecodeError as err:
        raise DatasetError(f"{path} is not valid JSON ({err}); rebuild the dataset with "
                           f"{rebuild_hint(path.parent)}") from None
    if not isinstance(config, dict):
        raise DatasetError(f"{path} holds a JSON {type(config).__name__}, not an object of "
                           f"build settings; rebuild the dataset with "
                           f"{rebuild_hint(path.parent)}")
    _positive(config, "frame_size", path, required=True, maximum=2**15)
    for name in ("resolution", "n_frames", "dt_us", "per_category", "oversample"):
        _positive(config, name, path)
    if "windows" in config and config["windows"] not in WINDOWS:
        raise DatasetError(f"{path}: windows must be one of {', '.join(WINDOWS)}, got "
                           f"{config['windows']!r}; fix it or rebuild the dataset")
    if "categories" in config:
        names = config["categories"]
        if not isinstance(names, list) or not names or any(
                not isinstance(n, str) or n not in paper.CATEGORIES for n in names):
            raise DatasetError(f"{path}: categories must be a list of some of "
                               f"{', '.join(paper.CATEGORIES)}, got {names!r}; fix it")
    values = config.get("n_frames", paper.N_EVENT_FRAMES) * config["frame_size"] ** 2
    if values > MAX_FRAMES_PER_SAMPLE:
        raise DatasetError(f"{path}: {config.get('n_frames', paper.N_EVENT_FRAMES)} frames of "
                           f"{config['frame_size']} px are {values} values per sample, more "
                           f"than the {MAX_FRAMES_PER_SAMPLE} e2vlib reads "
                           "(data.MAX_FRAMES_PER_SAMPLE); fix the config")
    return config
