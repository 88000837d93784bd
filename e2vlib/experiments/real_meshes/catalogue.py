"""Debian's Sweet Home 3D furniture libraries: their catalogues, licences and constants.

``apt-get install sweethome3d-furniture`` installs five libraries,
``/usr/share/sweethome3d/furniture/*.sh3f``: zip files holding OBJ models (with their MTL
files and textures) and a ``PluginFurnitureCatalog.properties`` that lists each entry as
numbered keys (``id#N``, ``name#N``, ``category#N``, ``model#N``, ``creator#N``,
``width#N``, ``depth#N``, ``height#N`` in cm, optional ``modelRotation#N``). Every library
is under one licence, stated in its ``LICENSE.TXT`` (CC0 or CC-BY 3.0;
:data:`LIBRARY_LICENCES`); a model's own licence file can say otherwise
(:func:`entry_licence`). The aircraft of ``crrcsim-data`` are AC3D files on disk, one
:class:`CatalogueEntry` each (:func:`crrcsim_entry`).

Scored by :mod:`e2vlib.experiments.real_study` (experiments/results/real_meshes.json).
"""

from __future__ import annotations

import os
import posixpath
import re
import zipfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

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
"""Largest OBJ member read from a library, and largest AC3D file, in bytes (the biggest
installed one is about 20 MB)."""
MAX_CATALOGUE_BYTES = 16 << 20
"""Largest :data:`CATALOGUE_FILE` read from a library, in bytes (the installed ones are
under 1 MB)."""
MAX_LICENCE_BYTES = 1 << 20
"""Largest licence file read from a model's folder, in bytes (Blend Swap's are a few KB)."""
MIN_MODEL_EXTENT = 1e-4
"""Smallest longest side of a model as stored, in its own units (mm, cm or m): trimesh
welds vertices closer than 1e-8, so a smaller model collapses to a point."""
MAX_MODEL_COORDINATE = 1e9
"""Largest absolute vertex coordinate of a model as stored or scaled to its catalogue size,
in its own units: trimesh's vertex welding overflows int64 above about 9.2e10."""
ZIP_METHODS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflated"}
"""Compression methods read from a library (Sweet Home 3D writes deflated members); others
(bzip2, lzma) are refused, as they cannot be inflated a bounded piece at a time."""
_CHUNK = 1 << 20  # bytes inflated per read of a zip member

CRRCSIM_DIR = Path("/usr/share/games/crrcsim/objects")
"""Where Debian's ``crrcsim-data`` installs its AC3D (``.ac``) model aircraft."""
CRRCSIM_INSTALL_HINT = "apt-get install crrcsim-data"
CRRCSIM_COPYRIGHT = "/usr/share/doc/crrcsim-data/copyright"
CRRCSIM_CREATOR = "CRRCSim contributors (Debian copyright: J. E. Kansky, M. Drela, B. Jackson)"


class RealMeshError(ValueError):
    """A real-mesh library, catalogue entry or mapping row that cannot be used; the message
    names the file or entry and the fix.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> junk = Path(tempfile.mkdtemp()) / "junk.sh3f"
    >>> _ = junk.write_bytes(b"not a zip")
    >>> try:
    ...     read_catalogue(junk)
    ... except RealMeshError as err:  # a ValueError
    ...     print(str(err).split(": ")[1].split(" (")[0])
    not a readable .sh3f zip
    """


def open_library(path: str | os.PathLike) -> zipfile.ZipFile:
    """The ``.sh3f`` zip at ``path``, open; :class:`RealMeshError` naming the file when it
    is not a readable zip (close it after use: ``with open_library(path) as zf``)."""
    try:
        return zipfile.ZipFile(path)
    except Exception as err:  # zipfile raises BadZipFile, OSError, ValueError, EOFError...
        raise RealMeshError(f"{path}: not a readable .sh3f zip ({type(err).__name__}: "
                            f"{err}); reinstall it with {INSTALL_HINT} --reinstall") from err


