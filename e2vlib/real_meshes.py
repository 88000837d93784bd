"""Real third-party meshes of the paper's categories, from Debian's ``sweethome3d-furniture``.

The package (``apt-get install sweethome3d-furniture``) installs five Sweet Home 3D furniture
libraries, ``/usr/share/sweethome3d/furniture/*.sh3f``: zip files holding OBJ models (with
their MTL files and textures) and a ``PluginFurnitureCatalog.properties`` that lists each
entry as numbered keys (``id#N``, ``name#N``, ``category#N``, ``model#N``, ``creator#N``,
``width#N``, ``depth#N``, ``height#N`` in cm, optional ``modelRotation#N``). Every library is
under one licence, stated in its ``LICENSE.TXT`` (CC0 or CC-BY 3.0; :data:`LIBRARY_LICENCES`).

This module reads those catalogues (:func:`read_catalogue`), loads an entry's model as one
``trimesh.Trimesh`` in the project's frame (:func:`load_entry_mesh`: z up, front -y, bounding
box centred, longest side 1), and reads the reviewed table that maps entries to the paper's 13
categories (:func:`read_mapping`, ``data_small/real/catalogue.csv``). The samples are built
with the data_small protocol by :func:`build_real_dataset` (``python -m e2vlib make-data
--preset real``) and scored by :mod:`e2vlib.real_study`.

Introduced in notebooks/13_putting_it_together.ipynb.
"""

from __future__ import annotations

import csv
import io
import os
import posixpath
import re
import zipfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from e2vlib import paper

FURNITURE_DIR = Path("/usr/share/sweethome3d/furniture")
"""Where Debian's ``sweethome3d-furniture`` installs its ``.sh3f`` libraries."""
INSTALL_HINT = "apt-get install sweethome3d-furniture"
"""The install step the real-mesh test set needs (Debian's package, about 130 MB; its
aircraft also need ``crrcsim-data``, :data:`CRRCSIM_INSTALL_HINT`)."""
CRRCSIM = "crrcsim-data"
"""The ``library`` of mapping rows whose model is an AC3D aircraft of Debian's crrcsim-data
(``entry_id``: the ``.ac`` file name in :data:`CRRCSIM_DIR`)."""
CATALOGUE_FILE = "PluginFurnitureCatalog.properties"
"""The catalogue inside an ``.sh3f`` zip (Java properties, ISO-8859-1)."""
MAPPING_CSV = Path(__file__).resolve().parent.parent / "data_small" / "real" / "catalogue.csv"
"""The reviewed mapping from catalogue entries to the paper's categories."""
MAPPING_FIELDS = ("id", "library", "entry_id", "name", "creator", "licence", "licence_file",
                  "category", "pose", "keep", "note")
"""Columns of the mapping table: our id, the ``.sh3f`` file, the entry's ``id#N``, its name
and creator, its licence and the file inside the library that states it
(:func:`entry_licence`), our category (one of the paper's 13), the pose (a key of
:data:`POSES`), ``yes``/``no`` and what looking at the model showed."""
POSES = {
    "as_placed": np.eye(4),
    "stood_up": np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]]),
}
"""Extra turn after :data:`SH3D_TO_ZUP`: ``as_placed`` keeps the pose Sweet Home 3D puts the
object in a room; ``stood_up`` (+90 degrees about x) stands a phone that lies flat on its back
upright with its screen to the front (-y), as ShapeNet's and our procedural telephones
stand."""
LIBRARY_CODES = {
    "BlendSwap-CC-0.sh3f": "bs0",
    "BlendSwap-CC-BY.sh3f": "bsby",
    "KatorLegaz.sh3f": "kl",
    "Reallusion.sh3f": "rl",
    "Scopia.sh3f": "sc",
    CRRCSIM: "crrc",
}
"""Short code of each library, used in our ids (``chair_bs0_armchair``)."""
LICENCES = ("CC0-1.0", "CC-BY-3.0", "CC-BY-3.0-US", "GPL-2.0")
"""Licences a mapped entry may carry (SPDX names). GPL-2.0 is only that of Debian's
``crrcsim-data`` aircraft (:data:`CRRCSIM`), which are read where the package installs them
and never shipped; models that ship in ``data_small/real/meshes`` are CC0."""
LIBRARY_LICENCES = {
    "BlendSwap-CC-0.sh3f": "CC0-1.0",
    "BlendSwap-CC-BY.sh3f": "CC-BY-3.0",
    "KatorLegaz.sh3f": "CC-BY-3.0-US",
    "Reallusion.sh3f": "CC-BY-3.0-US",
    "Scopia.sh3f": "CC-BY-3.0",
    CRRCSIM: "GPL-2.0",
}
"""Each library's licence, as its ``LICENSE.TXT`` and Debian's copyright file state it
(``crrcsim-data``: its copyright file, ``Files: *``)."""
MAX_MODEL_BYTES = 64 << 20
"""Largest OBJ member read from a library (the biggest installed one is about 20 MB)."""

