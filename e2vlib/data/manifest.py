"""ROOT/manifest.csv: one row per built sample, with the digest of its file's arrays.

:func:`write_manifest` lists the planned samples present on disk with their
:func:`npz_digest`; :func:`read_manifest` reads it back, every row checked.
Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import csv
import hashlib
import os
import zipfile
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from e2vlib.data.checks import read_manifest_rows
from e2vlib.data.plan import SampleSpec
from e2vlib.files import atomic_path

MANIFEST_FIELDS = ("id", "category", "split", "seed", "n_events", "sha256")


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
    """Rows of ROOT/manifest.csv as dicts (``seed``, ``n_events`` as int; ``sha256`` as
    written, and absent from manifests older than it). Every row is checked
    (:func:`e2vlib.data.checks.read_manifest_rows`): a bad one is a :class:`DatasetError`
    naming its line.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> rows = "id,category,split,seed,n_events\\nlamp_3,lamp,val,5,9"
    >>> _ = (root / "manifest.csv").write_text(rows)
    >>> read_manifest(root)  # an older manifest, without sha256
    [{'id': 'lamp_3', 'category': 'lamp', 'split': 'val', 'seed': 5, 'n_events': 9}]
    """
    return read_manifest_rows(root)
