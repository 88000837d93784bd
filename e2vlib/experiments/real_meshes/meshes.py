"""One catalogue entry's model as a ``trimesh.Trimesh`` in the project's frame.

:func:`load_entry_mesh` reads an entry's OBJ from its ``.sh3f`` zip (:func:`obj_to_mesh`)
or a crrcsim-data aircraft's AC3D file (:func:`~e2vlib.experiments.real_meshes.ac3d.ac3d_to_mesh`),
turns it as Sweet Home 3D shows it (:func:`entry_transform`, :data:`SH3D_TO_ZUP`: z up,
front -y), applies the reviewed pose (:data:`POSES`) and normalizes it (bounding box
centred, longest side 1).

Scored by :mod:`e2vlib.experiments.real_study` (experiments/results/real_meshes.json).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import trimesh

from e2vlib.experiments.real_meshes.ac3d import ac3d_to_mesh
from e2vlib.experiments.real_meshes.catalogue import (
    CRRCSIM,
    CRRCSIM_INSTALL_HINT,
    FURNITURE_DIR,
    INSTALL_HINT,
    MAX_MODEL_BYTES,
    CatalogueEntry,
    RealMeshError,
    check_model_extent,
    open_library,
    read_member,
)

SH3D_TO_ZUP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
"""Sweet Home 3D models are y up with the front towards +z; this rotation (+90 degrees
about x: ``(x, y, z) -> (x, -z, y)``) turns them into our frame (z up, front -y)."""

POSES = {
    "as_placed": np.eye(4),
    "stood_up": np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]]),
}
"""Extra turn after :data:`SH3D_TO_ZUP`: ``as_placed`` keeps the pose Sweet Home 3D puts the
object in a room; ``stood_up`` (+90 degrees about x) stands a phone that lies flat on its back
upright with its screen to the front (-y), as ShapeNet's and our procedural telephones
stand."""


def obj_to_mesh(data: bytes, where: str = "OBJ") -> trimesh.Trimesh:
    """Every face of OBJ text ``data`` as one ``trimesh.Trimesh``, as stored (no materials:
    the renderer shades by geometry; parts and groups are merged, duplicate vertices welded).

    Raises :class:`RealMeshError` naming ``where`` for text with no triangles, or
    vertices that :func:`check_model_extent` refuses (NaN/inf, too far, too small).

    Examples
    --------
    Two triangles of two parts sharing an edge: their four vertices are welded into one mesh:

    >>> mesh = obj_to_mesh(b"o a\\nv 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 3\\n"
    ...                    b"o b\\nv 1 0 0\\nv 1 1 0\\nv 0 1 0\\nf 4 5 6\\n")
    >>> len(mesh.vertices), len(mesh.faces)
    (4, 2)
    >>> obj_to_mesh(b"v 0 0 0\\n", "empty.obj")
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: empty.obj: the OBJ holds no triangles
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
    check_model_extent(loaded.vertices, where)
    # merge the parts' duplicate vertices, so closed parts are watertight for voxelize
    return trimesh.Trimesh(loaded.vertices, loaded.faces, process=True)


def entry_transform(entry: CatalogueEntry, bounds: np.ndarray) -> np.ndarray:
    """4x4 transform taking the stored OBJ of ``entry`` (bounding box ``bounds``, (2, 3))
    to our frame as Sweet Home 3D shows it: ``modelRotation`` first, then each axis scaled
    to the catalogue's width (x), height (y), depth (z), then :data:`SH3D_TO_ZUP`.

    Examples
    --------
    A unit cube shown 200 cm wide (x), 100 cm deep (z) and 50 cm high (y), then turned z up:

    >>> from e2vlib.experiments.real_meshes.catalogue import CatalogueEntry
    >>> entry = CatalogueEntry("BlendSwap-CC-0.sh3f", 1, "Test#box", "Box", "", "", "box.obj",
    ...                        (200.0, 100.0, 50.0), None, "CC0-1.0")
    >>> entry_transform(entry, np.array([[0.0, 0, 0], [1, 1, 1]])).astype(int).tolist()
    [[200, 0, 0, 0], [0, 0, -100, 0], [0, 50, 0, 0], [0, 0, 0, 1]]
    """
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

    Examples
    --------
    A cube in a small library, shown 200 x 100 x 50 cm, comes out 1 x 0.5 x 0.25 (m, z up):

    >>> import tempfile, zipfile
    >>> from pathlib import Path
    >>> from e2vlib.experiments.real_meshes.catalogue import read_catalogue
    >>> folder = Path(tempfile.mkdtemp())
    >>> with zipfile.ZipFile(folder / "BlendSwap-CC-0.sh3f", "w") as zf:
    ...     zf.writestr("PluginFurnitureCatalog.properties", "id#1=Test#box\\nname#1=Box\\n"
    ...                 "model#1=/box/box.obj\\nwidth#1=200\\ndepth#1=100\\nheight#1=50\\n")
    ...     zf.writestr("box/box.obj", trimesh.exchange.obj.export_obj(trimesh.creation.box()))
    >>> entry = read_catalogue(folder / "BlendSwap-CC-0.sh3f")[0]
    >>> mesh = load_entry_mesh(entry, folder)
    >>> mesh.extents.round(3).tolist(), mesh.bounds.mean(axis=0).round(3).tolist()
    ([1.0, 0.5, 0.25], [0.0, 0.0, 0.0])
    """
    from e2vlib.shapes import normalize_mesh

    if pose not in POSES:
        raise ValueError(f"pose must be one of {', '.join(POSES)}, got {pose!r}")
    if entry.library == CRRCSIM:  # an AC3D file on disk (entry.model: its path)
        where = str(entry.model)
        mesh = ac3d_to_mesh(_read_ac3d(Path(entry.model)), where)
        mesh.apply_transform(POSES[pose] @ SH3D_TO_ZUP)  # AC3D is y up too, nose to +z
    else:
        path = Path(folder) / entry.library
        if not path.is_file():
            raise FileNotFoundError(f"{path} not found: sweethome3d-furniture is not "
                                    f"installed; {INSTALL_HINT}")
        where = f"{entry.library} entry #{entry.number} ({entry.name})"
        with open_library(path) as zf:
            mesh = obj_to_mesh(read_member(zf, entry.model, MAX_MODEL_BYTES, where), where)
        mesh.apply_transform(POSES[pose] @ entry_transform(entry, mesh.bounds))
        check_model_extent(mesh.vertices, where, f"scaled to its catalogue size "
                           f"{entry.size_cm} cm")
    if not normalize:
        return mesh
    try:
        return normalize_mesh(mesh)
    except ValueError as err:
        raise RealMeshError(f"{where}: {err}") from None


def _read_ac3d(path: Path) -> str:
    """The text of the AC3D file ``path``, refused before reading when it is not a regular
    file or is larger than :data:`MAX_MODEL_BYTES`."""
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: crrcsim-data is not installed; "
                                f"{CRRCSIM_INSTALL_HINT}")
    if not path.is_file():
        raise RealMeshError(f"{path} is not a regular file (a folder, pipe or device); give "
                            "an .ac file of crrcsim-data")
    size = path.stat().st_size
    if size > MAX_MODEL_BYTES:
        raise RealMeshError(f"{path} is {size} bytes, more than MAX_MODEL_BYTES "
                            f"({MAX_MODEL_BYTES}); it is not one of crrcsim-data's aircraft")
    return path.read_bytes().decode("latin-1")