CRRCSIM_DIR = Path("/usr/share/games/crrcsim/objects")
"""Where Debian's ``crrcsim-data`` installs its AC3D (``.ac``) model aircraft."""
CRRCSIM_INSTALL_HINT = "apt-get install crrcsim-data"
CRRCSIM_COPYRIGHT = "/usr/share/doc/crrcsim-data/copyright"
CRRCSIM_CREATOR = "CRRCSim contributors (Debian copyright: J. E. Kansky, M. Drela, B. Jackson)"

SH3D_TO_ZUP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
"""Sweet Home 3D models are y up with the front towards +z; this rotation (+90 degrees
about x: ``(x, y, z) -> (x, -z, y)``) turns them into our frame (z up, front -y)."""


class RealMeshError(ValueError):
    """A real-mesh library, catalogue entry or mapping row that cannot be used; the message
    names the file or entry and the fix."""


@dataclass(frozen=True)
class CatalogueEntry:
    """One furniture entry of an ``.sh3f`` catalogue.

    ``number`` is the ``N`` of its ``key#N`` keys; ``model`` the OBJ's path inside the zip
    (no leading slash); ``size_cm`` ``(width, depth, height)`` as the catalogue gives them
    (x, z, y of the OBJ, in cm); ``rotation`` the row-major 3x3 ``modelRotation`` (None when
    absent); ``licence`` the library's (:data:`LIBRARY_LICENCES`, or its ``license`` key).
    """

    library: str
    number: int
    entry_id: str
    name: str
    category: str
    creator: str
    model: str
    size_cm: tuple[float, float, float] | None
    rotation: tuple[float, ...] | None
    licence: str


_ESCAPES = {"t": "\t", "n": "\n", "r": "\r", "f": "\f"}


def _unescape(text: str) -> str:
    """Undo Java properties escapes (``\\uXXXX``, ``\\t``..., ``\\x`` -> ``x``)."""
    out, i = [], 0
    while i < len(text):
        c = text[i]
        if c != "\\" or i + 1 == len(text):
            out.append(c)
            i += 1
            continue
        nxt = text[i + 1]
        if nxt == "u" and re.fullmatch(r"[0-9a-fA-F]{4}", text[i + 2:i + 6]):
            out.append(chr(int(text[i + 2:i + 6], 16)))
            i += 6
        else:
            out.append(_ESCAPES.get(nxt, nxt))
            i += 2
    return "".join(out)


def _logical_lines(text: str) -> Iterator[str]:
    """Java properties logical lines: comments and blanks dropped, continuations joined."""
    pending = ""
    for raw in text.splitlines():
        line = raw.lstrip(" \t\f")
        if not pending and (not line or line[0] in "#!"):
            continue
        trailing = len(line) - len(line.rstrip("\\"))
        if trailing % 2:  # an odd number of backslashes continues the line
            pending += line[:-1]
            continue
        yield pending + line
        pending = ""
    if pending:
        yield pending


