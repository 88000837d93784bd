"""Meshes in and out of the project's frame: :func:`normalize_mesh` (centre the bounding box,
longest side 1) and :func:`load_mesh` (read one mesh file of a type in :data:`MESH_SUFFIXES`).
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np
import trimesh

from e2vlib.files import input_file

MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")
"""File types :func:`load_mesh` reads."""

MAX_MESH_COORDINATE = 1e12
"""Largest vertex coordinate (in the file's units, 1e12 m is about 7 times the distance to
the Sun) :func:`load_mesh` and :func:`normalize_mesh` accept. Beyond it float64 keeps
less than 1e-4 of a 1 m object's size, and larger values overflow trimesh's vertex merge
and the bounding box: such a file is broken, not big."""

_MERGE_DIGITS = 8  # trimesh merges vertices that agree to 8 decimals (trimesh.tol.merge)
_OBJ_BLOCK = 1 << 23  # bytes of an OBJ file checked at a time


def mesh_name(mesh: trimesh.Trimesh) -> str:
    """The file a mesh came from (``load_mesh`` records it), else ``"the mesh"``; for
    messages.

    Examples
    --------
    >>> mesh_name(trimesh.creation.box())
    'the mesh'
    """
    path = getattr(mesh, "metadata", {}).get("file_path")
    return f"mesh {path}" if path else "the mesh"


def normalize_mesh(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Return a copy moved and scaled so its bounding box is centred at the origin with
    longest side 1 (the paper's objects "fit within 1 m^3"). Orientation is unchanged.

    Raises ValueError naming the mesh's file (when :func:`load_mesh` read it) for an empty
    mesh, NaN/inf vertices, coordinates beyond :data:`MAX_MESH_COORDINATE` or a mesh of
    zero extent.

    Introduced in notebooks/04_building_the_dataset.ipynb.

    Examples
    --------
    >>> box = trimesh.creation.box(extents=(2.0, 4.0, 1.0)).apply_translation((10.0, 0.0, 0.0))
    >>> out = normalize_mesh(box)
    >>> out.extents.tolist()  # longest side (y) scaled from 4 m to 1
    [0.5, 1.0, 0.25]
    >>> out.bounds.tolist()  # bounding box centred at the origin
    [[-0.25, -0.5, -0.125], [0.25, 0.5, 0.125]]
    >>> box.bounds[0].tolist()  # the input is not changed
    [9.0, -2.0, -0.5]
    """
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError(f"normalize_mesh needs a trimesh.Trimesh, got {type(mesh).__name__}")
    name = mesh_name(mesh)
    if len(mesh.vertices) == 0 or len(mesh.faces) == 0:
        raise ValueError(f"{name}: cannot normalize an empty mesh (no vertices or faces)")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} has NaN/inf vertex coordinates; clean the mesh first")
    used = v[np.unique(np.asarray(mesh.faces))]
    lo, hi = used.min(axis=0), used.max(axis=0)
    _check_coordinates(name, lo, hi)
    extent = float((hi - lo).max())
    if not (extent > 0 and math.isfinite(1.0 / extent)):
        raise ValueError(f"{name} has zero extent (all {len(used)} vertices its faces use "
                         f"coincide, at {((lo + hi) / 2).tolist()}): there is no shape to "
                         "scale; check the file")
    out = mesh.copy()
    out.apply_translation(-(lo + hi) / 2)
    out.apply_scale(1.0 / extent)
    return out


def _check_coordinates(name: str, lo: np.ndarray, hi: np.ndarray) -> None:
    """Refuse a bounding box ``lo``..``hi`` beyond :data:`MAX_MESH_COORDINATE`."""
    largest = float(max(np.abs(lo).max(), np.abs(hi).max()))
    if largest > MAX_MESH_COORDINATE:
        raise ValueError(f"{name} has vertex coordinates up to {largest:.3g}, beyond "
                         f"shapes.MAX_MESH_COORDINATE = {MAX_MESH_COORDINATE:.0e} (the "
                         "object cannot be represented to scale); the file is broken: "
                         "re-export it")


def _merge_digits(vertices: np.ndarray) -> int:
    """Decimals to merge vertices at: trimesh's 8, more for a tiny mesh (so its vertices do
    not all merge), fewer where 8 would overflow int64 (coordinates above about 9e10)."""
    if len(vertices) == 0:
        return _MERGE_DIGITS
    extent = float((vertices.max(axis=0) - vertices.min(axis=0)).max())
    largest = float(np.abs(vertices).max())
    digits = _MERGE_DIGITS
    if 0 < extent < 1e-3:  # keep merging at 1e-5 of the size, as trimesh does for 1 mm
        digits += math.ceil(math.log10(1e-3 / extent))
    if largest > 0:
        digits = min(digits, math.floor(math.log10(2.0**62 / largest)))
    return digits


