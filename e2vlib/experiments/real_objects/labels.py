"""Solid 32^3 voxel labels for open, many-part meshes.

:func:`e2vlib.voxels.voxelize` decides what lies inside by winding numbers, which need
faces turned consistently; almost no real model here is one closed, consistently turned
object (a median of about a hundred open parts, overlapping copies, faces facing either
way). :func:`solid_labels` needs no orientation. On a grid :data:`FACTOR` times finer than
the label (128^3 for 32^3 labels) it

1. marks every cell a dense sample of the surface falls in (points at most half a fine
   cell apart on every triangle: :func:`surface_cells`);
2. seals gaps narrower than about one label voxel by a morphological closing with a ball
   of :data:`CLOSE_CELLS` fine cells (parts that nearly touch, cracks between faces);
3. fills what that surface encloses (``scipy.ndimage.binary_fill_holes``); where nothing
   encloses (an open box, a boat's hull, a lamp shade) a cell still counts as inside when
   the surface lies beyond it in at least :data:`VOTES` of the six axis directions (so an
   opening on one side does not empty the inside, while open space beside a part, with
   nothing beyond it on two sides or more, stays empty);
4. comes down to the label grid (:func:`coarse_solid`) as :func:`voxelize` rules: a voxel
   is set when its centre is inside (judged from the fine cells around it, those the
   surface passes through counting half), or when solid fine cells of it lie more than half
   a voxel from every such voxel (thin parts: legs, panels, wings thinner than a voxel), and
   cavities are filled.

A surface with no inside at all (a flat plane) keeps just its shell. What step 3 found is
the sample's ``fill``: ``enclosed`` (something closed), ``voted`` (the inside of an open
shape, by the six directions), ``shell`` (nothing inside: the label is the surface).
Known answers (tests/test_real_object_samples.py): a closed box gives exactly
:func:`voxelize`'s grid; a box missing one face, or one missing a whole side, and a box of
six separate overlapping faces turned either way give the same grid; a flat plane stays
a one-voxel shell.
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy import ndimage

from e2vlib import paper

FACTOR = 4
"""Fine cells per label voxel along each axis."""
CLOSE_CELLS = 2
"""Radius (fine cells) of the ball of the closing that seals gaps: gaps up to about
``2 * CLOSE_CELLS`` fine cells (one label voxel) wide are sealed."""
VOTES = 5
"""Axis directions (of six) in which the surface must lie beyond a cell that nothing
encloses for it to count as inside."""
SPACING = 0.5
"""Largest distance between surface samples on a triangle, in fine cells."""
MAX_POINTS = 300_000_000
"""Most surface samples :func:`surface_cells` makes (a mesh needing more is refused)."""
NOTICE = 0.01
"""Share of the solid's fine cells a step must add for the record to name it."""
_CHUNK = 2_000_000
_NUDGE = 1e-9
FILLS = ("enclosed", "voted", "shell")
"""What :func:`solid_labels` found inside a mesh (its record's ``fill``)."""


