"""A small reader of AC3D (``.ac``) models, the format of Debian's crrcsim-data aircraft.

Scored by :mod:`e2vlib.experiments.real_study` (experiments/results/real_meshes.json).
"""

from __future__ import annotations

import numpy as np
import trimesh

from e2vlib.experiments.real_meshes.catalogue import RealMeshError


def ac3d_to_mesh(text: str, where: str = "AC3D") -> trimesh.Trimesh:
    """The polygons of AC3D text (``AC3Db`` files) as one ``trimesh.Trimesh``, as stored.

    Objects nest (``kids``); each object's vertices are moved by its ``loc`` and those of
    its parents (and turned by a ``rot`` matrix where one is given, applied to column
    vectors). Polygon surfaces (``SURF`` type 0) are fanned into triangles; line surfaces
    (types 1 and 2) have no area and are left out. Materials and textures are not read.
    Raises :class:`RealMeshError` naming ``where`` and the line for text that does not
    parse or holds no polygon.

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
    >>> ac3d_to_mesh("OBJECT world", "plane.ac")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: plane.ac: not an AC3D file ...
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
