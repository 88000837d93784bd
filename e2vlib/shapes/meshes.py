"""Meshes in and out of the project's frame: :func:`normalize_mesh` (centre the bounding box,
longest side 1) and :func:`load_mesh` (read one mesh file of a type in :data:`MESH_SUFFIXES`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import trimesh

MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")
"""File types :func:`load_mesh` reads."""


def normalize_mesh(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Return a copy moved and scaled so its bounding box is centred at the origin with
    longest side 1 (the paper's objects "fit within 1 m^3"). Orientation is unchanged.

    Raises ValueError for an empty mesh, NaN/inf vertices or a mesh of zero extent.

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
    if len(mesh.vertices) == 0 or len(mesh.faces) == 0:
        raise ValueError("cannot normalize an empty mesh (no vertices or faces)")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise ValueError("mesh has NaN/inf vertex coordinates; clean the mesh first")
    used = v[np.unique(np.asarray(mesh.faces))]
    lo, hi = used.min(axis=0), used.max(axis=0)
    extent = float((hi - lo).max())
    if not extent > 0:
        raise ValueError("mesh has zero extent (all vertices coincide); cannot scale it")
    out = mesh.copy()
    out.apply_translation(-(lo + hi) / 2)
    out.apply_scale(1.0 / extent)
    return out


def load_mesh(path: str | os.PathLike) -> trimesh.Trimesh:
    """Load an OBJ/PLY/STL/OFF/GLB/GLTF file as one ``trimesh.Trimesh``.

    Files holding a scene (several objects, e.g. an OBJ with groups or a GLB) are merged into
    one mesh with their scene transforms applied. The mesh is returned **as stored**: not
    normalized, not rotated (ShapeNet is y up: see :func:`shapenet_to_zup`); call
    :func:`normalize_mesh` before voxelizing or rendering.

    Raises FileNotFoundError for a missing file and ValueError naming the file for an
    unsupported suffix or a file with no triangles / that cannot be parsed.

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"mesh file not found: {p}")
    suffix = p.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise ValueError(
            f"{p}: unsupported mesh type {suffix!r}; use one of {', '.join(MESH_SUFFIXES)}"
        )
    try:
        # unprocessed first: processing silently drops NaN/inf vertices and their faces
        raw = trimesh.load(str(p), force="mesh", process=False, skip_materials=True)
        parts = raw.geometry.values() if isinstance(raw, trimesh.Scene) else [raw]
        vertices = [np.asarray(getattr(g, "vertices", np.zeros((0, 3)))) for g in parts]
        bad = sum(int((~np.isfinite(v)).any(axis=1).sum()) for v in vertices if v.ndim == 2)
        if bad:
            raise ValueError(
                f"{p}: {bad} of {sum(len(v) for v in vertices)} vertices have "
                "NaN or infinite coordinates; fix or re-export the mesh"
            )
        loaded = trimesh.load(str(p), force="mesh", process=True, skip_materials=True)
    except ValueError as err:
        if str(err).startswith(str(p)):
            raise
        raise ValueError(f"{p}: could not read mesh (ValueError: {err})") from err
    except Exception as err:  # parsers raise many types
        raise ValueError(f"{p}: could not read mesh ({type(err).__name__}: {err})") from err
    if isinstance(loaded, trimesh.Scene):  # defensive: force="mesh" normally merges
        loaded = loaded.to_geometry()
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{p}: file holds no triangles (corrupt, empty, or a point cloud)")
    if not np.all(np.isfinite(loaded.vertices)):
        raise ValueError(f"{p}: mesh has NaN/inf vertex coordinates")
    return loaded
