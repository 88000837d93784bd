"""Occupancy grids: meshes to solid voxels, and the binvox file format.

A voxel grid here is a ``bool`` array ``(R, R, R)`` indexed ``[i, j, k] = (x, y, z)`` that
covers the cube ``[-0.5, 0.5]^3`` (metres, the normalized object frame). Voxel ``i`` along
x spans ``[-0.5 + i / R, -0.5 + (i + 1) / R)``, so its centre is at ``-0.5 + (i + 0.5) / R``.
Grids are *solid* (interior filled), like the ShapeNetVox32 / Pix2Vox labels the paper
trains on.

Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import trimesh
from scipy import ndimage
from trimesh.exchange import binvox as trimesh_binvox
from trimesh.voxel import runlength

from e2vlib import paper
from e2vlib.files import atomic_path
from e2vlib.shapes.meshes import MAX_MESH_COORDINATE, mesh_name

# A tiny, irrational-looking offset of the ray positions (in voxels) so that no ray passes
# exactly through a mesh edge or vertex placed on a "nice" coordinate (e.g. the diagonal of
# a box face through voxel centres). It moves rays by about a millionth of a voxel.
_RAY_JITTER = (0.7071067811865476e-6, 0.3183098861837907e-6)

# Surface sample spacing in voxels: every surface point lies within about this distance of
# a sample point.
_SURFACE_SPACING = 0.35


class VoxelError(ValueError):
    """A voxel grid or binvox file is malformed (wrong shape, dtype, header or data)."""


# --------------------------------------------------------------------------- voxelize


def _check_mesh(mesh: trimesh.Trimesh) -> np.ndarray:
    """Return the mesh triangles as a float64 array (F, 3, 3), or raise ValueError."""
    if isinstance(mesh, trimesh.Scene):
        raise ValueError(
            "voxelize needs a single trimesh.Trimesh, got a Scene; merge it first with "
            "e2vlib.shapes.load_mesh(path) or scene.to_geometry()"
        )
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError(f"voxelize needs a trimesh.Trimesh, got {type(mesh).__name__}")
    name = mesh_name(mesh)
    if len(mesh.faces) == 0:
        raise ValueError(f"voxelize got {name} with no faces; nothing to voxelize")
    if len(mesh.faces) > MAX_FACES:
        raise ValueError(f"{name} has {len(mesh.faces)} faces, more than voxels.MAX_FACES = "
                         f"{MAX_FACES}; simplify it first (e.g. "
                         "mesh.simplify_quadric_decimation, or in Blender)")
    faces, n_vertices = np.asarray(mesh.faces), len(mesh.vertices)
    if faces.ndim != 2 or faces.shape[1] != 3 or faces.dtype.kind not in "iu":
        raise ValueError(f"mesh faces must be an (F, 3) integer array, got {faces.dtype} "
                         f"{faces.shape}; build the mesh with trimesh.Trimesh(vertices, faces)")
    if faces.min() < 0 or faces.max() >= n_vertices:
        raise ValueError(f"mesh faces index vertices {int(faces.min())}..{int(faces.max())} "
                         f"but the mesh has {n_vertices} (0..{n_vertices - 1}); fix the faces "
                         "or load the mesh again with e2vlib.shapes.load_mesh")
    tri = np.asarray(mesh.vertices, dtype=np.float64)[faces]
    if not np.all(np.isfinite(tri)):
        raise ValueError(f"{name} has NaN/inf vertex coordinates; clean the mesh first")
    largest = float(np.abs(tri).max())
    if largest > MAX_MESH_COORDINATE:
        raise ValueError(f"{name} has vertex coordinates up to {largest:.3g} m, beyond "
                         f"shapes.MAX_MESH_COORDINATE = {MAX_MESH_COORDINATE:.0e}: the mesh is "
                         "broken; re-export it")
    return tri


MAX_FACES: int = 5_000_000
"""Most triangles :func:`voxelize` takes: its per-triangle arrays take about 400 bytes each
(2 GB at the bound; a 1.3 M-face sphere needs 0.5 GB and 7 s). Simplify larger meshes
first."""

MAX_RAY_TESTS: int = 200_000_000
"""Most (triangle, voxel column) pairs :func:`voxelize` tests, over all its ray axes
(about 35 s on one core; made ``_CHUNK`` at a time, so memory stays near 300 MB). A
normalized mesh needs a few per column (32^2 columns at resolution 32); millions of large
triangles, or a mesh far larger than the grid cube, need more."""

_CHUNK = 1_000_000
"""Ray tests or surface points made at a time (about 250 MB of working arrays)."""


def _chunks(cost: np.ndarray, budget: int = _CHUNK) -> list[slice]:
    """Consecutive slices of the triangles whose ``cost`` adds up to about ``budget`` each
    (at most ``budget`` triangles), so that the memory of each step stays bounded."""
    start = np.cumsum(cost) - cost
    group = np.maximum(start // budget, np.arange(len(cost)) // budget)
    edges = [0, *(np.flatnonzero(np.diff(group)) + 1).tolist(), len(cost)]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def _check_work(tri: np.ndarray, resolution: int, axes: tuple[int, ...], name: str) -> None:
    """Refuse a mesh that would take more than :data:`MAX_RAY_TESTS` ray tests or
    :data:`MAX_SURFACE_POINTS` surface samples, before any is made."""
    tests = sum(int(_columns(tri[:, :, _permutation(axis)], resolution)[2].sum())
                for axis in axes)
    points = float(_surface_point_counts(tri, resolution).sum())
    size = float(np.max(tri.max(axis=(0, 1)) - tri.min(axis=(0, 1))))
    fix = (f"normalize it first with e2vlib.shapes.normalize_mesh (it is {size:.3g} m across "
           "against the 1 m grid cube)" if size > 2 else
           "simplify it (e.g. mesh.simplify_quadric_decimation) or lower the resolution")
    if tests > MAX_RAY_TESTS:
        raise ValueError(f"voxelizing {name} ({len(tri)} triangles) at resolution {resolution} "
                         f"would make {tests:.3g} ray tests, more than voxels.MAX_RAY_TESTS = "
                         f"{MAX_RAY_TESTS:.0e}; {fix}")
    if points > MAX_SURFACE_POINTS:
        raise ValueError(f"voxelizing {name} ({len(tri)} triangles) at resolution {resolution} "
                         f"would sample {points:.3g} surface points, more than "
                         f"voxels.MAX_SURFACE_POINTS = {MAX_SURFACE_POINTS:.0e}; {fix}")


def _check_resolution(resolution: int) -> int:
    if isinstance(resolution, bool) or not isinstance(resolution, int | np.integer):
        raise ValueError(f"resolution must be a positive int, got {resolution!r}")
    if not 1 <= int(resolution) <= 1024:
        raise ValueError(f"resolution must be in [1, 1024], got {resolution}")
    return int(resolution)


def _permutation(axis: int) -> list[int]:
    """Cyclic (right-handed) order of the coordinates that puts ``axis`` last ("w")."""
    return [(axis + 1) % 3, (axis + 2) % 3, axis]


def _columns(t: np.ndarray, r: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Voxel columns each triangle's (u, v) projection may cover: the first column index
    ``lo`` (F, 2), how many along u and v ``n`` (F, 2) and their product ``count`` (F,)."""
    uv = t[:, :, :2]  # (F, 3, 2)
    g = (uv + 0.5) * r - 0.5  # coordinates in which column centres are integers
    jitter = np.asarray(_RAY_JITTER)
    lo = np.clip(np.ceil(g.min(axis=1) - jitter), 0, r).astype(np.int64)
    hi = np.clip(np.floor(g.max(axis=1) - jitter), -1, r - 1).astype(np.int64)
    n = np.maximum(hi - lo + 1, 0)
    return lo, n, n[:, 0] * n[:, 1]


