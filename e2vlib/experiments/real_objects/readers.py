"""Readers of the real objects' formats, each giving one mesh in the project's frame.

AC3D (``.ac``, TORCS's ``.acc``) goes through the project's own reader
(:func:`e2vlib.experiments.real_meshes.ac3d.ac3d_to_mesh`) with :data:`DROP_PARTS` left
out; OBJ through :func:`e2vlib.experiments.real_meshes.meshes.obj_to_mesh`; Quake 2's
``.md2`` (UFO:AI) through :func:`md2_to_mesh`, a small numpy reader of its first frame;
``.3ds`` and ``.md3`` through ``assimp export in out.obj`` (Debian's ``assimp-utils``, a
build-time tool: :func:`assimp_to_mesh`). :func:`load_model` then turns the mesh by the
format's up axis (:data:`FORMAT_TURNS`) and the reviewed ``rotation``
(:func:`rotation_matrix`) and normalizes it: z up, front -y, bounding box centred, longest
side 1.
"""

from __future__ import annotations

import os
import re
import shutil
import struct
import subprocess
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import trimesh

from e2vlib.experiments.real_meshes.ac3d import ac3d_to_mesh
from e2vlib.experiments.real_meshes.catalogue import (
    MAX_MODEL_BYTES,
    RealMeshError,
    check_model_extent,
)
from e2vlib.experiments.real_meshes.meshes import obj_to_mesh
from e2vlib.experiments.real_objects.sources import MEMBER_SEP

DROP_PARTS = re.compile(
    r"(?i)(?<!silver_)(?<!no)shadow|(^|[^a-z])lod[-_ ]?([1-9]|low|far|med)|low[-_ ]?lod|lowres|"
    r"low[-_ ]?poly[-_ ]?copy|light[-_ ]?cone|cone[-_ ]?light|lightcone|beam|halo|glow|flare|"
    r"light[-_ ]?volume|^volume\d*$|procedural[-_ ]?light|ground[-_ ]?light|^shine$|"
    r"^(groundplane|plane_ground)$")
"""Names of AC3D objects left out: shadow squares, level-of-detail copies, light cones,
halos and ground planes (FlightGear and TORCS name them so)."""


def drop_part(name: str) -> bool:
    """Whether an AC3D object named ``name`` is left out: :data:`DROP_PARTS`, except that
    of FlightGear's level-of-detail groups (``LOD near/far``) the nearest one is kept.

    Examples
    --------
    >>> [drop_part(n) for n in ("LOD 0.000000/1000.0", "LOD 1000/5000", "shadow", "wing",
    ...                         "Default LOD", "body_lod1")]
    [False, True, True, False, False, True]
    """
    m = re.match(r"(?i)lod[ _]?(\d+(\.\d*)?)/", name)
    if m:
        return float(m.group(1)) > 0
    return bool(DROP_PARTS.search(name))


FORMAT_TURNS = {".ac": "x90", ".acc": "x90", ".obj": "x90", ".3ds": "", ".md2": "",
                ".md3": ""}
"""The turn from each format's axes to ours (z up) before the reviewed ``rotation``:
AC3D and OBJ are y up (``x90``: +90 degrees about x); ``.3ds``, ``.md2`` and ``.md3`` are
z up already."""
MD2_MAGIC = b"IDP2"
MD2_HEADER = struct.Struct("<4s16i")
ASSIMP = "assimp"
ASSIMP_HINT = "apt-get install assimp-utils"
ASSIMP_SUFFIXES = (".3ds", ".md3")
"""The model formats read through assimp."""


