"""The real objects a lesson may ship: the CC0 / CC-BY rows' samples, with their attribution.

Most kept real objects come from GPL or CC-BY-SA models, so nothing made from them is
committed. The Sweet Home 3D rows under CC0 or CC-BY (:data:`SHIPPABLE`) may be shared with
their attribution: :func:`ship_samples` copies their samples from the built dataset
(``make real-data``) into a small dataset folder in the repository
(``data_small/real_objects``: ``config.json``, ``manifest.csv``, ``samples/``,
``ATTRIBUTION.md``) that :class:`e2vlib.data.E2VDataset` reads, each object in its catalogue
split. Command: ``python -m e2vlib.experiments.real_objects ship``.
"""

from __future__ import annotations

import csv
import json
import os
from collections import Counter
from pathlib import Path

from e2vlib import paper
from e2vlib.data.manifest import MANIFEST_FIELDS
from e2vlib.experiments.real_objects.catalogue import CATALOGUE_CSV, RealObject, read_catalogue
from e2vlib.experiments.real_objects.samples import DATA_DIR
from e2vlib.files import atomic_path

SHIPPABLE = ("CC0-1.0", "CC-BY-3.0", "CC-BY-3.0-US")
"""Licences whose models' samples may be committed (with attribution for CC-BY)."""
SHIP_DIR = "data_small/real_objects"
SHIP_COMMAND = "python -m e2vlib.experiments.real_objects ship --out data_small/real_objects"


def shippable_rows(rows: list[RealObject] | None = None) -> list[RealObject]:
    """The kept catalogue rows under a licence of :data:`SHIPPABLE`, in catalogue order.

    Examples
    --------
    >>> rows = shippable_rows()
    >>> sorted({r.licence for r in rows}) == sorted(SHIPPABLE)
    True
    """
    rows = read_catalogue() if rows is None else rows
    return [row for row in rows if row.licence in SHIPPABLE]


def _attribution(rows: list[RealObject], mapping: dict[str, dict]) -> str:
    """ATTRIBUTION.md: one line per model (name, creator, licence, library, licence file)."""
    lines = [
        "# Attribution: the real objects of data_small/real_objects",
        "",
        "Each sample here (100 binary event frames and a 32^3 voxel label) was made from one",
        "3D model of Debian's `sweethome3d-furniture` package (Sweet Home 3D's furniture",
        "libraries) by rendering it on an orbit, simulating events and voxelising it. The",
        "models are the work of the creators named below, under the licence named beside",
        "each (CC0-1.0: no rights reserved; CC-BY-3.0: use with credit, as here). The samples",
        "are shared under the same licence as the model they were made from. The file named",
        "in the last column, inside the library, states the licence.",
        "",
        "| sample | model | creator | licence | library | licence file |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for row in rows:
        m = mapping[row.id]
        cells = [row.id, m["name"], m["creator"], row.licence, m["library"], m["licence_file"]]
        lines.append("| " + " | ".join(c.replace("|", "/") for c in cells) + " |")
    return "\n".join(lines) + "\n"


MAX_SHIP_SAMPLE_BYTES = 16 << 20
"""Largest sample file shipped, in bytes (a built sample is about 100 kB)."""
MAX_SHIP_ARRAY_BYTES = 256 << 20
"""Largest total of a sample's arrays once unpacked, in bytes."""


def check_ship_out(data: Path, out: Path) -> None:
    """Refuse an ``out`` folder that is, holds or lies inside the dataset ``data`` it is
    shipped from (shipping would rewrite its source), or that is an existing file."""
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--out {out} is an existing file, not a folder; give a "
                                 f"folder to ship into (default {SHIP_DIR})")
    source, target = data.resolve(), out.resolve()
    if target == source or source.is_relative_to(target) or target.is_relative_to(source):
        how = ("is" if target == source else "holds" if source.is_relative_to(target)
               else "lies inside")
        raise ValueError(f"--out {out} {how} the dataset {data} it ships from; shipping "
                         f"would rewrite its source: give another folder (default {SHIP_DIR})")


