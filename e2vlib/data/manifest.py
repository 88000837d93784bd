"""ROOT/manifest.csv: one row per built sample, with the digest of its file's arrays.

:func:`write_manifest` lists the planned samples present on disk with their
:func:`npz_digest`; :func:`read_manifest` reads it back, every row checked.
Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import csv
import hashlib
import os
import re
import zipfile
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from e2vlib import paper
from e2vlib.data.checks import SPLITS, DatasetError, check_id, read_capped_text, rebuild_hint
from e2vlib.data.plan import SampleSpec
from e2vlib.files import atomic_path

MANIFEST_FIELDS = ("id", "category", "split", "seed", "n_events", "sha256")
MANIFEST_REQUIRED = MANIFEST_FIELDS[:5]
"""The columns every manifest has (``sha256`` came later: older manifests lack it)."""
MAX_MANIFEST_BYTES = 64 * 2**20
"""Largest manifest.csv read (64 MiB; the paper's 39,741 samples take about 4 MiB)."""
_SHA256 = re.compile(r"[0-9a-f]{64}")


def npz_digest(path: str | os.PathLike) -> str:
    """SHA-256 (hex) of an ``.npz`` file's arrays: every member's name and ``.npy`` bytes,
    in name order. Unlike the file's own bytes it leaves out the write times that
    ``np.savez`` puts in the zip, so two builds of one sample give the same digest.
    Raises ValueError naming the file when it is not a readable zip (CRCs are checked).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> for name in ("a.npz", "b.npz"):
    ...     np.savez(folder / name, x=np.arange(3))
    >>> npz_digest(folder / "a.npz") == npz_digest(folder / "b.npz")  # the same arrays
    True
    >>> len(npz_digest(folder / "a.npz"))  # 256 bits in hex
    64
    """
    h = hashlib.sha256()
    try:
        with zipfile.ZipFile(path) as zf:
            for name in sorted(zf.namelist()):
                encoded = name.encode()
                h.update(len(encoded).to_bytes(8, "little") + encoded)
                h.update(zf.getinfo(name).file_size.to_bytes(8, "little"))
                with zf.open(name) as member:
                    for block in iter(lambda: member.read(1 << 20), b""):
                        h.update(block)
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as err:
        raise ValueError(f"{path}: corrupted or truncated file ({err})") from err
    return h.hexdigest()


def manifest_digests(root: Path) -> dict[str, str]:
    """``{id: sha256}`` recorded in ROOT/manifest.csv (empty for old or unreadable ones).

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> manifest_digests(root)  # no manifest yet
    {}
    >>> row = "chair_0000,chair,test,7,1200," + "ab" * 32
    >>> _ = (root / "manifest.csv").write_text("id,category,split,seed,n_events,sha256\\n" + row)
    >>> manifest_digests(root) == {"chair_0000": "ab" * 32}
    True
    """
    try:
        rows = read_manifest(root)
    except (OSError, ValueError, KeyError):
        return {}
    return {r["id"]: r["sha256"] for r in rows if r.get("sha256")}


def write_manifest(root: Path, specs: Iterable[SampleSpec],
                   digests: Mapping[str, str] | None = None) -> Path:
    """Write ROOT/manifest.csv for every planned sample whose file exists.

    ``sha256`` is :func:`npz_digest` of the sample file, taken from ``digests``, else from
    the manifest already there (the digest recorded when it was built), else computed.

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.data.samples import save_sample
    >>> root = Path(tempfile.mkdtemp())
    >>> (root / "samples").mkdir()
    >>> specs = [SampleSpec("chair_0000", "chair", 0, "test", 7),
    ...          SampleSpec("chair_0001", "chair", 1, "train", 8)]
    >>> save_sample(root / "samples" / "chair_0000.npz", np.zeros((100, 8, 8)),
    ...             np.zeros((32, 32, 32)), n_events=1200)
    >>> write_manifest(root, specs).name  # chair_0001 has no file yet: not listed
    'manifest.csv'
    >>> [(r["id"], r["split"], r["n_events"], len(r["sha256"])) for r in read_manifest(root)]
    [('chair_0000', 'test', 1200, 64)]
    """
    root = Path(root)
    known = {**manifest_digests(root), **(digests or {})}
    rows = []
    for spec in specs:
        path = root / "samples" / f"{spec.id}.npz"
        if path.exists():
            with np.load(path, allow_pickle=False) as data:
                n_events = int(data["n_events"])
            rows.append({"id": spec.id, "category": spec.category, "split": spec.split,
                         "seed": spec.seed, "n_events": n_events,
                         "sha256": known.get(spec.id) or npz_digest(path)})
    manifest = root / "manifest.csv"
    with atomic_path(manifest) as tmp, open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=MANIFEST_FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    return manifest


def read_manifest(root: str | os.PathLike) -> list[dict]:
    """Rows of ROOT/manifest.csv as dicts, each checked: the columns id, category, split,
    seed, n_events present; a plain-name id (:func:`check_id`) listed once; a split of
    train/val/test (exact case); a category of :data:`e2vlib.paper.CATEGORIES`; seed and
    n_events whole numbers (returned as int); ``sha256``, where given, 64 hex digits
    (absent from manifests older than it). Raises FileNotFoundError when there is no
    manifest, :class:`~e2vlib.data.checks.DatasetError` naming the row.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> header = "id,category,split,seed,n_events"
    >>> _ = (root / "manifest.csv").write_text(header + "\\nchair_0000,chair,test,7,1200")
    >>> read_manifest(root)
    [{'id': 'chair_0000', 'category': 'chair', 'split': 'test', 'seed': 7, 'n_events': 1200}]
    >>> _ = (root / "manifest.csv").write_text(header + "\\nchair_0000,chair,Test,7,1200")
    >>> read_manifest(root)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.data.checks.DatasetError: ...line 2 (sample 'chair_0000'): split 'Test' is not one of ...
    """
    root = Path(root)
    path = root / "manifest.csv"
    if not path.exists():
        raise FileNotFoundError(
            f"{path} not found: build a dataset with `python -m e2vlib make-data --out {root}`")
    reader = csv.DictReader(read_capped_text(path, MAX_MANIFEST_BYTES, "manifest").splitlines())
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


def _whole(text: str | None, name: str, where: str) -> int:
    if text is None or not re.fullmatch(r"\d{1,19}", text.strip()):
        raise DatasetError(f"{where}: {name} must be a whole number >= 0, got {text!r}; fix "
                           "the row or rebuild the manifest with make-data")
    return int(text)
