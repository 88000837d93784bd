"""The committed catalogue of real objects and its checker.

``experiments/real_objects/catalogue.csv`` has one row per model looked at
(:data:`FIELDS`): our id (category first), the Debian package and the path inside it
(``archive::member`` inside a zip; for the reviewed Sweet Home 3D
rows ``library::entry id``), its licence (SPDX), one of the paper's 13 categories, the
rotation that stands it upright facing -y (turns such as ``z90``, after the format's own:
:data:`~e2vlib.experiments.real_objects.readers.FORMAT_TURNS`; the Sweet Home 3D rows keep
their pose name), the parts the reader left out, ``yes``/``no``, the split of kept rows
(``train``/``val``/``test``, by object, stratified by category: :func:`assign_splits`) and
what looking at it showed (``looked: ...``). It holds facts only, no geometry.
:func:`read_catalogue` reads and checks it (:func:`check_catalogue`).
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from e2vlib.experiments.real_meshes.catalogue import RealMeshError
from e2vlib.experiments.real_meshes.mapping import id_and_category_problems, read_reviewed_csv
from e2vlib.experiments.real_meshes.meshes import POSES
from e2vlib.experiments.real_objects.sources import MEMBER_SEP

CATALOGUE_CSV = Path(__file__).resolve().parents[3] / "experiments" / "real_objects" / \
    "catalogue.csv"
"""The committed catalogue."""
FIELDS = ("id", "source", "path", "licence", "category", "rotation", "removed", "keep",
          "split", "note")
"""Its columns, in order."""
SOURCES = ("flightgear-data-base", "flightgear-data-ai", "flightgear-data-models",
           "torcs-data", "ufoai-data", "gl-117-data", "openarena-data",
           "minetest-mod-homedecor", "sweethome3d", "sweethome3d-furniture", "crrcsim-data")
"""Debian packages a row may come from (the last two: the reviewed rows of
:mod:`e2vlib.experiments.real_meshes`)."""
LICENCES = ("GPL-2.0", "GPL-2.0-only", "GPL-2.0-or-later", "GPL-3.0-or-later",
            "CC-BY-SA-3.0", "CC-BY-SA-4.0", "CC-BY-3.0", "CC-BY-3.0-US", "CC0-1.0",
            "public-domain", "WTFPL", "FAL-1.3")
"""Licences a row may carry (SPDX names)."""
SHAREABLE = ("CC0-1.0", "CC-BY-3.0", "CC-BY-3.0-US", "public-domain", "WTFPL")
"""Licences whose models may ship with the lessons (with attribution); all others (GPL,
CC-BY-SA) stay out of git."""
SPLITS = ("train", "val", "test")
SPLIT_FRACTIONS = (0.70, 0.15, 0.15)
"""Share of each category's kept objects in each split."""
MAX_CATALOGUE_BYTES = 8 << 20
"""Largest catalogue read, in bytes."""


@dataclass(frozen=True)
class RealObject:
    """One row of the catalogue (:data:`FIELDS`; ``keep`` a bool)."""

    id: str
    source: str
    path: str
    licence: str
    category: str
    rotation: str
    removed: str
    keep: bool
    split: str
    note: str


def _rotation_ok(text: str) -> bool:
    return text in POSES or text in ("", "none") or all(
        re.fullmatch(r"[xyz]-?(90|180|270)", t) for t in text.split())


def path_problem(path: str) -> str | None:
    """What is wrong with a row's ``path`` (None: nothing): it names a file inside its
    package's folder, ``archive`` or ``archive::member`` (a zip member, or a Sweet Home 3D
    entry), each part relative and plain: not empty, not absolute, no ``..``, no drive.

    Examples
    --------
    >>> path_problem("cars/p406.acc"), path_problem("z.zip::models/x.ac")
    (None, None)
    >>> path_problem("/etc/passwd")
    "path '/etc/passwd' is absolute; give it relative to its package's folder"
    >>> path_problem("z.zip::../../x.ac")
    "path 'z.zip::../../x.ac' climbs out with '..'; give a plain path inside its package"
    """
    parts = path.split(MEMBER_SEP)
    if len(parts) > 2 or not all(part.strip() for part in parts):
        return (f"path {path!r} is not 'file' or 'archive{MEMBER_SEP}member' with both parts "
                "named")
    for part in parts:
        steps = re.split(r"[/\\]", part)
        if part.startswith(("/", "\\")) or re.match(r"[A-Za-z]:", part):
            return f"path {path!r} is absolute; give it relative to its package's folder"
        if ".." in steps:
            return f"path {path!r} climbs out with '..'; give a plain path inside its package"
        if "\x00" in part:
            return f"path {path!r} holds a NUL character"
    return None