def parse_properties(text: str) -> dict[str, str]:
    """Parse Java ``.properties`` text into ``{key: value}`` (later keys win).

    Follows ``java.util.Properties.load``: ``#``/``!`` comments, ``=``, ``:`` or white space
    between key and value, backslash continuations and ``\\uXXXX`` escapes.

    >>> parse_properties("# note\\nname#1=Arm\\\\\\n  chair\\nkey\\\\ one : caf\\\\u00e9")
    {'name#1': 'Armchair', 'key one': 'café'}
    """
    props = {}
    for line in _logical_lines(text):
        i, key_end = 0, None
        while i < len(line):
            c = line[i]
            if c == "\\":
                i += 2
                continue
            if c in "=: \t\f":
                key_end = i
                break
            i += 1
        if key_end is None:
            props[_unescape(line)] = ""
            continue
        rest = line[key_end:].lstrip(" \t\f")
        if line[key_end] in " \t\f" and rest[:1] in ("=", ":"):
            rest = rest[1:].lstrip(" \t\f")
        elif line[key_end] in "=:":
            rest = line[key_end + 1:].lstrip(" \t\f")
        props[_unescape(line[:key_end])] = _unescape(rest)
    return props


def _floats(text: str | None, count: int, where: str) -> tuple[float, ...] | None:
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        values = ()
    if len(values) != count or not all(np.isfinite(values)):
        raise RealMeshError(f"{where}: expected {count} numbers, got {text!r}")
    return values


def read_catalogue(library: str | os.PathLike) -> list[CatalogueEntry]:
    """Every entry of one ``.sh3f`` library, in ``N`` order.

    Raises :class:`RealMeshError` naming the file when it is not a zip, holds no
    :data:`CATALOGUE_FILE`, or an entry lacks its ``id``, ``name`` or ``model``.
    """
    path = Path(library)
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found; the real meshes come from Debian's "
                                f"package: {INSTALL_HINT}")
    try:
        with zipfile.ZipFile(path) as zf:
            text = zf.read(CATALOGUE_FILE).decode("latin-1")
    except KeyError:
        raise RealMeshError(f"{path} holds no {CATALOGUE_FILE}: it is not a Sweet Home 3D "
                            "furniture library") from None
    except (zipfile.BadZipFile, OSError) as err:
        raise RealMeshError(f"{path}: not a readable .sh3f zip ({err}); reinstall it with "
                            f"{INSTALL_HINT} --reinstall") from err
    props = parse_properties(text)
    licence = LIBRARY_LICENCES.get(path.name, props.get("license", ""))
    numbers = sorted({int(m.group(1)) for k in props if (m := re.fullmatch(r"id#(\d+)", k))})
    entries = []
    for n in numbers:
        where = f"{path.name} entry #{n}"
        missing = [k for k in ("name", "model") if not props.get(f"{k}#{n}")]
        if missing:
            raise RealMeshError(f"{where} has no {' or '.join(missing)}; the catalogue is "
                                "damaged: reinstall the package")
        dims = [props.get(f"{k}#{n}") for k in ("width", "depth", "height")]
        size = (_floats(" ".join(dims), 3, where) if all(d is not None for d in dims)
                else None)
        entries.append(CatalogueEntry(
            library=path.name, number=n, entry_id=props[f"id#{n}"], name=props[f"name#{n}"],
            category=props.get(f"category#{n}", ""), creator=props.get(f"creator#{n}", ""),
            model=props[f"model#{n}"].lstrip("/"), size_cm=size,
            rotation=_floats(props.get(f"modelRotation#{n}"), 9, where), licence=licence))
    return entries


def installed_libraries(folder: str | os.PathLike = FURNITURE_DIR) -> list[Path]:
    """The ``.sh3f`` files in ``folder``, sorted; FileNotFoundError naming the install step
    when there are none."""
    folder = Path(folder)
    found = sorted(folder.glob("*.sh3f")) if folder.is_dir() else []
    if not found:
        raise FileNotFoundError(f"no .sh3f furniture libraries in {folder}: "
                                f"sweethome3d-furniture is not installed; {INSTALL_HINT}")
    return found


