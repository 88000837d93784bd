"""The reviewed table that maps catalogue entries to the paper's 13 categories.

``data_small/real/catalogue.csv`` (:data:`MAPPING_CSV`) has one row per candidate model
(:data:`MAPPING_FIELDS`): our id, where the model comes from, its licence and the file
stating it, our category, its pose, whether we keep it and what looking at it showed.
:func:`read_mapping` reads and checks it (:func:`check_mapping`); :func:`resolve` pairs
each row with its entry of the installed libraries.

Scored by :mod:`e2vlib.experiments.real_study` (experiments/results/real_meshes.json).
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from e2vlib import paper
from e2vlib.experiments.real_meshes.catalogue import (
    CRRCSIM,
    CRRCSIM_DIR,
    CRRCSIM_INSTALL_HINT,
    FURNITURE_DIR,
    LIBRARY_LICENCES,
    LICENCES,
    CatalogueEntry,
    RealMeshError,
    crrcsim_entry,
    read_catalogue,
)
from e2vlib.experiments.real_meshes.meshes import POSES

MAPPING_CSV = Path(__file__).resolve().parents[3] / "data_small" / "real" / "catalogue.csv"
"""The reviewed mapping from catalogue entries to the paper's categories."""
MAPPING_FIELDS = ("id", "library", "entry_id", "name", "creator", "licence", "licence_file",
                  "category", "pose", "keep", "note")
"""Columns of the mapping table: our id, the ``.sh3f`` file, the entry's ``id#N``, its name
and creator, its licence and the file inside the library that states it
(:func:`entry_licence`), our category (one of the paper's 13), the pose (a key of
:data:`POSES`), ``yes``/``no`` and what looking at the model showed."""


MAX_MAPPING_BYTES = 4 << 20
"""Largest mapping table read, in bytes (the reviewed one, 258 rows, is about 60 KB)."""


@dataclass(frozen=True)
class MappedEntry:
    """One row of the mapping table (:data:`MAPPING_FIELDS`).

    Examples
    --------
    >>> row = {"id": "table_bs0_box", "library": "BlendSwap-CC-0.sh3f", "entry_id": "Test#box",
    ...        "name": "Box table", "creator": "Someone", "licence": "CC0-1.0",
    ...        "licence_file": "LICENSE.TXT", "category": "table", "pose": "as_placed",
    ...        "keep": "yes", "note": "looked: a box"}
    >>> entry = check_mapping([row])[0]
    >>> entry.id, entry.category, entry.keep
    ('table_bs0_box', 'table', True)
    """

    id: str
    library: str
    entry_id: str
    name: str
    creator: str
    licence: str
    licence_file: str
    category: str
    pose: str
    keep: bool
    note: str


def id_and_category_problems(row: dict, line: int, seen: set[str]) -> list[str]:
    """What is wrong with a catalogue row's ``id`` and ``category`` (a plain lower-case id,
    unique among ``seen``, which it joins, starting with a category of the paper's), each
    naming ``line``; shared by this table and the real-object catalogue."""
    rid, problems = row["id"], []
    if not re.fullmatch(r"[a-z]+_[a-z0-9_]+", rid):
        problems.append(f"line {line}: id {rid!r} is not a plain lower-case name")
    if rid in seen:
        problems.append(f"line {line}: duplicate id {rid!r}")
    seen.add(rid)
    if row["category"] not in paper.CATEGORIES:
        problems.append(f"line {line}: category {row['category']!r} is not one of the "
                        f"paper's ({', '.join(paper.CATEGORIES)})")
    elif not rid.startswith(row["category"] + "_"):
        problems.append(f"line {line}: id {rid!r} must start with its category")
    return problems