def read_member(zf: zipfile.ZipFile, name: str, limit: int, where: str) -> bytes:
    """The bytes of member ``name`` of the open library ``zf``, at most ``limit`` of them.

    The size the zip declares is checked before anything is read, and the member is
    inflated a piece at a time, so a member that inflates past its declared size stops at
    ``limit``. Raises :class:`RealMeshError` naming ``where`` and the member when it is
    missing, larger than ``limit``, compressed by a method not in :data:`ZIP_METHODS`, or
    damaged.

    Examples
    --------
    >>> import io
    >>> buffer = io.BytesIO()
    >>> with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as zf:
    ...     zf.writestr("big.txt", b"0" * 5000)
    >>> read_member(zipfile.ZipFile(buffer), "big.txt", 4096, "lib.sh3f")
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: lib.sh3f: big.txt is 5000 bytes, \
more than the bound of 4096 bytes; this is not one of Debian's libraries: reinstall it with \
apt-get install sweethome3d-furniture --reinstall
    """
    fix = f"this is not one of Debian's libraries: reinstall it with {INSTALL_HINT} --reinstall"
    try:
        info = zf.getinfo(name)
    except KeyError:
        raise RealMeshError(f"{where}: {name} is missing from the library; reinstall it with "
                            f"{INSTALL_HINT} --reinstall") from None
    if info.file_size > limit:
        raise RealMeshError(f"{where}: {name} is {info.file_size} bytes, more than the bound "
                            f"of {limit} bytes; {fix}")
    if info.compress_type not in ZIP_METHODS:
        raise RealMeshError(f"{where}: {name} is compressed by zip method {info.compress_type}"
                            f", not {' or '.join(ZIP_METHODS.values())}; {fix}")
    parts, size = [], 0
    try:
        with zf.open(info) as member:
            while chunk := member.read(_CHUNK):
                size += len(chunk)
                if size > limit:
                    raise RealMeshError(f"{where}: {name} inflates past the bound of {limit} "
                                        f"bytes (it declares {info.file_size}); {fix}")
                parts.append(chunk)
    except RealMeshError:
        raise
    except Exception as err:  # BadZipFile (CRC), zlib.error, RuntimeError (encrypted), EOFError
        raise RealMeshError(f"{where}: {name} cannot be read ({type(err).__name__}: {err}); "
                            f"{fix}") from err
    return b"".join(parts)