def check_catalogue(rows: Iterable[dict], where: str = "catalogue.csv") -> list[RealObject]:
    """Check catalogue rows (dicts of :data:`FIELDS`) and return them as
    :class:`RealObject`; raises :class:`RealMeshError` naming ``where`` and each bad line:
    missing columns, ids that are not unique plain names starting with their category, an
    unknown source, licence or category, a path that leaves its package
    (:func:`path_problem`), a bad rotation, keep not yes/no, a kept row without a split (or
    a dropped one with one), a note that does not start ``looked:``.

    Examples
    --------
    >>> row = {"id": "car_torcs_p406", "source": "torcs-data", "path": "cars/p406.acc",
    ...        "licence": "GPL-2.0-or-later", "category": "car", "rotation": "z90",
    ...        "removed": "", "keep": "yes", "split": "train", "note": "looked: a saloon"}
    >>> [r.id for r in check_catalogue([row])]
    ['car_torcs_p406']
    >>> check_catalogue([row, {**row, "category": "truck", "split": "dev", "note": ""}])
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: catalogue.csv: 4 bad row(s): \
line 3: duplicate id 'car_torcs_p406'; line 3: category 'truck' is not one of the paper's \
(airplane, bench, cabinet, car, chair, display, lamp, speaker, rifle, sofa, table, \
telephone, watercraft); line 3: a kept row needs a split (train, val or test), got 'dev'; \
line 3: note must start 'looked:' (say what looking at it showed)
    """
    problems, out, seen = [], [], set()
    for line, row in enumerate(rows, start=2):
        absent = [f for f in FIELDS if row.get(f) is None]
        if absent:
            problems.append(f"line {line}: missing columns {absent}")
            continue
        problems += id_and_category_problems(row, line, seen)
        if row["source"] not in SOURCES:
            problems.append(f"line {line}: unknown source {row['source']!r}")
        if not row["path"].strip():
            problems.append(f"line {line}: path is empty")
        elif (problem := path_problem(row["path"])) is not None:
            problems.append(f"line {line}: {problem}")
        if row["licence"] not in LICENCES:
            problems.append(f"line {line}: licence {row['licence']!r} is not one of "
                            f"{', '.join(LICENCES)}")
        if not _rotation_ok(row["rotation"]):
            problems.append(f"line {line}: rotation {row['rotation']!r} is not turns such "
                            "as 'x90 z-90' or a pose name")
        if row["keep"] not in ("yes", "no"):
            problems.append(f"line {line}: keep must be yes or no, got {row['keep']!r}")
        elif row["keep"] == "yes" and row["split"] not in SPLITS:
            problems.append(f"line {line}: a kept row needs a split (train, val or test), "
                            f"got {row['split']!r}")
        elif row["keep"] == "no" and row["split"]:
            problems.append(f"line {line}: a dropped row has no split, got {row['split']!r}")
        if not row["note"].startswith("looked:") or len(row["note"].strip()) <= 8:
            problems.append(f"line {line}: note must start 'looked:' (say what looking at "
                            "it showed)")
        out.append(RealObject(**{f: row[f] for f in FIELDS if f != "keep"},
                              keep=row["keep"] == "yes"))
    if problems:
        raise RealMeshError(f"{where}: {len(problems)} bad row(s): " + "; ".join(problems[:10])
                            + ("; ..." if len(problems) > 10 else ""))
    return out


def read_catalogue(path: str | os.PathLike = CATALOGUE_CSV, kept_only: bool = True
                   ) -> list[RealObject]:
    """The catalogue at ``path``, read as every reviewed table is
    (:func:`~e2vlib.experiments.real_meshes.mapping.read_reviewed_csv`) and checked
    (:func:`check_catalogue`: each row's path inside its package); kept rows only by
    default. Raises FileNotFoundError or :class:`RealMeshError` naming the file."""
    rows = read_reviewed_csv(path, FIELDS, MAX_CATALOGUE_BYTES, "catalogue",
                             "experiments/real_objects/catalogue.csv")
    return [r for r in check_catalogue(rows, str(path)) if r.keep or not kept_only]


def assign_splits(ids_by_category: dict[str, list[str]],
                  fractions: tuple[float, float, float] = SPLIT_FRACTIONS) -> dict[str, str]:
    """``{id: split}``: within each category the ids are ordered by a hash of the id and cut
    at the cumulative ``fractions`` (at least one val and one test object in a category of
    three or more), so every split holds each category in proportion and no object is in
    two splits.

    Examples
    --------
    >>> splits = assign_splits({"car": [f"car_{i}" for i in range(20)], "lamp": ["lamp_a"]})
    >>> sorted(splits.values()).count("test"), splits["lamp_a"]
    (3, 'train')
    """
    out = {}
    for _category, ids in sorted(ids_by_category.items()):
        order = sorted(ids, key=lambda i: hashlib.sha256(i.encode()).hexdigest())
        n = len(order)
        n_val = round(n * fractions[1])
        n_test = round(n * fractions[2])
        if n >= 3:
            n_val, n_test = max(n_val, 1), max(n_test, 1)
        n_train = n - n_val - n_test
        for k, rid in enumerate(order):
            out[rid] = "train" if k < n_train else "val" if k < n_train + n_val else "test"
    return out


def write_rows(path: str | os.PathLike, rows: list[dict]) -> None:
    """Write catalogue rows (checked first) to ``path`` through a temporary file."""
    check_catalogue(rows, str(path))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, FIELDS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(buffer.getvalue(), encoding="utf-8")
    os.replace(tmp, path)
