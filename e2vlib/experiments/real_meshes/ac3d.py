"""A small reader of AC3D (``.ac``) models, the format of Debian's crrcsim-data aircraft.

Scored by :mod:`e2vlib.experiments.real_study` (experiments/results/real_meshes.json).
"""

from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np
import trimesh

from e2vlib.experiments.real_meshes.catalogue import RealMeshError, check_model_extent

MAX_AC3D_DEPTH = 64
"""Deepest nesting of AC3D objects read, in levels (``kids`` inside ``kids``; the
crrcsim-data aircraft nest a few levels)."""


def ac3d_to_mesh(text: str, where: str = "AC3D", drop: Callable[[str], bool] | None = None,
                 dropped: list[str] | None = None, strict: bool = True) -> trimesh.Trimesh:
    """The polygons of AC3D text (``AC3Db`` files) as one ``trimesh.Trimesh``, as stored.

    Objects nest (``kids``); each object's vertices are moved by its ``loc`` and those of
    its parents (and turned by a ``rot`` matrix where one is given, applied to column
    vectors). Polygon surfaces (``SURF`` type 0) are fanned into triangles and triangle
    strips (type 4, TORCS's ``.acc``) unrolled; line surfaces (types 1 and 2) have no area
    and are left out. Materials and textures are not read.
    Raises :class:`RealMeshError` naming ``where`` and the line for text that does not
    parse: a count (``numvert``, ``numsurf``, ``refs``, ``kids``) that is not a whole number
    or more than the lines left can hold, objects nested deeper than
    :data:`MAX_AC3D_DEPTH`, or no polygon (:func:`check_model_extent` for the vertices).

    ``drop``, when given, is asked about each object's ``name`` (``""`` when it has none):
    an object it answers True for is left out with all its kids, and its name is appended
    to ``dropped`` (when a list is given). Debian's FlightGear and TORCS models name their
    shadow squares, light cones and level-of-detail copies so
    (:mod:`e2vlib.experiments.real_objects.readers`); TORCS's ``.acc`` files read as
    ``.ac`` (their extra texture coordinates are ignored). With ``strict=False`` a file
    that ends before the objects its ``kids`` lines promise, or holds more top-level
    objects than its world's ``kids``, is read as far as it goes, and blank lines are
    skipped (some FlightGear files).

    Examples
    --------
    One square (a four-vertex polygon: two triangles) in an object moved by ``loc 1 0 0``:

    >>> text = "\\n".join(["AC3Db", "OBJECT world", "kids 1", "OBJECT poly", "loc 1 0 0",
    ...                    "numvert 4", "0 0 0", "1 0 0", "1 1 0", "0 1 0", "numsurf 1",
    ...                    "SURF 0x10", "mat 0", "refs 4", "0 0 0", "1 0 0", "2 0 0", "3 0 0",
    ...                    "kids 0"])
    >>> mesh = ac3d_to_mesh(text)
    >>> len(mesh.faces), mesh.bounds.tolist()
    (2, [[1.0, 0.0, 0.0], [2.0, 1.0, 0.0]])
    >>> gone = []
    >>> shadowless = ac3d_to_mesh(text.replace("OBJECT poly", 'OBJECT poly\\nname "shadow"')
    ...                           + "\\nOBJECT poly\\nnumvert 3\\n0 0 0\\n1 0 0\\n0 0 1\\nnumsurf 1"
    ...                           "\\nSURF 0\\nrefs 3\\n0 0 0\\n1 0 0\\n2 0 0\\nkids 0",
    ...                           drop=lambda name: name == "shadow", dropped=gone,
    ...                           strict=False)
    >>> len(shadowless.faces), gone
    (1, ['shadow'])
    >>> ac3d_to_mesh("OBJECT world", "plane.ac")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: plane.ac: not an AC3D file ...
    """
    reader = _Lines(text, where)
    if not strict:  # blank lines inside a surface's refs (some FlightGear files)
        reader.lines = [line for line in reader.lines if line.strip()]
    if not reader.lines or not reader.lines[0].startswith("AC3D"):
        raise RealMeshError(f"{where}: not an AC3D file (no AC3D header)")
    reader.skip_to_object()
    if reader.pos == len(reader.lines):
        raise RealMeshError(f"{where}: no OBJECT in the file")
    vertices: list[np.ndarray] = []
    faces: list[list[int]] = []
    _read_object(reader, np.eye(4), vertices, faces, depth=1, drop=drop, dropped=dropped,
                 strict=strict)
    while not strict:  # files whose world holds fewer kids than follow (TORCS's)
        reader.skip_to_object()
        if reader.pos == len(reader.lines):
            break
        reader.pos += 1
        _read_object(reader, np.eye(4), vertices, faces, depth=1, drop=drop, dropped=dropped,
                     strict=strict)
    if not faces:
        raise RealMeshError(f"{where}: the file holds no polygon surface")
    check_model_extent(np.concatenate(vertices), where)
    return trimesh.Trimesh(np.concatenate(vertices), np.array(faces), process=True)