def _crossings(a: np.ndarray, b: np.ndarray, c: np.ndarray, area2: np.ndarray, r: int
               ) -> np.ndarray:
    """Signed crossings of triangles ``a b c`` (in (u, v, w)) with the voxel columns, as
    a flat array ``(r * r * (r + 1),)``: per column, per number of centres below."""
    lo, n, count = _columns(np.stack([a, b, c], axis=1), r)
    total = int(count.sum())
    if not total:
        return np.zeros(r * r * (r + 1))
    jitter = np.asarray(_RAY_JITTER)
    fid = np.repeat(np.arange(len(count)), count)
    local = np.arange(total) - np.repeat(np.cumsum(count) - count, count)
    ci = lo[fid, 0] + local // n[fid, 1]
    cj = lo[fid, 1] + local % n[fid, 1]
    pu = -0.5 + (ci + 0.5 + jitter[0]) / r
    pv = -0.5 + (cj + 0.5 + jitter[1]) / r
    fa, fb, fc = a[fid], b[fid], c[fid]
    # Barycentric weights from edge functions, scaled by the signed area.
    wa = (fb[:, 0] - pu) * (fc[:, 1] - pv) - (fb[:, 1] - pv) * (fc[:, 0] - pu)
    wb = (fc[:, 0] - pu) * (fa[:, 1] - pv) - (fc[:, 1] - pv) * (fa[:, 0] - pu)
    wc = (fa[:, 0] - pu) * (fb[:, 1] - pv) - (fa[:, 1] - pv) * (fb[:, 0] - pu)
    s = np.sign(area2[fid])
    inside = (wa * s >= 0) & (wb * s >= 0) & (wc * s >= 0)
    ci, cj, s = ci[inside], cj[inside], s[inside]
    inv = 1.0 / area2[fid][inside]
    w = wa[inside] * fa[inside, 2] + wb[inside] * fb[inside, 2] + wc[inside] * fc[inside, 2]
    w = w * inv
    # m = number of voxel centres below the crossing along the column.
    m = np.clip(np.ceil((w + 0.5) * r - 0.5), 0, r).astype(np.int64)
    return np.bincount((ci * r + cj) * (r + 1) + m, weights=s, minlength=r * r * (r + 1))