def _lattice(n: int) -> np.ndarray:
    """Barycentric weights ``(K, 3)`` of the points ``(i, j) / n``, ``i + j <= n``."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    a, b = i[keep] / n, j[keep] / n
    return np.stack([1 - a - b, a, b], axis=1)


def surface_cells(mesh: trimesh.Trimesh, grid: int, spacing: float = SPACING) -> np.ndarray:
    """Boolean ``(grid,) * 3`` grid over ``[-0.5, 0.5]^3`` (indexed ``[x, y, z]``) of the
    cells the surface of ``mesh`` passes through: every triangle is sampled on a regular
    barycentric lattice whose points lie at most ``spacing`` cells apart, vertices and
    edges included. Points outside the cube are clipped to its border cells.

    Examples
    --------
    >>> cells = surface_cells(trimesh.creation.box(extents=(0.5, 0.5, 0.5)), 8)
    >>> int(cells.sum()), bool(cells[4, 4, 4])  # a 4^3 block's shell and one face further
    (98, False)
    """
    tri = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)]
    out = np.zeros((grid,) * 3, dtype=bool)
    if len(tri) == 0:
        return out
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    n = np.maximum(1, np.ceil(edges * grid / spacing)).astype(np.int64)
    total = float(((n + 1) * (n + 2) // 2).sum())
    if total > MAX_POINTS:
        raise ValueError(f"sampling the surface of a mesh of {len(tri)} triangles at "
                         f"{grid}^3 takes {total:.3g} points, more than MAX_POINTS "
                         f"({MAX_POINTS:.0e}); normalize or simplify it first")
    for value in np.unique(n):
        weights = _lattice(int(value))
        rows = np.flatnonzero(n == value)
        step = max(1, _CHUNK // len(weights))
        for start in range(0, len(rows), step):
            pts = np.einsum("kc,fcd->fkd", weights, tri[rows[start:start + step]])
            # the nudge keeps points on a cell border, rounded just below it, in one cell
            idx = np.clip(np.floor((pts.reshape(-1, 3) + 0.5) * grid + _NUDGE)
                          .astype(np.int64), 0, grid - 1)
            out[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    return out


def _ball(radius: int) -> np.ndarray:
    r = np.arange(-radius, radius + 1)
    x, y, z = np.meshgrid(r, r, r, indexing="ij")
    return x * x + y * y + z * z <= radius * radius


def blocked_directions(occ: np.ndarray) -> np.ndarray:
    """``int8`` count, per cell, of the six axis directions (+x, -x, +y, -y, +z, -z) in
    which ``occ`` has an occupied cell at or beyond it.

    Examples
    --------
    >>> occ = np.zeros((3, 3, 3), bool)
    >>> occ[0, 1, 1] = occ[2, 1, 1] = True  # a cell on each side along x
    >>> int(blocked_directions(occ)[1, 1, 1]), int(blocked_directions(occ)[1, 0, 0])
    (2, 0)
    """
    count = np.zeros(occ.shape, dtype=np.int8)
    for axis in range(3):
        forward = np.flip(np.logical_or.accumulate(np.flip(occ, axis), axis=axis), axis)
        backward = np.logical_or.accumulate(occ, axis=axis)
        count += forward.astype(np.int8) + backward.astype(np.int8)
    return count


def fine_solid(surface: np.ndarray, close: int = CLOSE_CELLS, votes: int = VOTES
               ) -> tuple[np.ndarray, np.ndarray, str]:
    """The solid of a fine surface grid (steps 2 and 3 of the module's recipe), the
    sealed surface (the closing of ``surface``) and what was found inside (one of
    :data:`FILLS`: the last step that added more than :data:`NOTICE` of the solid)."""
    pad = close + 1
    closed = ndimage.binary_closing(np.pad(surface, pad), structure=_ball(close))
    closed = closed[pad:-pad, pad:-pad, pad:-pad] | surface
    enclosed = ndimage.binary_fill_holes(closed)
    solid = ndimage.binary_fill_holes(enclosed | (blocked_directions(enclosed) >= votes))
    n_solid, n_enclosed = int(solid.sum()), int(enclosed.sum())
    if n_solid - n_enclosed > NOTICE * n_solid:
        fill = "voted"
    elif n_enclosed - int(closed.sum()) > NOTICE * n_solid:
        fill = "enclosed"
    else:
        fill = "shell"
    return solid, closed, fill


def coarse_solid(fine: np.ndarray, shell: np.ndarray, factor: int = FACTOR,
                 near: int | None = None) -> np.ndarray:
    """A fine solid brought down ``factor`` times (step 4). A voxel is set when its centre
    is inside: the mean over the ``2 x 2 x 2`` fine cells around its centre, counting a
    solid cell 1 and a cell of the surface ``shell`` (which straddles the surface) 1/2, is
    above 1/2; or when solid cells of it lie more than ``factor // 2`` fine cells
    (Chebyshev) from every voxel set so (thin parts). Enclosed voxels are then filled.

    Examples
    --------
    A cube of two voxels a side whose top surface lies in the lowest fine cell of the next
    layer, and a rod thinner than a voxel:

    >>> fine = np.zeros((16, 16, 16), bool)
    >>> fine[4:12, 4:12, 4:13] = True
    >>> shell = fine & ~np.pad(fine[1:-1, 1:-1, 1:-1], 1)
    >>> fine[0, 0, :] = shell[0, 0, :] = True
    >>> coarse = coarse_solid(fine, shell)
    >>> int(coarse[1:3, 1:3, 1:3].sum()), int(coarse.sum()), coarse[0, 0].tolist()
    (8, 12, [True, True, True, True])
    """
    r = fine.shape[0] // factor
    weight = fine.astype(np.float32) - 0.5 * (fine & shell)
    mid = slice(factor // 2 - 1, factor // 2 + 1)
    centre = weight.reshape(r, factor, r, factor, r, factor)[:, mid, :, mid, :, mid]
    inside = centre.mean(axis=(1, 3, 5)) > 0.5
    up = np.repeat(np.repeat(np.repeat(inside, factor, 0), factor, 1), factor, 2)
    near = ndimage.binary_dilation(up, structure=np.ones((3, 3, 3), bool),
                                   iterations=factor // 2 if near is None else near)
    thin = (fine & ~near).reshape(r, factor, r, factor, r, factor).any(axis=(1, 3, 5))
    return ndimage.binary_fill_holes(inside | thin)


def solid_labels(mesh: trimesh.Trimesh, resolution: int = paper.GRID_SIDE,
                 factor: int = FACTOR) -> tuple[np.ndarray, dict]:
    """Solid ``bool`` label grid ``(resolution,) * 3`` of ``mesh`` (normalized: inside
    ``[-0.5, 0.5]^3``, indexed ``[x, y, z]`` like :func:`e2vlib.voxels.voxelize`) that
    tolerates open, many-part meshes, and its record: ``fill`` (:data:`FILLS`),
    ``surface`` (label voxels the surface passes through) and ``voxels`` (set).

    Examples
    --------
    >>> box = trimesh.creation.box(extents=(0.5, 0.5, 0.5))
    >>> grid, record = solid_labels(box)
    >>> int(grid.sum()) == 16 ** 3, bool(grid[8:24, 8:24, 8:24].all()), record["fill"]
    (True, True, 'enclosed')
    >>> plane = trimesh.Trimesh([[-0.4, -0.4, 0.01], [0.4, -0.4, 0.01], [0.4, 0.4, 0.01],
    ...                          [-0.4, 0.4, 0.01]], [[0, 1, 2], [0, 2, 3]])
    >>> grid, record = solid_labels(plane)
    >>> record["fill"], np.unique(np.argwhere(grid)[:, 2]).tolist()  # one layer, z = 16
    ('shell', [16])
    """
    surface = surface_cells(mesh, resolution * factor)
    solid, closed, fill = fine_solid(surface)
    grid = coarse_solid(solid, closed, factor)
    shell = surface.reshape((resolution, factor) * 3).any(axis=(1, 3, 5))
    return grid, {"fill": fill, "surface": int(shell.sum()), "voxels": int(grid.sum())}