def rotation_matrix(spec: str) -> np.ndarray:
    """The 4x4 rotation of ``spec``: turns such as ``"x90 z-90"`` (axis, degrees, multiples
    of 90), applied left to right; ``""`` or ``"none"`` is the identity.

    Examples
    --------
    >>> rotation_matrix("z90")[:3, :3].round().astype(int).tolist()  # -x to -y
    [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    >>> rotation_matrix("y45")
    Traceback (most recent call last):
    ...
    ValueError: rotation 'y45': each turn is x, y or z and a multiple of 90 degrees, got 'y45'
    """
    out = np.eye(4)
    for turn in spec.replace("none", "").split():
        m = re.fullmatch(r"([xyz])(-?\d{1,3})", turn)
        if not m or int(m.group(2)) % 90:
            raise ValueError(f"rotation {spec!r}: each turn is x, y or z and a multiple of "
                             f"90 degrees, got {turn!r}")
        axis = {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[m.group(1)]
        r = trimesh.transformations.rotation_matrix(np.radians(int(m.group(2))), axis)
        out = np.round(r, 12) @ out
    return out


def md2_to_mesh(data: bytes, where: str = "MD2") -> trimesh.Trimesh:
    """The first frame of a Quake 2 ``.md2`` model as a mesh, as stored (z up).

    Raises :class:`RealMeshError` naming ``where`` for a bad magic or version, offsets or
    counts outside the file, or triangle indices outside the vertices.

    Examples
    --------
    A one-triangle model built by hand (frame scale 1, translate 0):

    >>> tri = struct.pack("<6h", 0, 1, 2, 0, 0, 0)
    >>> frame = struct.pack("<6f16s", 1, 1, 1, 0, 0, 0, b"f0") + bytes([0, 0, 0, 0, 9, 0, 0, 0,
    ...                                                                 0, 9, 0, 0])
    >>> head = MD2_HEADER.pack(MD2_MAGIC, 8, 0, 0, len(frame), 0, 3, 0, 1, 0, 1,
    ...                        68, 68, 68, 80, 80 + len(frame), 80 + len(frame))
    >>> md2_to_mesh(head + tri + frame).bounds.tolist()
    [[0.0, 0.0, 0.0], [9.0, 9.0, 0.0]]
    >>> md2_to_mesh(b"IDP3" + bytes(64), "gun.md2")
    Traceback (most recent call last):
    ...
    e2vlib.experiments.real_meshes.catalogue.RealMeshError: gun.md2: not an MD2 model \
(magic b'IDP3', version 0)
    """
    if len(data) < MD2_HEADER.size:
        raise RealMeshError(f"{where}: {len(data)} bytes, shorter than an MD2 header")
    (magic, version, _sw, _sh, framesize, _nskins, nxyz, _nst, ntris, _ngl, nframes,
     _oskins, _ost, otris, oframes, _ogl, _oend) = MD2_HEADER.unpack_from(data)
    if magic != MD2_MAGIC or version != 8:
        raise RealMeshError(f"{where}: not an MD2 model (magic {magic!r}, version {version})")
    if nxyz <= 0 or ntris <= 0 or nframes <= 0:
        raise RealMeshError(f"{where}: the model has {nxyz} vertices, {ntris} triangles and "
                            f"{nframes} frames")
    if (otris < 0 or otris + 12 * ntris > len(data) or oframes < 0
            or oframes + 40 + 4 * nxyz > len(data) or framesize < 40 + 4 * nxyz):
        raise RealMeshError(f"{where}: its triangles or first frame lie outside the "
                            f"{len(data)} bytes of the file")
    tris = np.frombuffer(data, "<i2", 6 * ntris, otris).reshape(-1, 6)[:, :3].astype(np.int64)
    if tris.min() < 0 or tris.max() >= nxyz:
        raise RealMeshError(f"{where}: a triangle refers to a vertex outside 0..{nxyz - 1}")
    scale = np.frombuffer(data, "<f4", 3, oframes).astype(np.float64)
    move = np.frombuffer(data, "<f4", 3, oframes + 12).astype(np.float64)
    packed = np.frombuffer(data, np.uint8, 4 * nxyz, oframes + 40).reshape(-1, 4)[:, :3]
    vertices = packed * scale + move
    check_model_extent(vertices, where)
    return trimesh.Trimesh(vertices, tris[:, ::-1], process=True)


def assimp_to_mesh(path: str | os.PathLike, where: str | None = None) -> trimesh.Trimesh:
    """The model file ``path`` (``.3ds``, ``.md3``, anything assimp reads) as a mesh, as
    stored, by ``assimp export path out.obj``; :class:`RealMeshError` when assimp is not
    installed (:data:`ASSIMP_HINT`) or fails."""
    where = where or str(path)
    if shutil.which(ASSIMP) is None:
        raise RealMeshError(f"{where}: assimp is not installed; {ASSIMP_HINT}")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.obj"
        done = subprocess.run([ASSIMP, "export", str(path), str(out)], capture_output=True,
                              text=True, timeout=300)
        if done.returncode or not out.is_file():
            raise RealMeshError(f"{where}: assimp could not convert it "
                                f"({(done.stdout + done.stderr).strip()[-200:]})")
        return obj_to_mesh(out.read_bytes(), where)


def read_bytes(root: str | os.PathLike, path: str) -> bytes:
    """The bytes of ``path`` inside the unpacked package ``root`` (``archive::member`` for a
    member of a zip), at most :data:`MAX_MODEL_BYTES`; :class:`RealMeshError` naming it when
    it is absent, too large or unreadable, or when it would read outside ``root`` (an
    absolute path, ``..``, a link leading out: :func:`~e2vlib.experiments.real_objects.
    catalogue.path_problem`)."""
    from e2vlib.experiments.real_objects.catalogue import path_problem

    problem = path_problem(path)
    if problem is not None:
        raise RealMeshError(f"{problem} (package folder {root})")
    archive, _, member = path.partition(MEMBER_SEP)
    file = Path(root) / archive
    if not file.resolve().is_relative_to(Path(root).resolve()):
        raise RealMeshError(f"{file} leads outside its package folder {root} (a link?); "
                            "extract the package again")
    if not file.is_file():
        raise RealMeshError(f"{file}: not found; download and extract the package "
                            "(python -m e2vlib.experiments.real_objects download)")
    if not member:
        if file.stat().st_size > MAX_MODEL_BYTES:
            raise RealMeshError(f"{file}: larger than MAX_MODEL_BYTES ({MAX_MODEL_BYTES})")
        return file.read_bytes()
    try:
        with zipfile.ZipFile(file) as zf:
            info = zf.getinfo(member)
            if info.file_size > MAX_MODEL_BYTES:
                raise RealMeshError(f"{path}: larger than MAX_MODEL_BYTES")
            return zf.read(member)
    except RealMeshError:
        raise
    except Exception as err:
        raise RealMeshError(f"{path}: cannot be read ({type(err).__name__}: {err})") from err


def read_model(root: str | os.PathLike, path: str,
               removed: list[str] | None = None) -> trimesh.Trimesh:
    """The model at ``path`` inside the unpacked package ``root``, as stored (its own axes);
    AC3D parts named by :data:`DROP_PARTS` are left out and their names appended to
    ``removed``."""
    suffix = Path(path).suffix.lower()
    data = read_bytes(root, path)
    where = path
    if suffix in (".ac", ".acc"):
        return ac3d_to_mesh(data.decode("latin-1"), where, drop=drop_part, dropped=removed,
                            strict=False)
    if suffix == ".obj":
        return obj_to_mesh(data, where)
    if suffix == ".md2":
        return md2_to_mesh(data, where)
    if suffix in ASSIMP_SUFFIXES:
        with tempfile.TemporaryDirectory() as tmp:
            file = Path(tmp) / ("model" + suffix)
            file.write_bytes(data)
            return assimp_to_mesh(file, where)
    raise RealMeshError(f"{where}: no reader for {suffix!r} files")


def to_frame(mesh: trimesh.Trimesh, suffix: str, rotation: str,
             where: str = "model") -> trimesh.Trimesh:
    """``mesh`` (as stored in a ``suffix`` file) turned by :data:`FORMAT_TURNS` then
    ``rotation`` (:func:`rotation_matrix`), bounding box centred, longest side 1.

    Examples
    --------
    >>> box = trimesh.creation.box(extents=(2.0, 1.0, 4.0))  # y-up file: 4 along z
    >>> to_frame(box, ".ac", "").extents.round(3).tolist()  # z -> -y
    [0.5, 1.0, 0.25]
    """
    from e2vlib.shapes import normalize_mesh

    out = mesh.copy()
    out.apply_transform(rotation_matrix(rotation) @ rotation_matrix(FORMAT_TURNS[suffix]))
    try:
        return normalize_mesh(out)
    except ValueError as err:
        raise RealMeshError(f"{where}: {err}") from None


PART_KINDS = ("ground", "cones")
"""Parts :func:`remove_parts` can find by shape: ``ground`` (flat squares or light pools at
the bottom, wider than the object) and ``cones`` (light cones and glow volumes whose
footprint dwarfs the lamp's)."""
GROUND_SQUARE, LIGHT_CONE = "ground square (by shape)", "light cone (by shape)"
"""How :func:`remove_parts` names what it removes (the catalogue's ``removed`` column keeps
these names, so the review can be read back from it)."""
FLAT = 0.02
"""Largest height of a ground part, as a share of the model's longest side."""
LOW = 0.1
"""Highest top of a ground part above the model's bottom, as a share of its height (poles
often reach a little below the ground square)."""
DWARFS = 4.0
"""How many times the footprint of the rest a light cone's footprint must be."""


def _footprint(parts: list[trimesh.Trimesh]) -> float:
    if not parts:
        return 0.0
    lo = np.min([p.bounds[0] for p in parts], axis=0)
    hi = np.max([p.bounds[1] for p in parts], axis=0)
    return float((hi[0] - lo[0]) * (hi[1] - lo[1]))


def remove_parts(mesh: trimesh.Trimesh, kinds: str) -> tuple[trimesh.Trimesh, list[str]]:
    """``mesh`` (z up) without the parts of ``kinds`` (space-separated :data:`PART_KINDS`),
    found among its connected pieces by shape, and the names of what was removed.

    ``ground``: a piece less than :data:`FLAT` of the model's size high, lying within
    :data:`LOW` of the model's height from its bottom, whose footprint is at least half that
    of all the other pieces together. ``cones``: the piece
    with the widest footprint while that footprint is at least :data:`DWARFS` times the rest's.

    Examples
    --------
    A pole standing on a wide flat square: the square goes.

    >>> pole = trimesh.creation.box(extents=(0.1, 0.1, 1.0))
    >>> square = trimesh.creation.box(extents=(2.0, 2.0, 0.001)).apply_translation((0, 0, -0.5))
    >>> kept, gone = remove_parts(trimesh.util.concatenate([pole, square]), "ground")
    >>> kept.extents.round(2).tolist(), gone
    ([0.1, 0.1, 1.0], ['ground square (by shape)'])
    """
    unknown = set(kinds.split()) - set(PART_KINDS)
    if unknown:
        raise ValueError(f"parts {kinds!r}: unknown kinds {sorted(unknown)}; use "
                         f"{', '.join(PART_KINDS)}")
    if not kinds.split():
        return mesh, []
    pieces = list(mesh.split(only_watertight=False))
    if len(pieces) < 2:
        return mesh, []
    size = float(mesh.extents.max())
    bottom, height = float(mesh.bounds[0, 2]), float(mesh.extents[2])
    gone = []
    if "ground" in kinds.split():
        keep = []
        for k, piece in enumerate(pieces):
            rest = pieces[:k] + pieces[k + 1:]
            flat = piece.extents[2] < FLAT * size
            low = piece.bounds[1, 2] <= bottom + LOW * height
            if flat and low and _footprint([piece]) >= 0.5 * _footprint(rest):
                gone.append(GROUND_SQUARE)
            else:
                keep.append(piece)
        pieces = keep
    if "cones" in kinds.split():
        while len(pieces) > 1:
            widest = max(range(len(pieces)), key=lambda k: _footprint([pieces[k]]))
            rest = pieces[:widest] + pieces[widest + 1:]
            if _footprint([pieces[widest]]) < DWARFS * _footprint(rest):
                break
            gone.append(LIGHT_CONE)
            pieces = rest
    if not gone or not pieces:
        return mesh, []
    return trimesh.util.concatenate(pieces), gone


def load_model(root: str | os.PathLike, path: str, rotation: str = "",
               removed: list[str] | None = None, parts: str = "") -> trimesh.Trimesh:
    """The model at ``path`` in the unpacked package ``root`` in our frame (z up, front -y,
    centred, longest side 1): :func:`read_model`, :func:`to_frame`, and
    :func:`remove_parts` of ``parts`` (what it removes is appended to ``removed``)."""
    mesh = read_model(root, path, removed)
    mesh = to_frame(mesh, Path(path).suffix.lower(), rotation, path)
    if parts.split():
        mesh, gone = remove_parts(mesh, parts)
        if removed is not None:
            removed.extend(gone)
        if gone:
            mesh = to_frame(mesh, ".md2", "", path)  # re-centre and rescale, no turn
    return mesh
