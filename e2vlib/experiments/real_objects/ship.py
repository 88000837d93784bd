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
import shutil
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


def ship_samples(data: str | os.PathLike = DATA_DIR,
                 out: str | os.PathLike = SHIP_DIR,
                 catalogue: str | os.PathLike = CATALOGUE_CSV) -> dict[str, int]:
    """Copy the shippable rows' samples from ``data`` into ``out`` with a manifest, the
    build settings and ATTRIBUTION.md; return the count per split. Every file is written
    to a temporary name and renamed; a row missing from ``data`` is refused, naming it."""
    from e2vlib.experiments.real_meshes import MAPPING_CSV

    data, out = Path(data), Path(out)
    if not (data / "manifest.csv").is_file():
        raise FileNotFoundError(f"{data} holds no real-object dataset; build it with "
                                "`make real-data`")
    rows = shippable_rows(read_catalogue(catalogue))
    with open(data / "manifest.csv", newline="") as f:
        built = {r["id"]: r for r in csv.DictReader(f)}
    missing = [row.id for row in rows if row.id not in built]
    if missing:
        raise ValueError(f"{len(missing)} shippable rows are not built in {data} "
                         f"({', '.join(missing[:3])}, ...); run `make real-data` first")
    with open(MAPPING_CSV, newline="") as f:
        mapping = {r["id"]: r for r in csv.DictReader(f)}
    (out / "samples").mkdir(parents=True, exist_ok=True)
    for row in rows:
        with atomic_path(out / "samples" / f"{row.id}.npz") as partial:
            shutil.copyfile(data / "samples" / f"{row.id}.npz", partial)
    stored = json.loads((data / "config.json").read_text())
    config = {**{k: v for k, v in stored.items() if k != "source"},
              "source": {"catalogue": "experiments/real_objects/catalogue.csv",
                         "catalogue_sha256": stored.get("source", {}).get("catalogue_sha256"),
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