def read_all_catalogues(folder: str | os.PathLike = FURNITURE_DIR) -> list[CatalogueEntry]:
    """Entries of every installed library (:func:`installed_libraries`), library by library."""
    return [e for lib in installed_libraries(folder) for e in read_catalogue(lib)]


# --- loading a model ---------------------------------------------------------------------


def _read_member(zf: zipfile.ZipFile, name: str, where: str) -> bytes:
    try:
        info = zf.getinfo(name)
    except KeyError:
        raise RealMeshError(f"{where}: {name} is missing from the library; reinstall it with "
                            f"{INSTALL_HINT} --reinstall") from None
    if info.file_size > MAX_MODEL_BYTES:
        raise RealMeshError(f"{where}: {name} is {info.file_size} bytes, more than "
                            f"real_meshes.MAX_MODEL_BYTES ({MAX_MODEL_BYTES})")
    return zf.read(info)


def obj_to_mesh(data: bytes, where: str = "OBJ") -> trimesh.Trimesh:
    """Every face of OBJ text ``data`` as one ``trimesh.Trimesh``, as stored (no materials:
    the renderer shades by geometry; parts and groups are merged, duplicate vertices welded).

    Raises :class:`RealMeshError` for text with no triangles or NaN/inf vertices.
    """
    try:
        loaded = trimesh.load(io.BytesIO(data), file_type="obj", force="mesh", process=False,
                              skip_materials=True)
    except Exception as err:  # the OBJ parser raises many types
        raise RealMeshError(f"{where}: could not read the OBJ ({type(err).__name__}: "
                            f"{err})") from err
    if isinstance(loaded, trimesh.Scene):
        loaded = loaded.to_geometry()
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise RealMeshError(f"{where}: the OBJ holds no triangles")
    if not np.all(np.isfinite(loaded.vertices)):
        raise RealMeshError(f"{where}: the OBJ has NaN or infinite vertex coordinates")
    # merge the parts' duplicate vertices, so closed parts are watertight for voxelize
    return trimesh.Trimesh(loaded.vertices, loaded.faces, process=True)


def entry_transform(entry: CatalogueEntry, bounds: np.ndarray) -> np.ndarray:
    """4x4 transform taking the stored OBJ of ``entry`` (bounding box ``bounds``, (2, 3))
    to our frame as Sweet Home 3D shows it: ``modelRotation`` first, then each axis scaled
    to the catalogue's width (x), height (y), depth (z), then :data:`SH3D_TO_ZUP`."""
    rotation = np.eye(4)
    if entry.rotation is not None:
        rotation[:3, :3] = np.reshape(entry.rotation, (3, 3))
    corners = np.array([[x, y, z] for x in bounds[:, 0] for y in bounds[:, 1]
                        for z in bounds[:, 2]])
    turned = trimesh.transform_points(corners, rotation)
    extent = turned.max(0) - turned.min(0)
    scale = np.eye(4)
    if entry.size_cm is not None and np.all(extent > 0):
        width, depth, height = entry.size_cm
        target = np.array([width, height, depth])
        if np.all(target > 0):
            scale[:3, :3] = np.diag(target / extent)
    return SH3D_TO_ZUP @ scale @ rotation