class _Lines:
    """The lines of an AC3D file and a cursor (``pos``: the next line to read); every
    error it makes names the file and the line just read."""

    def __init__(self, text: str, where: str):
        self.lines, self.where, self.pos = text.splitlines(), where, 1

    def fail(self, message: str) -> RealMeshError:
        return RealMeshError(f"{self.where} line {self.pos}: {message}")

    def next(self, what: str) -> str:
        """The next line, stripped (the cursor moves past it)."""
        if self.pos >= len(self.lines):
            raise RealMeshError(f"{self.where}: the file ends where {what} should be "
                                f"(after line {len(self.lines)})")
        self.pos += 1
        return self.lines[self.pos - 1].strip()

    def skip_to_object(self) -> None:
        """Move the cursor to the next ``OBJECT`` line (or the end)."""
        while self.pos < len(self.lines) and not self.lines[self.pos].startswith("OBJECT"):
            self.pos += 1

    def numbers(self, line: str, count: int) -> list[float]:
        """The first ``count`` finite numbers of ``line``."""
        try:
            values = [float(v) for v in line.split()[:count]]
        except ValueError:
            values = []
        if len(values) != count or not all(np.isfinite(values)):
            raise self.fail(f"expected {count} numbers, got {line[:80]!r}")
        return values

    def count(self, line: str, lines_each: int) -> int:
        """The whole number after the keyword of ``line``: at least 0 and at most what the
        lines left can hold (``lines_each`` lines per item)."""
        fields = line.split()
        if len(fields) != 2 or not re.fullmatch(r"\d{1,18}", fields[1]):
            raise self.fail(f"{fields[0]} needs one whole number >= 0, got {line[:80]!r}")
        n, room = int(fields[1]), (len(self.lines) - self.pos) // lines_each
        if n > room:
            raise self.fail(f"{fields[0]} {n} is more than the {room} the "
                            f"{len(self.lines) - self.pos} lines left can hold")
        return n


def _read_object(reader: _Lines, parent: np.ndarray, vertices: list[np.ndarray],
                 faces: list[list[int]], depth: int,
                 drop: Callable[[str], bool] | None = None,
                 dropped: list[str] | None = None, skip: bool = False,
                 strict: bool = True) -> None:
    """Read the object whose ``OBJECT`` line was just read, and its kids, into ``vertices``
    (moved by ``parent`` and its own ``loc``/``rot``) and ``faces``; an object that ``drop``
    picks by name (or under one, ``skip``) is read past and left out."""
    if depth > MAX_AC3D_DEPTH:
        raise reader.fail(f"objects nest deeper than MAX_AC3D_DEPTH ({MAX_AC3D_DEPTH} "
                          "levels); the file is damaged")
    local, own, kids, own_faces = np.eye(4), None, 0, []
    offset = sum(map(len, vertices))
    while reader.pos < len(reader.lines):
        line = reader.next("a keyword")
        word = line.split(" ", 1)[0]
        if word == "name" and drop is not None and not skip:
            name = line[5:].strip().strip('"')
            if drop(name):
                skip = True
                if dropped is not None:
                    dropped.append(name)
        elif word == "loc":
            local[:3, 3] = reader.numbers(line[4:], 3)
        elif word == "rot":
            local[:3, :3] = np.reshape(reader.numbers(line[4:], 9), (3, 3))
        elif word == "data":
            reader.next("the data string")
        elif word == "numvert":
            if own is not None:
                raise reader.fail("a second numvert in one object")
            n = reader.count(line, 1)
            own = np.array([reader.numbers(reader.next("a vertex"), 3) for _ in range(n)]
                           ).reshape(-1, 3)
        elif word == "numsurf":
            for _ in range(reader.count(line, 2)):
                _read_surface(reader, own_faces, offset, 0 if own is None else len(own))
        elif word == "kids":
            kids = reader.count(line, 1)
            break
    transform = parent @ local
    if own is not None and len(own) and not skip:
        vertices.append(trimesh.transform_points(own, transform))
        faces.extend(own_faces)
    for _ in range(kids):
        reader.skip_to_object()
        if reader.pos == len(reader.lines):
            if not strict:
                return
            raise reader.fail("fewer objects than its kids line says")
        reader.pos += 1
        _read_object(reader, transform, vertices, faces, depth + 1, drop, dropped, skip,
                     strict)


def _read_surface(reader: _Lines, faces: list[list[int]], offset: int,
                  n_vertices: int) -> None:
    """Read one ``SURF`` block; fan its polygon into ``faces`` (vertex indices shifted by
    ``offset``)."""
    line = reader.next("SURF")
    if not line.startswith("SURF"):
        raise reader.fail(f"expected SURF, got {line[:80]!r}")
    try:
        kind = int(line.split()[1], 16) & 0xF
    except (IndexError, ValueError):
        raise reader.fail(f"bad SURF flags {line[:80]!r}") from None
    line = reader.next("refs")
    while not line.startswith("refs"):
        line = reader.next("refs")  # mat
    n = reader.count(line, 1)
    refs = []
    for _ in range(n):
        fields = reader.next("a vertex reference").split()
        if not fields or not re.fullmatch(r"\d{1,18}", fields[0]):
            raise reader.fail(f"a vertex reference must be a whole number, got {fields[:1]}")
        refs.append(int(fields[0]))
        if refs[-1] >= n_vertices:
            raise reader.fail(f"a surface refers to vertex {refs[-1]}, outside "
                              f"0..{n_vertices - 1}")
    if kind == 0:
        faces.extend([offset + refs[0], offset + refs[k], offset + refs[k + 1]]
                     for k in range(1, n - 1))
    elif kind == 4:  # a triangle strip (TORCS's .acc files)
        faces.extend([offset + refs[k + (k % 2)], offset + refs[k + 1 - (k % 2)],
                      offset + refs[k + 2]] for k in range(n - 2))