def read_sample(data: Path, sample_id: str, sha256: str) -> bytes:
    """The bytes of ``data/samples/<sample_id>.npz``, checked before anything is copied: a
    regular file inside ``data`` (no link leaving it, no FIFO or device), at most
    :data:`MAX_SHIP_SAMPLE_BYTES`, arrays of at most :data:`MAX_SHIP_ARRAY_BYTES`, whose
    digest (:func:`~e2vlib.data.manifest.npz_digest`) is the manifest's ``sha256``.
    ValueError naming the file and the fix otherwise."""
    import io
    import zipfile

    from e2vlib.data.checks import inside
    from e2vlib.data.manifest import npz_digest
    from e2vlib.files import read_bounded

    path = data / "samples" / f"{sample_id}.npz"
    inside(data.resolve(), path)  # a link out of the dataset is refused
    content = read_bounded(path, "sample", MAX_SHIP_SAMPLE_BYTES)
    rebuild = "rebuild it with `make real-data`"
    try:
        with zipfile.ZipFile(io.BytesIO(content)) as zf:
            unpacked = sum(info.file_size for info in zf.infolist())
    except zipfile.BadZipFile:
        raise ValueError(f"sample {path} is not an .npz file; {rebuild}") from None
    if unpacked > MAX_SHIP_ARRAY_BYTES:
        raise ValueError(f"sample {path} unpacks to {unpacked} bytes, more than "
                         f"MAX_SHIP_ARRAY_BYTES ({MAX_SHIP_ARRAY_BYTES}); {rebuild}")
    if not sha256:
        raise ValueError(f"{data / 'manifest.csv'} records no sha256 for {sample_id}; "
                         f"{rebuild}")
    try:
        digest = npz_digest(io.BytesIO(content))
    except ValueError:
        raise ValueError(f"sample {path} is a damaged .npz file; {rebuild}") from None
    if digest != sha256:
        raise ValueError(f"sample {path} does not match its digest in {data / 'manifest.csv'}"
                         f" (sha256 {digest[:12]}..., recorded {sha256[:12]}...); {rebuild}")
    return content


def ship_samples(data: str | os.PathLike = DATA_DIR,
                 out: str | os.PathLike = SHIP_DIR,
                 catalogue: str | os.PathLike = CATALOGUE_CSV) -> dict[str, int]:
    """Copy the shippable rows' samples from ``data`` into ``out`` with a manifest, the
    build settings and ATTRIBUTION.md; return the count per split.

    Every sample is read and checked (:func:`read_sample`: a regular file inside ``data``,
    bounded, its digest the manifest's) before anything is written; every file is then
    written to a temporary name and renamed. A row missing from ``data``, an ``out`` that
    is, holds or lies in ``data`` or is a file (:func:`check_ship_out`) are refused."""
    from e2vlib.data.checks import inside, read_config
    from e2vlib.data.manifest import read_manifest
    from e2vlib.experiments.real_meshes import MAPPING_CSV

    data, out = Path(data), Path(out)
    if not (data / "manifest.csv").is_file():
        raise FileNotFoundError(f"{data} holds no real-object dataset; build it with "
                                "`make real-data`")
    check_ship_out(data, out)
    rows = shippable_rows(read_catalogue(catalogue))
    inside(data.resolve(), data / "manifest.csv")
    inside(data.resolve(), data / "config.json")
    built = {r["id"]: r for r in read_manifest(data)}
    missing = [row.id for row in rows if row.id not in built]
    if missing:
        raise ValueError(f"{len(missing)} shippable rows are not built in {data} "
                         f"({', '.join(missing[:3])}, ...); run `make real-data` first")
    stored = read_config(data)
    content = {row.id: read_sample(data, row.id, built[row.id].get("sha256", ""))
               for row in rows}
    with open(MAPPING_CSV, newline="") as f:
        mapping = {r["id"]: r for r in csv.DictReader(f)}
    (out / "samples").mkdir(parents=True, exist_ok=True)
    for row in rows:
        with atomic_path(out / "samples" / f"{row.id}.npz") as partial:
            partial.write_bytes(content[row.id])
    source = stored.get("source") if isinstance(stored.get("source"), dict) else {}
    config = {**{k: v for k, v in stored.items() if k != "source"},
              "source": {"catalogue": "experiments/real_objects/catalogue.csv",
                         "catalogue_sha256": source.get("catalogue_sha256"),
                         "licences": list(SHIPPABLE), "command": SHIP_COMMAND}}
    with atomic_path(out / "config.json") as partial:
        partial.write_text(json.dumps(config, indent=1) + "\n")
    with atomic_path(out / "manifest.csv") as partial, open(partial, "w", newline="") as f:
        writer = csv.DictWriter(f, MANIFEST_FIELDS, extrasaction="ignore")
        writer.writeheader()
        order = {c: i for i, c in enumerate(paper.CATEGORIES)}
        for row in sorted(rows, key=lambda r: (order[r.category], r.id)):
            writer.writerow(built[row.id])
    with atomic_path(out / "ATTRIBUTION.md") as partial:
        partial.write_text(_attribution(rows, mapping))
    return dict(Counter(row.split for row in rows))