def check_mapping(rows: Iterable[dict], where: str = "catalogue.csv") -> list[MappedEntry]:
    """Check mapping rows (dicts of :data:`MAPPING_FIELDS`) and return them as
    :class:`MappedEntry`: ids unique plain names, categories the paper's, licences in
    :data:`LICENCES` and matching their library, ``keep`` ``yes`` or ``no``. Raises
    :class:`RealMeshError` listing every bad row (by line) and what to fix.

    Examples
    --------
    >>> row = {"id": "table_bs0_box", "library": "BlendSwap-CC-0.sh3f", "entry_id": "Test#box",
    ...        "name": "Box table", "creator": "Someone", "licence": "CC0-1.0",
    ...        "licence_file": "LICENSE.TXT", "category": "table", "pose": "as_placed",
    ...        "keep": "yes", "note": "looked: a box"}
    >>> [m.id for m in check_mapping([row])]
    ['table_bs0_box']
    >>> check_mapping([row, {**row, "category": "tables", "keep": "maybe"}])
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: catalogue.csv: 3 bad row(s): line 3: \
duplicate id 'table_bs0_box'; line 3: category 'tables' is not one of the paper's (airplane, \
bench, cabinet, car, chair, display, lamp, speaker, rifle, sofa, table, telephone, watercraft); \
line 3: keep must be yes or no, got 'maybe'
    """
    problems, out, seen = [], [], set()
    for line, row in enumerate(rows, start=2):
        absent = [f for f in MAPPING_FIELDS if row.get(f) is None]
        if absent:
            problems.append(f"line {line}: missing columns {absent}")
            continue
        problems += id_and_category_problems(row, line, seen)
        if row["licence"] not in LICENCES:
            problems.append(f"line {line}: licence {row['licence']!r} is not one of "
                            f"{', '.join(LICENCES)}")
        if row["library"] not in LIBRARY_LICENCES:
            problems.append(f"line {line}: unknown library {row['library']!r}")
        if row["licence"] == "GPL-2.0" and row["library"] != CRRCSIM:
            problems.append(f"line {line}: GPL-2.0 is allowed only for {CRRCSIM} rows")
        if not row["licence_file"].strip():
            problems.append(f"line {line}: licence_file is empty (name the file stating it)")
        if row["pose"] not in POSES:
            problems.append(f"line {line}: pose {row['pose']!r} is not one of "
                            f"{', '.join(POSES)}")
        if row["keep"] not in ("yes", "no"):
            problems.append(f"line {line}: keep must be yes or no, got {row['keep']!r}")
        if not row["note"].strip():
            problems.append(f"line {line}: note is empty (say what looking at it showed)")
        out.append(MappedEntry(**{f: row[f] for f in MAPPING_FIELDS if f != "keep"},
                               keep=row["keep"] == "yes"))
    if problems:
        raise RealMeshError(f"{where}: {len(problems)} bad row(s): " + "; ".join(problems[:10])
                            + ("; ..." if len(problems) > 10 else ""))
    return out


def read_mapping(path: str | os.PathLike = MAPPING_CSV, kept_only: bool = True
                 ) -> list[MappedEntry]:
    """The reviewed mapping table (:func:`check_mapping`); only the kept rows by default.

    Examples
    --------
    The reviewed table that ships with the lessons keeps 241 of its 258 rows:

    >>> kept = read_mapping()
    >>> len(kept), len(read_mapping(kept_only=False))
    (241, 258)
    >>> sum(m.library == CRRCSIM for m in kept)  # the aircraft of crrcsim-data
    23
    """
    rows = check_mapping(read_reviewed_csv(path, MAPPING_FIELDS, MAX_MAPPING_BYTES,
                                           "mapping table", "data_small/real/catalogue.csv"),
                         str(path))
    return [r for r in rows if r.keep or not kept_only]