def _check_obj_faces(path: Path) -> None:
    """Refuse an OBJ face index outside ``1..n`` or ``-n..-1`` (n vertices in the file):
    trimesh wraps 0 and ``-n - 1`` round to another vertex in silence."""
    n_vertices, low, high, line = 0, 0, 0, None
    face = re.compile(rb"(?m)^[ \t]*f[ \t]+([^\n#]*)")
    vertex = re.compile(rb"(?m)^[ \t]*v[ \t]")
    with open(path, "rb") as f:
        tail = b""
        while True:
            block = f.read(_OBJ_BLOCK)
            text = tail + block
            cut = text.rfind(b"\n") + 1 if block else len(text)
            text, tail = text[:cut], text[cut:]
            n_vertices += len(vertex.findall(text))
            faces = b" ".join(face.findall(text))
            indices = re.sub(rb"/\S*", b"", faces).split()
            if indices:
                try:
                    values = np.array(indices).astype(np.int64)
                except (ValueError, OverflowError):
                    return  # not whole numbers: trimesh's parser reports the file
                if (values == 0).any():
                    line = next(m.group(0) for m in face.finditer(text)
                                if 0 in np.array(re.sub(rb"/\S*", b"", m.group(1)).split()
                                                 ).astype(np.int64))
                    raise ValueError(f"{path}: face {line.decode(errors='replace').strip()!r} "
                                     "uses vertex index 0, but OBJ indices start at 1 (or "
                                     "count back from -1); fix the face or re-export the file")
                low, high = min(low, int(values.min())), max(high, int(values.max()))
            if not block:
                break
    if high > n_vertices or -low > n_vertices:
        bad = high if high > n_vertices else low
        raise ValueError(f"{path}: a face uses vertex index {bad}, but the file has "
                         f"{n_vertices} vertices (OBJ indices run 1..{n_vertices} or "
                         f"-{n_vertices}..-1); fix the faces or re-export the file")


def load_mesh(path: str | os.PathLike) -> trimesh.Trimesh:
    """Load an OBJ/PLY/STL/OFF/GLB/GLTF file as one ``trimesh.Trimesh``.

    Files holding a scene (several objects, e.g. an OBJ with groups or a GLB) are merged into
    one mesh with their scene transforms applied. The mesh is returned **as stored**: not
    normalized, not rotated (ShapeNet is y up: see :func:`shapenet_to_zup`); call
    :func:`normalize_mesh` before voxelizing or rendering. Coincident vertices are merged as
    trimesh does (to 8 decimals), finer for a mesh smaller than a millimetre and coarser
    where 8 decimals overflow; the file's path is kept in ``mesh.metadata["file_path"]``.

    Raises FileNotFoundError for a missing file, IsADirectoryError for a folder, and
    ValueError naming the file for a FIFO or device, an unsupported suffix, a file with no
    triangles / that cannot be parsed, NaN/inf coordinates or coordinates beyond
    :data:`MAX_MESH_COORDINATE`, and OBJ face indices outside the file's vertices.

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    p = input_file(path, "mesh file")
    suffix = p.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise ValueError(
            f"{p}: unsupported mesh type {suffix!r}; use one of {', '.join(MESH_SUFFIXES)}"
        )
    if suffix == ".obj":
        _check_obj_faces(p)
    try:
        # unprocessed: processing silently drops NaN/inf vertices and their faces, and its
        # vertex merge overflows above 9e10
        loaded = trimesh.load(str(p), force="mesh", process=False, skip_materials=True)
        if isinstance(loaded, trimesh.Scene):  # defensive: force="mesh" normally merges
            loaded = loaded.to_geometry()
        vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=np.float64)
        bad = int((~np.isfinite(vertices)).any(axis=1).sum()) if vertices.ndim == 2 else 0
        if bad:
            raise ValueError(
                f"{p}: {bad} of {len(vertices)} vertices have "
                "NaN or infinite coordinates; fix or re-export the mesh"
            )
        if isinstance(loaded, trimesh.Trimesh) and len(vertices):
            _check_coordinates(str(p), vertices.min(axis=0), vertices.max(axis=0))
            loaded.merge_vertices(digits_vertex=_merge_digits(vertices))
    except ValueError as err:
        if str(err).startswith(str(p)):
            raise
        raise ValueError(f"{p}: could not read mesh (ValueError: {err})") from err
    except Exception as err:  # parsers raise many types
        raise ValueError(f"{p}: could not read mesh ({type(err).__name__}: {err})") from err
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{p}: file holds no triangles (corrupt, empty, or a point cloud)")
    loaded.metadata["file_path"] = str(p)
    return loaded