def check_model_extent(vertices: Sequence, where: str, cause: str = "as stored") -> None:
    """Refuse (:class:`RealMeshError` naming ``where``) vertices that are not finite, reach
    past :data:`MAX_MODEL_COORDINATE` or span less than :data:`MIN_MODEL_EXTENT`.

    Examples
    --------
    >>> check_model_extent([[0, 0, 0], [1, 2, 3]], "box.obj")
    >>> check_model_extent([[0, 0, 0], [1e-9, 0, 0]], "dot.obj")
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: dot.obj: the model as stored spans \
1e-09 units, less than MIN_MODEL_EXTENT (0.0001): it is degenerate or in far too small units
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if len(v) == 0:
        raise RealMeshError(f"{where}: the model {cause} has no vertices")
    if not np.all(np.isfinite(v)):
        raise RealMeshError(f"{where}: the model {cause} has NaN or infinite coordinates")
    reach = float(np.abs(v).max())
    if reach > MAX_MODEL_COORDINATE:
        raise RealMeshError(f"{where}: the model {cause} reaches {reach:.3g} units from the "
                            f"origin, more than MAX_MODEL_COORDINATE ({MAX_MODEL_COORDINATE:g}"
                            "): its coordinates or catalogue size are absurd")
    extent = float((v.max(axis=0) - v.min(axis=0)).max())
    if extent < MIN_MODEL_EXTENT:
        raise RealMeshError(f"{where}: the model {cause} spans {extent:.3g} units, less than "
                            f"MIN_MODEL_EXTENT ({MIN_MODEL_EXTENT:g}): it is degenerate or in "
                            "far too small units")


@dataclass(frozen=True)
class CatalogueEntry:
    """One furniture entry of an ``.sh3f`` catalogue.

    ``number`` is the ``N`` of its ``key#N`` keys; ``model`` the OBJ's path inside the zip
    (no leading slash); ``size_cm`` ``(width, depth, height)`` as the catalogue gives them
    (x, z, y of the OBJ, in cm); ``rotation`` the row-major 3x3 ``modelRotation`` (None when
    absent); ``licence`` the library's (:data:`LIBRARY_LICENCES`, or its ``license`` key).

    Examples
    --------
    >>> entry = crrcsim_entry("plane.ac", "/objects")
    >>> entry.library, entry.entry_id, entry.model, entry.size_cm, entry.licence
    ('crrcsim-data', 'plane.ac', '/objects/plane.ac', None, 'GPL-2.0')
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

    Examples
    --------
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

    Examples
    --------
    >>> import tempfile, zipfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> library = folder / "BlendSwap-CC-0.sh3f"
    >>> with zipfile.ZipFile(library, "w") as zf:
    ...     zf.writestr(CATALOGUE_FILE, "id#1=Test#box\\nname#1=Box table\\n"
    ...                 "model#1=/box/box.obj\\nwidth#1=200\\ndepth#1=100\\nheight#1=50\\n")
    >>> [(e.number, e.entry_id, e.name, e.model, e.size_cm, e.licence)
    ...  for e in read_catalogue(library)]
    [(1, 'Test#box', 'Box table', 'box/box.obj', (200.0, 100.0, 50.0), 'CC0-1.0')]
    """
    path = Path(library)
    if not path.exists():
        raise FileNotFoundError(f"{path} not found; the real meshes come from Debian's "
                                f"package: {INSTALL_HINT}")
    if not path.is_file():
        raise RealMeshError(f"{path} is not a regular file (a folder, pipe or device); give "
                            f"the .sh3f library that {INSTALL_HINT} installs")
    with open_library(path) as zf:
        if CATALOGUE_FILE not in zf.namelist():
            raise RealMeshError(f"{path} holds no {CATALOGUE_FILE}: it is not a Sweet Home 3D "
                                "furniture library")
        text = read_member(zf, CATALOGUE_FILE, MAX_CATALOGUE_BYTES, str(path)).decode("latin-1")
    props = parse_properties(text)
    licence = LIBRARY_LICENCES.get(path.name, props.get("license", ""))
    numbers = sorted({int(m.group(1)) for k in props
                      if (m := re.fullmatch(r"id#(\d{1,9})", k))})
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
    when there are none.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> installed_libraries(folder)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    FileNotFoundError: no .sh3f furniture libraries in ...: sweethome3d-furniture is not \
installed; apt-get install sweethome3d-furniture
    >>> for name in ("Scopia.sh3f", "KatorLegaz.sh3f", "notes.txt"):
    ...     _ = (folder / name).write_bytes(b"")
    >>> [path.name for path in installed_libraries(folder)]
    ['KatorLegaz.sh3f', 'Scopia.sh3f']
    """
    folder = Path(folder)
    found = sorted(folder.glob("*.sh3f")) if folder.is_dir() else []
    if not found:
        raise FileNotFoundError(f"no .sh3f furniture libraries in {folder}: "
                                f"sweethome3d-furniture is not installed; {INSTALL_HINT}")
    return found


def read_all_catalogues(folder: str | os.PathLike = FURNITURE_DIR) -> list[CatalogueEntry]:
    """Entries of every installed library (:func:`installed_libraries`), library by library.

    Examples
    --------
    >>> import tempfile, zipfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> library = folder / "BlendSwap-CC-0.sh3f"
    >>> with zipfile.ZipFile(library, "w") as zf:
    ...     zf.writestr(CATALOGUE_FILE, "id#1=Test#box\\nname#1=Box table\\n"
    ...                 "model#1=/box/box.obj\\nwidth#1=200\\ndepth#1=100\\nheight#1=50\\n")
    >>> [(e.library, e.entry_id) for e in read_all_catalogues(folder)]
    [('BlendSwap-CC-0.sh3f', 'Test#box')]
    """
    return [e for lib in installed_libraries(folder) for e in read_catalogue(lib)]


