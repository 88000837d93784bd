"""A dataset folder is untrusted input: checks of its manifest, config.json, ids and files.

Users point :class:`e2vlib.data.E2VDataset`, ``train`` and ``evaluate`` at folders they
downloaded or built elsewhere, so nothing read from one is trusted: ids must be plain file
names, every file read must lie inside the folder (symlinks are resolved), the manifest's
rows and config.json's values are checked on read, and every problem is a
:class:`DatasetError` naming the file, the row or sample, and the fix.

Introduced in notebooks/04_building_the_dataset.ipynb (the builder writes what this reads).
"""

from __future__ import annotations

import csv
import json
import os
import re
from pathlib import Path

from e2vlib import paper
from e2vlib.frames import WINDOWS

SPLITS = ("train", "val", "test")
MANIFEST_REQUIRED = ("id", "category", "split", "seed", "n_events")
MAX_MANIFEST_BYTES = 64 * 2**20
"""Largest manifest.csv read (64 MiB; the paper's 39,741 samples take about 4 MiB)."""
MAX_CONFIG_BYTES = 2**20
"""Largest config.json read (1 MiB; a real one is under 1 KiB)."""
MAX_FRAMES_PER_SAMPLE = 2**30
"""Most frame values (n_frames x frame_size^2) one sample may hold: 1 GiB unpacked (the
paper's 100 x 256 x 256 is 6.5 M)."""
MAX_ID_LENGTH = 128
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")
_SHA256 = re.compile(r"[0-9a-f]{64}")


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


def _read_text(path: Path, limit: int, what: str) -> str:
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


def _whole(text: str | None, name: str, where: str) -> int:
    if text is None or not re.fullmatch(r"\d{1,19}", text.strip()):
        raise DatasetError(f"{where}: {name} must be a whole number >= 0, got {text!r}; fix "
                           "the row or rebuild the manifest with make-data")
    return int(text)


def read_manifest_rows(root: str | os.PathLike) -> list[dict]:
    """Rows of ROOT/manifest.csv, each checked: the columns id, category, split, seed,
    n_events present; a plain-name id (:func:`check_id`) listed once; a split of
    train/val/test (exact case); a category of :data:`e2vlib.paper.CATEGORIES`; seed and
    n_events whole numbers (returned as int); ``sha256``, where given, 64 hex digits.
    Raises FileNotFoundError when there is no manifest, DatasetError naming the row.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> header = "id,category,split,seed,n_events"
    >>> _ = (root / "manifest.csv").write_text(header + "\\nchair_0000,chair,test,7,1200")
    >>> read_manifest_rows(root)
    [{'id': 'chair_0000', 'category': 'chair', 'split': 'test', 'seed': 7, 'n_events': 1200}]
    >>> _ = (root / "manifest.csv").write_text(header + "\\nchair_0000,chair,Test,7,1200")
    >>> read_manifest_rows(root)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.data.checks.DatasetError: ...line 2 (sample 'chair_0000'): split 'Test' is not one of ...
    """
    root = Path(root)
    path = root / "manifest.csv"
    if not path.exists():
        raise FileNotFoundError(
            f"{path} not found: build a dataset with `python -m e2vlib make-data --out {root}`")
    reader = csv.DictReader(_read_text(path, MAX_MANIFEST_BYTES, "manifest").splitlines())
    try:
        header = reader.fieldnames or []
        missing = [c for c in MANIFEST_REQUIRED if c not in header]
        if missing:
            raise DatasetError(f"{path}: the header lacks the column(s) {', '.join(missing)} "
                               f"(it has {', '.join(map(repr, header)) or 'nothing'}); a "
                               f"manifest starts with {','.join(MANIFEST_REQUIRED)}: rebuild "
                               f"it with {rebuild_hint(root)}")
        rows, seen = [], {}
        for row in reader:
            where = f"{path} line {reader.line_num}"
            if None in row or any(row.get(c) is None for c in header):
                raise DatasetError(f"{where}: {len(header)} fields expected, as in the header; "
                                   "fix the row or rebuild the manifest with make-data")
            sample_id = check_id(row["id"], where)
            where = f"{where} (sample {sample_id!r})"
            if sample_id in seen:
                raise DatasetError(f"{where}: the id is listed twice (also on line "
                                   f"{seen[sample_id]}); remove one of the rows")
            seen[sample_id] = reader.line_num
            if row["split"] not in SPLITS:
                raise DatasetError(f"{where}: split {row['split']!r} is not one of "
                                   f"{', '.join(SPLITS)} (lower case); fix the row")
            if row["category"] not in paper.CATEGORIES:
                raise DatasetError(f"{where}: category {row['category']!r} is not one of the "
                                   f"paper's {len(paper.CATEGORIES)} "
                                   f"({', '.join(paper.CATEGORIES)}); fix or remove the row")
            row["seed"] = _whole(row["seed"], "seed", where)
            row["n_events"] = _whole(row["n_events"], "n_events", where)
            if row.get("sha256") and not _SHA256.fullmatch(row["sha256"]):
                raise DatasetError(f"{where}: sha256 {row['sha256']!r} is not 64 hex digits; "
                                   "rebuild the manifest with make-data")
            rows.append(row)
    except csv.Error as err:
        raise DatasetError(f"{path}: not a readable CSV file ({err}); rebuild it with "
                           f"{rebuild_hint(root)}") from None
    return rows


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
    text = _read_text(path, MAX_CONFIG_BYTES, "config")
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