def load_entry_mesh(entry: CatalogueEntry, folder: str | os.PathLike = FURNITURE_DIR,
                    normalize: bool = True, pose: str = "as_placed") -> trimesh.Trimesh:
    """The model of ``entry`` as one mesh in our frame (z up, front -y), by
    :func:`entry_transform` and then the turn :data:`POSES` ``[pose]``; with ``normalize``
    (the default) also
    :func:`e2vlib.shapes.normalize_mesh` (bounding box centred, longest side 1, in m).

    ``folder`` holds the ``.sh3f`` libraries (Debian's package by default); an entry of
    :data:`CRRCSIM` is read from its AC3D file (:func:`ac3d_to_mesh`). Raises
    FileNotFoundError naming the install step when the library is absent and
    :class:`RealMeshError` when its model cannot be read.
    """
    from e2vlib.shapes import normalize_mesh

    if pose not in POSES:
        raise ValueError(f"pose must be one of {', '.join(POSES)}, got {pose!r}")
    if entry.library == CRRCSIM:  # an AC3D file on disk (entry.model: its path)
        path = Path(entry.model)
        if not path.is_file():
            raise FileNotFoundError(f"{path} not found: crrcsim-data is not installed; "
                                    f"{CRRCSIM_INSTALL_HINT}")
        mesh = ac3d_to_mesh(path.read_text(encoding="latin-1"), str(path))
        mesh.apply_transform(POSES[pose] @ SH3D_TO_ZUP)  # AC3D is y up too, nose to +z
        return normalize_mesh(mesh) if normalize else mesh
    path = Path(folder) / entry.library
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: sweethome3d-furniture is not installed; "
                                f"{INSTALL_HINT}")
    where = f"{entry.library} entry #{entry.number} ({entry.name})"
    with zipfile.ZipFile(path) as zf:
        mesh = obj_to_mesh(_read_member(zf, entry.model, where), where)
    mesh.apply_transform(POSES[pose] @ entry_transform(entry, mesh.bounds))
    return normalize_mesh(mesh) if normalize else mesh


_LICENCE_PATTERNS = (
    ("CC0-1.0", re.compile(r"Creative Commons Zero|\bCC-?0\b", re.I)),
    ("CC-BY-3.0", re.compile(r"Creative Commons Attribution 3\.0(?! United States)", re.I)),
)
_NOT_ALLOWED = re.compile(r"NonCommercial|Non-Commercial|Share ?Alike|No ?Derivs|\bNC\b|\bSA\b")


def licence_from_text(text: str) -> str | None:
    """The licence (SPDX name of :data:`LICENCES`) a Blend Swap licence file (text or
    HTML) states ("Released under ..." or "under the following license: ..."), or None
    when it states none of them or adds a NonCommercial / ShareAlike / NoDerivs term."""
    plain = " ".join(re.sub(r"<[^>]+>", " ", re.sub(r"<style.*?</style>", " ", text,
                                                      flags=re.S)).split())
    match = re.search(r"(?:Released under|under the following license:) (.{0,80})", plain)
    stated = match.group(1) if match else ""
    if _NOT_ALLOWED.search(stated):
        return None
    for spdx, pattern in _LICENCE_PATTERNS:
        if pattern.search(stated):
            return spdx
    return None


def entry_licence(entry: CatalogueEntry, folder: str | os.PathLike = FURNITURE_DIR
                  ) -> tuple[str | None, str]:
    """``(licence, file)``: what the licence file in the entry's model folder states
    (:func:`licence_from_text`; Blend Swap models carry one, and it can differ from the
    library's: two models of the CC0 library are CC-BY 3.0), else the library's licence
    (:data:`LIBRARY_LICENCES`, from its ``LICENSE.TXT``). ``licence`` is None when the
    model's own file names no allowed licence. A :data:`CRRCSIM` entry has the package's
    licence, stated in its Debian copyright file."""
    if entry.library == CRRCSIM:
        return entry.licence, CRRCSIM_COPYRIGHT
    model_dir = posixpath.dirname(entry.model) + "/"
    with zipfile.ZipFile(Path(folder) / entry.library) as zf:
        files = sorted(n for n in zf.namelist() if n.startswith(model_dir)
                       and "licen" in posixpath.basename(n).lower())
        if not files:
            return entry.licence, "LICENSE.TXT"
        return licence_from_text(zf.read(files[0]).decode("utf-8", "replace")), files[0]


# --- the reviewed mapping ----------------------------------------------------------------


@dataclass(frozen=True)
class MappedEntry:
    """One row of the mapping table (:data:`MAPPING_FIELDS`)."""

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


