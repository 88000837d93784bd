"""Looking at the candidates: surface occupancy grids, contact sheets and duplicates.

Every candidate is loaded in our frame (:func:`~e2vlib.experiments.real_objects.readers.load_model`)
and its surface sampled into a :data:`GRID`^3 occupancy grid (:func:`surface_grid`; open,
many-part meshes are fine: no inside is needed). The grids give the outline pictures
from three sides on contact sheets (:func:`contact_sheet`, for a person to look at) and the
duplicates by geometry (:func:`duplicates`: IoU of :data:`DEDUP_GRID`^3 grids within a
category above :data:`DEDUP_IOU`: liveries and level-of-detail copies). Grids and sheets
are derived from GPL and CC-BY-SA models: they stay under ``cache/``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import trimesh

from e2vlib.metrics import iou

if TYPE_CHECKING:
    import PIL.Image

GRID = 64
"""Cells per side of the occupancy grid the pictures are drawn from."""
DEDUP_GRID = 32
"""Cells per side of the grids compared for duplicates."""
DEDUP_IOU = 0.95
"""IoU above which two models of one category count as one shape."""
SAMPLES = 200_000
"""Surface points sampled per model (about 50 per occupied cell of a 64^3 grid)."""


def surface_grid(mesh: trimesh.Trimesh, grid: int = GRID, samples: int = SAMPLES,
                 seed: int = 0) -> np.ndarray:
    """Boolean ``(grid, grid, grid)`` occupancy of the surface of ``mesh`` (normalized:
    inside [-0.5, 0.5]^3), indexed ``[x, y, z]``: a cell is set when a sampled surface
    point or a vertex falls in it.

    Examples
    --------
    >>> occ = surface_grid(trimesh.creation.box(extents=(1, 0.5, 0.25)), grid=8)
    >>> occ.shape, bool(occ[0, 4, 4]), bool(occ[4, 4, 4])  # surface set, inside empty
    ((8, 8, 8), True, False)
    """
    points, _ = trimesh.sample.sample_surface(mesh, samples, seed=seed)
    points = np.concatenate([points, mesh.vertices])
    idx = np.clip(np.floor((points + 0.5) * grid).astype(np.int64), 0, grid - 1)
    occ = np.zeros((grid, grid, grid), dtype=bool)
    occ[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    return occ


def pool(occ: np.ndarray, grid: int = DEDUP_GRID) -> np.ndarray:
    """``occ`` max-pooled down to ``grid`` cells a side (its side a multiple of ``grid``).

    Examples
    --------
    >>> pool(np.eye(4, dtype=bool)[:, :, None].repeat(4, 2), 2)[:, :, 0].tolist()
    [[True, False], [False, True]]
    """
    k = occ.shape[0] // grid
    return occ.reshape(grid, k, grid, k, grid, k).any(axis=(1, 3, 5))


def duplicates(grids: dict[str, np.ndarray], categories: dict[str, str],
               threshold: float = DEDUP_IOU) -> dict[str, tuple[str, float]]:
    """``{key: (key it duplicates, IoU)}`` for every model whose pooled grid matches an
    earlier one (in key order) of its category with IoU above ``threshold``; the earliest
    of each group is kept.

    Examples
    --------
    >>> a = np.zeros((4, 4, 4), bool); a[1:3, 1:3, 1:3] = True
    >>> duplicates({"p": a, "q": a.copy(), "r": ~a}, {"p": "car", "q": "car", "r": "car"},
    ...            0.95)
    {'q': ('p', 1.0)}
    """
    out, kept = {}, {}
    for key in sorted(grids):
        cat = categories[key]
        for other in kept.get(cat, []):
            score = iou(grids[key], grids[other])
            if score > threshold:
                out[key] = (other, round(score, 3))
                break
        else:
            kept.setdefault(cat, []).append(key)
    return out


def views(occ: np.ndarray) -> list[np.ndarray]:
    """Three depth-shaded outline pictures (uint8, white background) of a ``[x, y, z]``
    grid: from the front (-y, x to the right), from the side (front -y to the left) and
    from above (front -y at the top); nearer surfaces are darker, z is up in the first two.

    Examples
    --------
    >>> occ = np.zeros((4, 4, 4), bool)
    >>> occ[2, 0, 2] = True  # a cell at the front (-y)
    >>> front, side, top = views(occ)
    >>> [np.argwhere(v < 255).tolist() for v in (side, top)]  # [row, column]
    [[[1, 0]], [[0, 2]]]
    """
    n = occ.shape[0]
    ramp = np.linspace(40, 200, n)

    def shade(grid: np.ndarray) -> np.ndarray:  # grid [u, v, depth], depth 0 nearest
        hit = grid.any(axis=2)
        first = grid.argmax(axis=2)
        return np.where(hit, ramp[first], 255).astype(np.uint8)

    front = shade(occ.transpose(0, 2, 1))[:, ::-1].T          # rows z (top up), cols x
    side = shade(occ[::-1].transpose(1, 2, 0))[:, ::-1].T       # rows z, cols -y..+y
    top = shade(occ[:, :, ::-1])[:, ::-1].T[::-1]               # rows y (-y bottom), cols x
    return [front, side, top]


def contact_sheet(cells: list[tuple[str, np.ndarray | None]], columns: int = 5,
                  scale: int = 1) -> PIL.Image.Image:
    """A greyscale PIL image of labelled cells, ``columns`` a row, each the three
    :func:`views` of one grid side by side at ``scale`` pixels per grid cell (a grey cell for
    a model that could not be read)."""
    from PIL import Image, ImageDraw

    n = GRID * scale
    width, height = 3 * n + 10, n + 16
    rows = max(1, -(-len(cells) // columns))
    sheet = Image.new("L", (columns * width, rows * height), 255)
    draw = ImageDraw.Draw(sheet)
    for i, (label, occ) in enumerate(cells):
        x0, y0 = (i % columns) * width, (i // columns) * height
        draw.text((x0 + 2, y0 + 2), label[:40], fill=0)
        if occ is None:
            draw.rectangle([x0 + 2, y0 + 14, x0 + 3 * n, y0 + 14 + n], fill=160)
            continue
        for k, pic in enumerate(views(occ)):
            im = Image.fromarray(pic).resize((n, n), Image.NEAREST)
            sheet.paste(im, (x0 + k * n, y0 + 14))
            draw.rectangle([x0 + k * n, y0 + 14, x0 + (k + 1) * n - 1, y0 + 13 + n],
                           outline=200)
    return sheet