def read_reviewed_csv(path: str | os.PathLike, fields: tuple[str, ...], limit: int,
                      what: str, reviewed: str) -> list[dict]:
    """The rows of a reviewed CSV table (the real-mesh mapping, the real-object catalogue)
    as dicts, before their own checks: a regular file of at most ``limit`` bytes, UTF-8 (a
    byte-order mark allowed), columns exactly ``fields``. FileNotFoundError or
    :class:`RealMeshError` naming the file (``what``; ``reviewed``, the committed table)
    and, for text that is not UTF-8 or not CSV, the line.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "t.csv"
    >>> _ = path.write_text("id,keep\\nchair_a,yes\\n")
    >>> read_reviewed_csv(path, ("id", "keep"), 100, "table", "t.csv")
    [{'id': 'chair_a', 'keep': 'yes'}]
    >>> read_reviewed_csv(path, ("id",), 100, "table", "t.csv")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: .../t.csv: columns must be id, \
got ['id', 'keep']
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{what} {path} not found; the reviewed one is {reviewed}")
    if not path.is_file():
        raise RealMeshError(f"{what} {path} is not a regular file (a folder, pipe or "
                            f"device); give a CSV file such as {reviewed}")
    size = path.stat().st_size
    if size > limit:
        raise RealMeshError(f"{what} {path} is {size} bytes, more than the {limit} such a "
                            f"table can be; give the reviewed table, {reviewed}")
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        raise RealMeshError(f"{path} line {line}: not UTF-8 text (byte {data[err.start]:#04x}"
                            f"); save the table as UTF-8 CSV") from None
    reader = csv.DictReader(io.StringIO(text, newline=""))
    try:
        if tuple(reader.fieldnames or ()) != fields:
            raise RealMeshError(f"{path}: columns must be {', '.join(fields)}, got "
                                f"{reader.fieldnames}")
        return list(reader)
    except csv.Error as err:
        raise RealMeshError(f"{path} line {reader.line_num}: not a CSV row ({err}); save the "
                            "table as UTF-8 CSV") from None


def resolve(mapped: Iterable[MappedEntry], folder: str | os.PathLike = FURNITURE_DIR,
            crrcsim_folder: str | os.PathLike = CRRCSIM_DIR
            ) -> list[tuple[MappedEntry, CatalogueEntry]]:
    """Each mapping row with its catalogue entry from the installed libraries (``.sh3f``
    files in ``folder``; crrcsim-data's AC3D files in ``crrcsim_folder``). Raises
    :class:`RealMeshError` naming rows whose entry is not there (another package version)
    and FileNotFoundError naming the install step of a package that is absent.

    Examples
    --------
    >>> import tempfile, zipfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> with zipfile.ZipFile(folder / "BlendSwap-CC-0.sh3f", "w") as zf:
    ...     zf.writestr("PluginFurnitureCatalog.properties",
    ...                 "id#1=Test#box\\nname#1=Box table\\nmodel#1=/box/box.obj\\n")
    >>> row = {"id": "table_bs0_box", "library": "BlendSwap-CC-0.sh3f", "entry_id": "Test#box",
    ...        "name": "Box table", "creator": "Someone", "licence": "CC0-1.0",
    ...        "licence_file": "LICENSE.TXT", "category": "table", "pose": "as_placed",
    ...        "keep": "yes", "note": "looked: a box"}
    >>> [(m.id, e.number, e.model) for m, e in resolve(check_mapping([row]), folder)]
    [('table_bs0_box', 1, 'box/box.obj')]
    >>> resolve(check_mapping([{**row, "entry_id": "Test#gone"}]), folder)
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: 1 mapped entries are not in the \
installed libraries (table_bs0_box); the package version differs from ...
    """
    mapped = list(mapped)
    catalogues = {}
    for lib in sorted({m.library for m in mapped}):
        if lib == CRRCSIM:
            if not Path(crrcsim_folder).is_dir():
                raise FileNotFoundError(f"{crrcsim_folder} not found: crrcsim-data is not "
                                        f"installed; {CRRCSIM_INSTALL_HINT}")
            catalogues[lib] = {m.entry_id: crrcsim_entry(m.entry_id, crrcsim_folder)
                               for m in mapped if m.library == lib
                               and (Path(crrcsim_folder) / m.entry_id).is_file()}
            continue
        catalogues[lib] = {e.entry_id: e for e in read_catalogue(Path(folder) / lib)}
    missing = [m.id for m in mapped if m.entry_id not in catalogues[m.library]]
    if missing:
        raise RealMeshError(f"{len(missing)} mapped entries are not in the installed "
                            f"libraries ({', '.join(missing[:5])}); the package version "
                            "differs from the one the table was reviewed on (1.8-1)")
    return [(m, catalogues[m.library][m.entry_id]) for m in mapped]