_LICENCE_PATTERNS = (
    ("CC0-1.0", re.compile(r"Creative Commons Zero|\bCC-?0\b", re.I)),
    ("CC-BY-3.0", re.compile(r"Creative Commons Attribution 3\.0(?! United States)", re.I)),
)
_NOT_ALLOWED = re.compile(r"NonCommercial|Non-Commercial|Share ?Alike|No ?Derivs|\bNC\b|\bSA\b")


def licence_from_text(text: str) -> str | None:
    """The licence (SPDX name of :data:`LICENCES`) a Blend Swap licence file (text or
    HTML) states ("Released under ..." or "under the following license: ..."), or None
    when it states none of them or adds a NonCommercial / ShareAlike / NoDerivs term.

    Examples
    --------
    >>> licence_from_text("<p>Released under Creative Commons Attribution 3.0</p>")
    'CC-BY-3.0'
    >>> licence_from_text("Released under CC0")
    'CC0-1.0'
    >>> licence_from_text("Released under Creative Commons Attribution-NonCommercial 3.0") is None
    True
    """
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
    licence, stated in its Debian copyright file.

    Examples
    --------
    >>> import tempfile, zipfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> library = folder / "BlendSwap-CC-0.sh3f"
    >>> with zipfile.ZipFile(library, "w") as zf:
    ...     zf.writestr(CATALOGUE_FILE, "id#1=Test#box\\nname#1=Box table\\n"
    ...                 "model#1=/box/box.obj\\nwidth#1=200\\ndepth#1=100\\nheight#1=50\\n")
    ...     zf.writestr("box/BLENDSWAP_LICENSE.txt", "Released under Creative Commons "
    ...                 "Attribution 3.0")
    >>> entry_licence(read_catalogue(library)[0], folder)  # the model's own file wins
    ('CC-BY-3.0', 'box/BLENDSWAP_LICENSE.txt')
    """
    if entry.library == CRRCSIM:
        return entry.licence, CRRCSIM_COPYRIGHT
    model_dir = posixpath.dirname(entry.model) + "/"
    path = Path(folder) / entry.library
    with open_library(path) as zf:
        files = sorted(n for n in zf.namelist() if n.startswith(model_dir)
                       and "licen" in posixpath.basename(n).lower())
        if not files:
            return entry.licence, "LICENSE.TXT"
        text = read_member(zf, files[0], MAX_LICENCE_BYTES, f"{path} entry #{entry.number}")
        return licence_from_text(text.decode("utf-8", "replace")), files[0]



def crrcsim_entry(file_name: str, crrcsim_folder: str | os.PathLike = CRRCSIM_DIR
                  ) -> CatalogueEntry:
    """The :class:`CatalogueEntry` of the AC3D model ``file_name`` of crrcsim-data.

    Examples
    --------
    >>> crrcsim_entry("plane.ac", "/objects").name
    'plane'
    >>> crrcsim_entry("../plane.ac")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: crrcsim-data entry '../plane.ac' ...
    """
    path = Path(crrcsim_folder) / file_name
    if Path(file_name).name != file_name or path.suffix != ".ac":
        raise RealMeshError(f"crrcsim-data entry {file_name!r} must be a plain .ac file name")
    return CatalogueEntry(library=CRRCSIM, number=0, entry_id=file_name, name=path.stem,
                          category="aircraft", creator=CRRCSIM_CREATOR, model=str(path),
                          size_cm=None, rotation=None, licence=LIBRARY_LICENCES[CRRCSIM])