def check_mapping(rows: Iterable[dict], where: str = "catalogue.csv") -> list[MappedEntry]:
    """Check mapping rows (dicts of :data:`MAPPING_FIELDS`) and return them as
    :class:`MappedEntry`: ids unique plain names, categories the paper's, licences in
    :data:`LICENCES` and matching their library, ``keep`` ``yes`` or ``no``. Raises
    :class:`RealMeshError` listing every bad row (by line) and what to fix."""
    problems, out, seen = [], [], set()
    for line, row in enumerate(rows, start=2):
        absent = [f for f in MAPPING_FIELDS if row.get(f) is None]
        if absent:
            problems.append(f"line {line}: missing columns {absent}")
            continue
        rid = row["id"]
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
    """The reviewed mapping table (:func:`check_mapping`); only the kept rows by default."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"mapping table {path} not found; the reviewed one is "
                                "data_small/real/catalogue.csv")
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        if tuple(reader.fieldnames or ()) != MAPPING_FIELDS:
            raise RealMeshError(f"{path}: columns must be {', '.join(MAPPING_FIELDS)}, got "
                                f"{reader.fieldnames}")
        rows = check_mapping(reader, str(path))
    return [r for r in rows if r.keep or not kept_only]


def crrcsim_entry(file_name: str, crrcsim_folder: str | os.PathLike = CRRCSIM_DIR
                  ) -> CatalogueEntry:
    """The :class:`CatalogueEntry` of the AC3D model ``file_name`` of crrcsim-data."""
    path = Path(crrcsim_folder) / file_name
    if Path(file_name).name != file_name or path.suffix != ".ac":
        raise RealMeshError(f"crrcsim-data entry {file_name!r} must be a plain .ac file name")
    return CatalogueEntry(library=CRRCSIM, number=0, entry_id=file_name, name=path.stem,
                          category="aircraft", creator=CRRCSIM_CREATOR, model=str(path),
                          size_cm=None, rotation=None, licence=LIBRARY_LICENCES[CRRCSIM])


def resolve(mapped: Iterable[MappedEntry], folder: str | os.PathLike = FURNITURE_DIR,
            crrcsim_folder: str | os.PathLike = CRRCSIM_DIR
            ) -> list[tuple[MappedEntry, CatalogueEntry]]:
    """Each mapping row with its catalogue entry from the installed libraries (``.sh3f``
    files in ``folder``; crrcsim-data's AC3D files in ``crrcsim_folder``). Raises
    :class:`RealMeshError` naming rows whose entry is not there (another package version)
    and FileNotFoundError naming the install step of a package that is absent."""
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


# --- building the samples ----------------------------------------------------------------


BUILD_COMMAND = ("apt-get install -y sweethome3d-furniture crrcsim-data && "
                 "python -m e2vlib make-data "
                 "--preset small --real-meshes data_small/real/catalogue.csv "
                 "--out cache/real_meshes")
"""The recorded command that builds the real-mesh test set (install step first)."""


def real_sample_seed(seed: int, sample_id: str) -> int:
    """A stable 31-bit simulator seed for the real object ``sample_id``."""
    import hashlib

    digest = hashlib.sha256(f"{seed}/real/{sample_id}".encode()).digest()
    return int.from_bytes(digest[:4], "little") & 0x7FFFFFFF


def real_config(config, catalogue: str | os.PathLike = MAPPING_CSV,
                folder: str | os.PathLike = FURNITURE_DIR) -> dict:
    """config.json of a real-mesh dataset: the frame and render settings of ``config`` (a
    :class:`e2vlib.data.BuildConfig`; ``per_category`` dropped, as the catalogue sets the
    objects), the categories present, and where the meshes came from (the libraries'
    folder and the catalogue, as given, with the catalogue's sha256)."""
    import hashlib

    catalogue = Path(catalogue)
    d = config.to_dict()
    d.pop("per_category")
    rows = read_mapping(catalogue)
    d["categories"] = [c for c in paper.CATEGORIES if any(m.category == c for m in rows)]
    aircraft = any(m.library == CRRCSIM for m in rows)
    d["source"] = {"packages": ["sweethome3d-furniture", *([CRRCSIM] if aircraft else [])],
                   "install": INSTALL_HINT + (" crrcsim-data" if aircraft else ""),
                   "folder": str(folder), "catalogue": str(catalogue),
                   "catalogue_sha256": hashlib.sha256(catalogue.read_bytes()).hexdigest()}
    return d


def _build_real_one(args: tuple) -> str:
    config, mapped, entry, root, folder = args
    from e2vlib.data import mesh_to_sample, save_sample

    mesh = load_entry_mesh(entry, folder, pose=mapped.pose)
    sample = mesh_to_sample(mesh, config, seed=real_sample_seed(config.seed, mapped.id))
    save_sample(Path(root) / "samples" / f"{mapped.id}.npz", sample.frames, sample.voxels,
                len(sample.events))
    return mapped.id


def build_real_dataset(root: str | os.PathLike, config,
                       catalogue: str | os.PathLike = MAPPING_CSV,
                       folder: str | os.PathLike = FURNITURE_DIR, workers: int = 1,
                       progress: bool = True) -> Path:
    """Build (or finish) the real-mesh test set in ``root``; return its manifest path.

    Every kept row of ``catalogue`` (:func:`read_mapping`) becomes one test sample, made
    from its installed model (:func:`load_entry_mesh`) by :func:`e2vlib.data.mesh_to_sample`
    with ``config``'s settings (the data_small protocol with ``--preset small``), so models
    trained on data_small read it as they read its test split. The layout is a dataset's
    (``config.json`` from :func:`real_config`, ``manifest.csv``, ``samples/<id>.npz``), so
    :class:`e2vlib.data.E2VDataset` (split ``test``) and ``evaluate`` read it. Resumable:
    samples on disk are skipped; every file is written to a temporary name and renamed.
    Raises FileNotFoundError naming the install step when the package is absent.
    """
    import json

    from e2vlib.data import SampleSpec, run_jobs, write_manifest
    from e2vlib.dataset_checks import DatasetError
    from e2vlib.files import atomic_path

    root = Path(root)
    installed_libraries(folder)  # names the install step when the package is absent
    wanted = real_config(config, catalogue, folder)
    config_path = root / "config.json"
    if config_path.exists():
        stored = json.loads(config_path.read_text())
        settings = {k: v for k, v in stored.items() if k not in ("categories", "source")}
        if "source" not in stored or settings != {
                k: v for k, v in wanted.items() if k not in ("categories", "source")}:
            raise DatasetError(f"{config_path} was built with other settings ({stored}); use "
                               "another --out folder or delete it to rebuild")
    elif root.exists() and any(p.name not in ("samples", "manifest.csv")
                               for p in root.iterdir()):
        raise DatasetError(f"{root} exists and is not a real-mesh dataset; choose another "
                           "--out folder")
    (root / "samples").mkdir(parents=True, exist_ok=True)
    # a changed catalogue keeps the samples it still lists (each is made from its own model
    # and id alone) and records the new catalogue
    with atomic_path(config_path) as tmp:
        tmp.write_text(json.dumps(wanted, indent=2) + "\n")
    pairs = resolve(read_mapping(catalogue), folder)
    specs, seen = [], {}
    for mapped, _ in pairs:
        index = seen[mapped.category] = seen.get(mapped.category, -1) + 1
        specs.append(SampleSpec(id=mapped.id, category=mapped.category, index=index,
                                split="test", seed=real_sample_seed(config.seed, mapped.id)))
    jobs = [(config, m, e, str(root), str(folder)) for m, e in pairs
            if not (root / "samples" / f"{m.id}.npz").exists()]
    run_jobs(_build_real_one, jobs, workers, f"building {root.name}", "object", progress)
    return write_manifest(root, specs)


# --- AC3D models (Debian's crrcsim-data) -------------------------------------------------




def ac3d_to_mesh(text: str, where: str = "AC3D") -> trimesh.Trimesh:
    """The polygons of AC3D text (``AC3Db`` files) as one ``trimesh.Trimesh``, as stored.

    Objects nest (``kids``); each object's vertices are moved by its ``loc`` and those of
    its parents (and turned by a ``rot`` matrix where one is given, applied to column
    vectors). Polygon surfaces (``SURF`` type 0) are fanned into triangles; line surfaces
    (types 1 and 2) have no area and are left out. Materials and textures are not read.
    Raises :class:`RealMeshError` naming ``where`` and the line for text that does not
    parse or holds no polygon.
    """
    lines = text.splitlines()
    if not lines or not lines[0].startswith("AC3D"):
        raise RealMeshError(f"{where}: not an AC3D file (no AC3D header)")
    vertices: list[np.ndarray] = []
    faces: list[list[int]] = []
    pos = 1

    def fail(message: str) -> RealMeshError:
        return RealMeshError(f"{where} line {pos + 1}: {message}")

    def numbers(line: str, count: int) -> list[float]:
        try:
            values = [float(v) for v in line.split()[:count]]
        except ValueError:
            values = []
        if len(values) != count or not all(np.isfinite(values)):
            raise fail(f"expected {count} numbers, got {line!r}")
        return values

    def read_object(parent: np.ndarray) -> None:
        nonlocal pos
        local, own, kids = np.eye(4), None, 0
        while pos < len(lines):
            line = lines[pos].strip()
            word = line.split(" ", 1)[0]
            pos += 1
            if word == "loc":
                local[:3, 3] = numbers(line[4:], 3)
            elif word == "rot":
                local[:3, :3] = np.reshape(numbers(line[4:], 9), (3, 3))
            elif word == "data":
                pos += 1  # the data string's line
            elif word == "numvert":
                n = int(numbers(line[8:], 1)[0])
                own = np.array([numbers(lines[pos + k], 3) for k in range(n)])
                pos += n
            elif word == "numsurf":
                for _ in range(int(numbers(line[8:], 1)[0])):
                    pos = _read_surface(lines, pos, faces, sum(map(len, vertices)),
                                        0 if own is None else len(own), fail)
            elif word == "kids":
                kids = int(numbers(line[5:], 1)[0])
                break
        transform = parent @ local
        if own is not None and len(own):
            vertices.append(trimesh.transform_points(own, transform))
        for _ in range(kids):
            while pos < len(lines) and not lines[pos].startswith("OBJECT"):
                pos += 1
            if pos == len(lines):
                raise fail("fewer objects than its kids line says")
            pos += 1
            read_object(transform)

    while pos < len(lines) and not lines[pos].startswith("OBJECT"):
        pos += 1
    if pos == len(lines):
        raise RealMeshError(f"{where}: no OBJECT in the file")
    pos += 1
    read_object(np.eye(4))
    if not faces:
        raise RealMeshError(f"{where}: the file holds no polygon surface")
    return trimesh.Trimesh(np.concatenate(vertices), np.array(faces), process=True)


def _read_surface(lines: list[str], pos: int, faces: list[list[int]], offset: int,
                  n_vertices: int, fail) -> int:
    """Read one ``SURF`` block from line ``pos``; fan its polygon into ``faces`` (vertex
    indices shifted by ``offset``); return the line after it."""
    if not lines[pos].startswith("SURF"):
        raise fail(f"expected SURF, got {lines[pos]!r}")
    try:
        kind = int(lines[pos].split()[1], 16) & 0xF
    except (IndexError, ValueError):
        raise fail(f"bad SURF flags {lines[pos]!r}") from None
    pos += 1
    while pos < len(lines) and not lines[pos].startswith("refs"):
        pos += 1  # mat
    if pos == len(lines):
        raise fail("a SURF without refs")
    n = int(lines[pos].split()[1])
    refs = [int(lines[pos + 1 + k].split()[0]) for k in range(n)]
    if any(not 0 <= r < n_vertices for r in refs):
        raise fail(f"a surface refers to vertices outside 0..{n_vertices - 1}")
    if kind == 0:
        faces.extend([offset + refs[0], offset + refs[k], offset + refs[k + 1]]
                     for k in range(1, n - 1))
    return pos + 1 + n