def _ray_windings(tri: np.ndarray, resolution: int, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Winding numbers of all voxel centres from rays along ``+axis`` and ``-axis``.

    For every column of voxel centres parallel to ``axis`` a ray is cast through the column
    and its crossings with the triangles are found. A crossing counts +1 where the surface
    is left (normal along the ray) and -1 where it is entered. The winding number of a
    centre seen along ``+axis`` is the sum over crossings beyond it; along ``-axis``, over
    crossings before it (with the sign flipped). For a closed, consistently oriented mesh
    both equal the true winding number: 1 inside, 0 outside, 2 where parts overlap.
    Triangles are taken in chunks of about ``_CHUNK`` (triangle, column) pairs.

    Returns two int arrays ``(R, R, R)`` indexed ``[x, y, z]``.
    """
    r = resolution
    perm = _permutation(axis)  # the ray axis becomes the last coordinate "w"
    d = np.zeros(r * r * (r + 1))
    for part in _chunks(_columns(tri[:, :, perm], r)[2]):
        t = tri[part][:, :, perm]
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        # Twice the signed area of the projection onto (u, v); its sign is the sign of the
        # normal's w component.
        area2 = ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                 - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
        keep = np.abs(area2) > 1e-14
        d += _crossings(a[keep], b[keep], c[keep], area2[keep], r)
    d = np.rint(d).astype(np.int64).reshape(r, r, r + 1)
    below = np.cumsum(d, axis=2)[:, :, :r]  # signed crossings at or below each centre
    up = d.sum(axis=2, keepdims=True) - below  # crossings beyond the centre, +axis ray
    down = -below  # crossings before the centre, seen by a ray towards -axis
    # Undo the permutation: array axes are currently (u, v, w) = perm.
    inverse = np.argsort(perm)
    return up.transpose(inverse), down.transpose(inverse)


MAX_SURFACE_POINTS: int = 50_000_000
"""Most surface samples :func:`voxelize` makes for the thin-part rule (made
``_CHUNK`` at a time); a mesh needing more (one far larger than the grid cube, or millions
of large triangles) is refused before any is made."""


def _surface_point_counts(tri: np.ndarray, resolution: int) -> np.ndarray:
    """Upper bounds of the points :func:`_surface_points` makes on each triangle: rows
    ``spacing`` apart across its height, each at most ``longest edge / spacing + 2``."""
    spacing = _SURFACE_SPACING / resolution
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    longest = np.max([np.linalg.norm(tri[:, (k + 2) % 3] - tri[:, (k + 1) % 3], axis=1)
                      for k in range(3)], axis=0)
    n_rows = np.ceil(area2 / np.maximum(longest, 1e-300) / spacing) + 1
    return np.where(area2 > 1e-18, n_rows * (np.ceil(longest / spacing) + 1), 0)


def _surface_points(tri: np.ndarray, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """Points covering every triangle at spacing about ``_SURFACE_SPACING`` voxels.

    Each triangle is swept by rows parallel to its longest edge ``BC``, from the opposite
    vertex ``A`` (a point) to ``BC`` itself, rows and points ``spacing`` apart, so slivers
    cost few points. Returns ``(points, inward)``, both ``(N, 3)``: the points (pulled a hair
    towards the triangle's centroid, so a point on a box edge belongs to the box's own
    voxels) and unit vectors against the face normals (inward for an outward-facing mesh).
    """
    spacing = _SURFACE_SPACING / resolution
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(normal, axis=1)
    ok = norm > 1e-18
    tri, normal, norm = tri[ok], normal[ok], norm[ok]
    inward = -normal / norm[:, None]
    centroid = tri.mean(axis=1)
    # put the vertex opposite the longest edge first
    opposite = np.stack(
        [np.linalg.norm(tri[:, (k + 2) % 3] - tri[:, (k + 1) % 3], axis=1) for k in range(3)],
        axis=1,
    )
    first = np.argmax(opposite, axis=1)
    rows = np.arange(len(tri))
    a = tri[rows, first]
    b = tri[rows, (first + 1) % 3]
    c = tri[rows, (first + 2) % 3]
    bc_len = opposite[rows, first]
    height = norm / np.maximum(bc_len, 1e-300)
    n_rows = np.ceil(height / spacing).astype(np.int64) + 1  # rows at s = k / (n_rows - 1)
    # (triangle, row) pairs
    f_row = np.repeat(rows, n_rows)
    k = np.arange(len(f_row)) - np.repeat(np.cumsum(n_rows) - n_rows, n_rows)
    denom = np.maximum(n_rows[f_row] - 1, 1)
    s_row = k / denom
    n_pts = np.ceil(s_row * bc_len[f_row] / spacing).astype(np.int64) + 1
    # (triangle, row, point) triples
    fid = np.repeat(f_row, n_pts)
    srow = np.repeat(s_row, n_pts)
    m = np.arange(len(fid)) - np.repeat(np.cumsum(n_pts) - n_pts, n_pts)
    t = m / np.maximum(np.repeat(n_pts, n_pts) - 1, 1)
    fa, fb, fc = a[fid], b[fid], c[fid]
    pts = fa + srow[:, None] * ((fb - fa) + t[:, None] * (fc - fb))
    pts = pts + 1e-6 * (centroid[fid] - pts)
    return pts, inward[fid]


def _voxel_index(pts: np.ndarray, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """Integer voxel indices ``(N, 3)`` of points and a mask of those inside the grid."""
    idx = np.floor((pts + 0.5) * resolution).astype(np.int64)
    return idx, np.all((idx >= 0) & (idx < resolution), axis=1)


def _thin_surface(solid: np.ndarray, tri: np.ndarray, resolution: int) -> np.ndarray:
    """Voxels the surface passes through where ``solid`` has nothing just beneath it.

    A surface sample whose points half a voxel and one voxel further inside both fall in
    empty voxels belongs to a part too thin to hold a voxel centre (a chair leg, a panel):
    its own voxel is returned. Elsewhere the solid already covers the surface.
    """
    pitch = 1.0 / resolution
    out = np.zeros_like(solid)
    for part in _chunks(_surface_point_counts(tri, resolution)):
        pts, inward = _surface_points(tri[part], resolution)
        # a hair inwards, so a face lying on a voxel boundary marks the voxel behind it
        own, ok = _voxel_index(pts + (1e-6 * pitch) * inward, resolution)
        covered = np.zeros(len(pts), dtype=bool)
        for depth in (0.5, 1.0):
            idx, inside = _voxel_index(pts + (depth * pitch) * inward, resolution)
            hit = np.zeros(len(pts), dtype=bool)
            hit[inside] = solid[idx[inside, 0], idx[inside, 1], idx[inside, 2]]
            covered |= hit
        own = own[ok & ~covered]
        out[own[:, 0], own[:, 1], own[:, 2]] = True
    return out


def voxelize(mesh: trimesh.Trimesh, resolution: int = paper.GRID_SIDE) -> np.ndarray:
    """Solid occupancy grid of a mesh over the cube ``[-0.5, 0.5]^3``.

    Returns a ``bool`` array ``(resolution,) * 3`` indexed ``[x, y, z]``; voxel ``i`` along x
    has its centre at ``-0.5 + (i + 0.5) / resolution`` (metres in the normalized frame).
    The mesh is **not** re-normalized: normalize it first (``e2vlib.shapes.normalize_mesh``);
    parts outside the cube are clipped away (they still count when deciding what lies inside).

    A voxel is occupied when any of these hold:

    1. its centre is inside the mesh. For a watertight mesh this is the non-zero winding
       rule along rays parallel to z, so overlapping closed parts (a concatenation of
       primitives) count as their union. For a mesh that is not watertight, rays are cast
       from the centre along +x, -x, +y, -y, +z, -z and the centre is inside when at least 4
       of the 6 see a non-zero winding number: a missing face or a small hole then leaves
       the interior filled, while open space next to an opening stays empty;
    2. the surface passes through it where rule 1 found no occupied voxel half a voxel and
       one voxel beneath the surface (surface sampled about every third of a voxel). This
       keeps parts thinner than a voxel, such as chair legs or a display panel, which
       centre sampling would break up or lose (binvox's ShapeNetVox32 labels keep them
       too), without fattening thick parts by a layer of surface voxels;
    3. it is empty but enclosed by occupied voxels (cavities are filled: labels are solid).

    A face lying exactly on a voxel boundary belongs to the voxel on its inner side. Normals
    are taken to point outwards; a watertight mesh that is inside-out is flipped first.
    For a mesh that is not watertight the guarantee is weaker: a closed mesh with one face
    (or a few) removed gives the same grid as the closed mesh, while a surface with no
    inside at all (a single sheet) gives just its surface voxels.

    Known answers (see tests/test_voxels.py): a centred box of half-size 0.25 gives exactly
    the central 16^3 block at resolution 32; a sphere of radius 0.5 fills about pi/6 of it.
    A mesh whose work exceeds a bound (:data:`MAX_FACES`, :data:`MAX_RAY_TESTS`,
    :data:`MAX_SURFACE_POINTS`: one far larger than the cube, or millions of large
    triangles) is refused, naming its file, before anything is allocated.

    Introduced in notebooks/04_building_the_dataset.ipynb.

    Examples
    --------
    >>> grid = voxelize(trimesh.creation.box((0.5, 0.5, 0.5)))
    >>> grid.shape, int(grid.sum()) == 16 ** 3, bool(grid[8:24, 8:24, 8:24].all())
    ((32, 32, 32), True, True)
    """
    r = _check_resolution(resolution)
    tri = _check_mesh(mesh)
    _check_work(tri, r, (2,) if mesh.is_watertight else (0, 1, 2), mesh_name(mesh))
    if mesh.is_watertight:
        signed_volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum()
        if signed_volume < 0:  # inside-out mesh: flip it so "inward" points inwards
            tri = tri[:, ::-1]
        up, _ = _ray_windings(tri, r, axis=2)
        occupied = up != 0
    else:
        votes = np.zeros((r, r, r), dtype=np.int8)
        for axis in range(3):
            up, down = _ray_windings(tri, r, axis)
            votes += (up != 0).astype(np.int8)
            votes += (down != 0).astype(np.int8)
        occupied = votes >= 4
    occupied |= _thin_surface(occupied, tri, r)
    return ndimage.binary_fill_holes(occupied)


def shapenet_voxels_to_zup(voxels: np.ndarray) -> np.ndarray:
    """Turn a grid in ShapeNetCore v2's frame (y up, front -z) into ours (z up, front -y).

    The same proper rotation as ``e2vlib.shapes.shapenet_to_zup``: ``(x, y, z) -> (-x, z, y)``,
    i.e. ``out[i, j, k] = voxels[R - 1 - i, k, j]``. Assumes the grid covers a cube centred
    on the origin. Returns a new ``bool`` array ``(R, R, R)``; VoxelError for a non-cubic grid.

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    v = _check_grid(voxels)
    return np.ascontiguousarray(v[::-1].transpose(0, 2, 1))


# --------------------------------------------------------------------------- binvox


def _check_grid(voxels: np.ndarray) -> np.ndarray:
    v = np.asarray(voxels)
    if v.ndim != 3 or len(set(v.shape)) != 1 or v.shape[0] == 0:
        raise VoxelError(f"voxels must be a cubic (R, R, R) array, got shape {v.shape}")
    if v.dtype != bool:
        if not np.issubdtype(v.dtype, np.number) or not np.all(np.isin(v, (0, 1))):
            raise VoxelError(
                f"voxels must be bool or hold only 0/1, got dtype {v.dtype}; "
                "threshold probabilities first, e.g. probabilities > 0.5"
            )
        v = v.astype(bool)
    return v


def read_binvox(path: str | os.PathLike) -> np.ndarray:
    """Read a binvox file into a ``bool`` array indexed ``[x, y, z]``.

    binvox (Patrick Min's voxelizer, used for ShapeNetVox32 and Pix2Vox labels) stores an
    ASCII header (``#binvox 1``, ``dim D D D``, ``translate tx ty tz``, ``scale s``,
    ``data``) followed by run-length pairs of bytes ``(value, count)``. The runs list the
    voxels with **y running fastest, then z, then x** (flat index ``x*D*D + z*D + y``), so
    the decoded array is reshaped to ``(D, D, D)`` = ``[x, z, y]`` and its last two axes are
    swapped. trimesh's binvox exchange parses the header and expands the runs; this function
    checks what it gets. ``translate`` and ``scale`` are read but not returned (our grids
    always cover ``[-0.5, 0.5]^3``). Note that ShapeNet's grids are in ShapeNet's y-up frame;
    see :func:`shapenet_voxels_to_zup`.

    Raises :class:`VoxelError` (a ValueError) naming the file for a bad header, a
    non-cubic grid, or run lengths that do not add up to ``D^3``; FileNotFoundError if missing.

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    path = Path(path)
    with open(path, "rb") as file:
        try:
            parsed = trimesh_binvox.parse_binvox(file)
        except ValueError as err:  # no magic word, no 'data' line, a non-number in a field
            raise VoxelError(f"{path}: not a readable binvox header ({err}); the file is "
                             "truncated or not a binvox file") from err
    dims = tuple(int(d) for d in parsed.shape)
    if len(dims) != 3 or min(dims) <= 0:
        raise VoxelError(f"{path}: binvox 'dim' must be three positive ints, got {dims}")
    if len(set(dims)) != 1:
        raise VoxelError(f"{path}: only cubic binvox grids are supported, got dim {dims}")
    runs = parsed.rle_data
    if runs.size % 2:
        raise VoxelError(f"{path}: binvox data has an odd number of bytes ({runs.size}); "
                         "file truncated?")
    total = int(runs[1::2].sum(dtype=np.int64))
    if total != dims[0] ** 3:
        raise VoxelError(f"{path}: binvox run lengths add up to {total} voxels but dim {dims} "
                         f"needs {dims[0] ** 3}; file truncated or corrupt")
    if np.any(runs[0::2] > 1):
        raise VoxelError(f"{path}: binvox run values must be 0 or 1; file corrupt")
    flat = runlength.rle_to_dense(runs, dtype=bool)
    return np.ascontiguousarray(flat.reshape(dims).transpose(0, 2, 1))


def write_binvox(
    path: str | os.PathLike,
    voxels: np.ndarray,
    translate: Sequence[float] = (-0.5, -0.5, -0.5),
    scale: float = 1.0,
) -> None:
    """Write a cubic grid indexed ``[x, y, z]`` as a binvox file (see :func:`read_binvox`).

    ``translate`` and ``scale`` go into the header; binvox readers map voxel ``i`` to
    ``translate + (i + 0.5) / D * scale``, so the defaults describe our cube
    ``[-0.5, 0.5]^3``. The runs (at most 255 voxels each) come from trimesh's run-length
    encoder and the bytes from its binvox exchange. The file is written to a temporary file
    next to ``path`` and then renamed, so an existing file is never left half-written. The
    input is not modified.

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    v = _check_grid(voxels)
    t = [float(x) for x in translate]
    if len(t) != 3 or not all(np.isfinite(t)):
        raise VoxelError(f"translate must be three finite floats, got {translate!r}")
    if not np.isfinite(scale) or scale <= 0:
        raise VoxelError(f"scale must be a positive float, got {scale!r}")
    runs = runlength.dense_to_rle(v.transpose(0, 2, 1).ravel().astype(np.uint8), dtype=np.uint8)
    runs = runs.reshape(-1, 2)
    runs = runs[runs[:, 1] > 0].ravel()  # trimesh splits a run of exactly 255 as 255 + 0
    data = trimesh_binvox.binvox_bytes(runs, v.shape, translate=t, scale=float(scale))
    with atomic_path(Path(path)) as tmp:
        tmp.write_bytes(data)
