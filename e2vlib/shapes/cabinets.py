"""Procedural cabinets in five sub-types (:data:`CABINET_KINDS`), the structural variety of
ShapeNet's cabinet category rather than one box of random proportions:

``chest``      a closed box (wardrobe, sideboard or nightstand) with doors and drawers
``shelves``    an open bookcase or cube shelf: empty compartments (no back panel on some)
``open_door``  a hollow wardrobe or cupboard with a door swung open on its shelves
``on_legs``    a closed body raised on tall legs (posts, splayed or hairpin), empty beneath
``hutch``      a dresser: a deep closed base with a shallow shelf unit set back on top

Voxel labels are solid only where a cavity is enclosed, so the open compartments, the
opened cupboard and the space under the legs stay empty in the 32^3 label.

Each builder takes a ``numpy.random.Generator`` and returns the parts of one object
(watertight ``trimesh.Trimesh`` solids) in rough metres, z up, front towards -y; parts that
meet overlap by ``OVERLAP_M``. :func:`e2vlib.shapes.builders.make_shape` joins and normalizes them.
The order of the random draws is part of the output: changing it changes every mesh.
"""

from __future__ import annotations

import numpy as np

from e2vlib.shapes.parts import pick_style, uniform
from e2vlib.shapes.primitives import (
    OVERLAP_M,
    Parts,
    Rng,
    beam_between,
    box_between,
    brick,
    centred_box,
    rod,
    sphere,
)

CABINET_KINDS = {"chest": 0.24, "shelves": 0.22, "open_door": 0.2, "on_legs": 0.16, "hutch": 0.18}
"""Cabinet sub-types and their probabilities (the first draw of :func:`build_cabinet`)."""


def _fronts(rng: Rng, w: float, fy: float, z0: float, h: float) -> Parts:
    """Doors and/or drawer fronts with knobs on a closed body's front face at ``y = fy``,
    covering ``z0 .. h``."""
    parts: Parts = []
    front = pick_style(rng, {"doors": 0.45, "drawers": 0.3, "mixed": 0.25})
    n_cols = int(rng.integers(1, 4)) if w > 0.8 else int(rng.integers(1, 3))
    gap = 0.01
    z_split = {"doors": h, "drawers": z0}.get(front, z0 + (h - z0) * uniform(rng, 0.55, 0.75))
    if z_split > z0 + 0.05:  # doors from z0 to z_split, a vertical bar handle each
        cw = w / n_cols
        for k in range(n_cols):
            x0, x1 = -w / 2 + k * cw + gap, -w / 2 + (k + 1) * cw - gap
            parts.append(box_between((x0, fy - 0.015, z0 + gap), (x1, fy + 0.01, z_split - gap)))
            hx = x1 - 0.04 if k % 2 == 0 else x0 + 0.04
            zc = z0 + (z_split - z0) * 0.6
            hl = min(0.15, (z_split - z0) * 0.25)
            parts.append(centred_box((hx, fy - 0.025, zc), (0.016, 0.025, hl)))
    if z_split < h - 0.05:  # drawers from z_split to h, a horizontal bar handle each
        n_rows = max(1, int(round((h - z_split) / uniform(rng, 0.15, 0.3))))
        rh = (h - z_split) / n_rows
        for k in range(n_rows):
            z_lo, z_hi = z_split + k * rh + gap, z_split + (k + 1) * rh - gap
            parts.append(
                box_between((-w / 2 + gap, fy - 0.015, z_lo), (w / 2 - gap, fy + 0.01, z_hi))
            )
            parts.append(
                centred_box((0, fy - 0.025, (z_lo + z_hi) / 2), (min(0.25, w * 0.3), 0.025, 0.016))
            )
    return parts


def _base(rng: Rng, w: float, d: float, kinds: dict[str, float]) -> tuple[Parts, float]:
    """What a body stands on (``plinth``, ``feet`` or ``none``): the parts and the height
    ``z0`` of the body's bottom."""
    base = pick_style(rng, kinds)
    if base == "plinth":
        z0 = uniform(rng, 0.05, 0.1)
        return [
            box_between(
                (-w / 2 + 0.03, -d / 2 + 0.04, 0), (w / 2 - 0.03, d / 2 - 0.01, z0 + OVERLAP_M)
            )
        ], z0
    if base == "feet":
        z0, f = uniform(rng, 0.03, 0.08), 0.05
        return [
            centred_box((sx * (w / 2 - f), sy * (d / 2 - f), z0 / 2), (f, f, z0 + 2 * OVERLAP_M))
            for sx in (-1, 1)
            for sy in (-1, 1)
        ], z0
    return [], 0.0


def _chest(rng: Rng) -> Parts:
    shape = pick_style(rng, {"tall": 0.35, "sideboard": 0.35, "nightstand": 0.3})
    w, d, h = {
        "tall": (uniform(rng, 0.5, 1.1), uniform(rng, 0.4, 0.6), uniform(rng, 1.4, 2.0)),
        "sideboard": (uniform(rng, 1.0, 1.8), uniform(rng, 0.4, 0.55), uniform(rng, 0.6, 0.95)),
        "nightstand": (uniform(rng, 0.4, 0.6), uniform(rng, 0.35, 0.5), uniform(rng, 0.45, 0.7)),
    }[shape]
    parts, z0 = _base(rng, w, d, {"plinth": 0.45, "feet": 0.25, "none": 0.3})
    parts.append(box_between((-w / 2, -d / 2, z0), (w / 2, d / 2, h)))
    if rng.random() < 0.5:  # top with an overhang
        o = uniform(rng, 0.01, 0.04)
        parts.append(
            box_between((-w / 2 - o, -d / 2 - o, h - OVERLAP_M), (w / 2 + o, d / 2 + o, h + 0.03))
        )
    return parts + _fronts(rng, w, -d / 2, z0, h)


def _shelf_grid(
    w: float, d: float, z0: float, h: float, t: float, cols: int, rows: int, back: bool
) -> Parts:
    """An open carcass: ``cols + 1`` uprights, ``rows + 1`` shelves, maybe a back panel."""
    parts: Parts = []
    for k in range(cols + 1):
        x = -w / 2 + (w - t) * k / cols
        parts.append(box_between((x, -d / 2, z0), (x + t, d / 2, h)))
    for k in range(rows + 1):
        z = z0 + (h - z0 - t) * k / rows
        parts.append(box_between((-w / 2 + t / 2, -d / 2, z), (w / 2 - t / 2, d / 2, z + t)))
    if back:
        parts.append(
            box_between((-w / 2 + t / 2, d / 2 - t, z0 + t / 2), (w / 2 - t / 2, d / 2, h - t / 2))
        )
    return parts


def _shelves(rng: Rng) -> Parts:
    style = pick_style(rng, {"bookcase": 0.45, "cubes": 0.35, "low": 0.2})
    if style == "bookcase":
        w, d, h = uniform(rng, 0.6, 1.2), uniform(rng, 0.25, 0.4), uniform(rng, 1.0, 2.0)
        cols, rows = (2 if w > 0.9 and rng.random() < 0.5 else 1), int(rng.integers(3, 6))
        t, back = uniform(rng, 0.02, 0.03), True
    elif style == "cubes":  # a grid of open cubes, often open at the back too
        cols, rows = int(rng.integers(2, 5)), int(rng.integers(1, 5))
        cell, t = uniform(rng, 0.33, 0.4), uniform(rng, 0.03, 0.05)
        w, h, d = cols * cell + t, rows * cell + t, uniform(rng, 0.35, 0.4)
        back = rng.random() < 0.3
    else:  # a low wide unit
        w, d, h = uniform(rng, 1.0, 1.8), uniform(rng, 0.3, 0.45), uniform(rng, 0.5, 0.9)
        cols, rows = int(rng.integers(2, 4)), int(rng.integers(1, 3))
        t, back = uniform(rng, 0.02, 0.035), True
    parts, z0 = _base(rng, w, d, {"plinth": 0.35, "feet": 0.25, "none": 0.4})
    h += z0
    parts += _shelf_grid(w, d, z0, h, t, cols, rows, back)
    if rows >= 3 and rng.random() < 0.4:  # a closed cupboard in the bottom row
        z_top = z0 + (h - z0 - t) / rows + t
        parts.append(box_between((-w / 2, -d / 2 - 0.015, z0), (w / 2, d / 2, z_top)))
    return parts


def _door(
    hinge_x: float, y: float, z_lo: float, z_hi: float, width: float, t: float, degrees: float
) -> Parts:
    """A door of ``width`` hinged on the vertical line ``(hinge_x, y)`` and opened outwards
    by ``degrees`` (0: closed, in the plane ``y``, running towards the cabinet's middle),
    with a knob near its free edge."""
    s = -np.sign(hinge_x)  # +1: hinged on the left, the door runs towards +x when closed
    a = np.radians(degrees)
    along = np.array([s * np.cos(a), -np.sin(a), 0.0])  # hinge -> free edge
    out = np.array([-s * np.sin(a), -np.cos(a), 0.0])  # the door's front face normal
    corner = np.array([hinge_x, y, z_lo])
    slab = brick(corner, along * width, out * t, (0, 0, z_hi - z_lo))
    knob = corner + along * (width - 0.05) + out * t + (0, 0, (z_hi - z_lo) * 0.55)
    return [slab, sphere(knob, 0.015, 1)]


def _open_door(rng: Rng) -> Parts:
    style = pick_style(rng, {"wardrobe": 0.5, "cupboard": 0.5})
    if style == "wardrobe":
        w, d, h = uniform(rng, 0.8, 1.2), uniform(rng, 0.5, 0.62), uniform(rng, 1.6, 2.0)
        n_doors = 2
    else:
        w, d, h = uniform(rng, 0.4, 0.9), uniform(rng, 0.35, 0.5), uniform(rng, 0.6, 1.2)
        n_doors = 2 if w > 0.6 and rng.random() < 0.6 else 1
    t = uniform(rng, 0.02, 0.03)
    parts, z0 = _base(rng, w, d, {"plinth": 0.4, "feet": 0.3, "none": 0.3})
    h += z0
    parts += _shelf_grid(w, d, z0, h, t, 1, 1, back=True)  # the hollow carcass
    inner = h - z0 - 2 * t
    if style == "wardrobe":  # a hat shelf and a hanging rail under it
        z_shelf = h - t - inner * uniform(rng, 0.12, 0.2)
        parts.append(
            box_between(
                (-w / 2 + t / 2, -d / 2 + 0.03, z_shelf),
                (w / 2 - t / 2, d / 2 - t / 2, z_shelf + t),
            )
        )
        zr = z_shelf - 0.06
        parts.append(rod((-w / 2 + t / 2, 0, zr), (w / 2 - t / 2, 0, zr), 0.015, 10))
    else:
        n = int(rng.integers(1, 3))
        for k in range(n):
            z = z0 + t + inner * (k + 1) / (n + 1) - t / 2
            parts.append(
                box_between(
                    (-w / 2 + t / 2, -d / 2 + 0.03, z), (w / 2 - t / 2, d / 2 - t / 2, z + t)
                )
            )
    # doors hinged on the outer edges, overlapping the carcass's front edges by 1 cm
    width = w / n_doors - 0.012
    hinges = (
        [-w / 2 + 0.01, w / 2 - 0.01][:n_doors]
        if n_doors == 2
        else [(-w / 2 + 0.01) if rng.random() < 0.5 else (w / 2 - 0.01)]
    )
    opened = [True] * n_doors if rng.random() < 0.35 else [False] * n_doors
    opened[int(rng.integers(0, n_doors))] = True
    for hx, is_open in zip(hinges, opened, strict=True):
        degrees = uniform(rng, 80, 150) if is_open else 0.0
        parts += _door(hx, -d / 2 + 0.01, z0 + 0.005, h - 0.005, width, t, degrees)
    return parts


def _on_legs(rng: Rng) -> Parts:
    style = pick_style(rng, {"wardrobe": 0.35, "credenza": 0.4, "tallboy": 0.25})
    w, d, body, z0 = {
        "wardrobe": (
            uniform(rng, 0.8, 1.2),
            uniform(rng, 0.5, 0.6),
            uniform(rng, 1.3, 1.7),
            uniform(rng, 0.15, 0.3),
        ),
        "credenza": (
            uniform(rng, 1.2, 1.8),
            uniform(rng, 0.4, 0.5),
            uniform(rng, 0.45, 0.7),
            uniform(rng, 0.2, 0.4),
        ),
        "tallboy": (
            uniform(rng, 0.5, 0.8),
            uniform(rng, 0.4, 0.5),
            uniform(rng, 0.7, 1.1),
            uniform(rng, 0.15, 0.3),
        ),
    }[style]
    h = z0 + body
    legs = pick_style(rng, {"posts": 0.4, "splayed": 0.35, "hairpin": 0.25})
    parts: Parts = [box_between((-w / 2, -d / 2, z0), (w / 2, d / 2, h))]
    lw = uniform(rng, 0.035, 0.06)
    inset = uniform(rng, 0.03, 0.1)
    for sx in (-1, 1):
        for sy in (-1, 1):
            x, y = sx * (w / 2 - inset), sy * (d / 2 - inset)
            if legs == "posts":
                parts.append(centred_box((x, y, z0 / 2 + OVERLAP_M), (lw, lw, z0 + 2 * OVERLAP_M)))
            elif legs == "splayed":
                out = uniform(rng, 0.03, 0.08)
                parts.append(
                    beam_between((x + sx * out, y + sy * out, 0), (x, y, z0 + 0.02), lw / 2)
                )
            else:  # hairpin: two thin rods meeting at the foot
                for dx in (-0.05, 0.05):
                    parts.append(rod((x, y, 0.01), (x + dx, y, z0 + 0.01), 0.008, 8))
                parts.append(sphere((x, y, 0.012), 0.014, 1))
    if legs == "posts" and rng.random() < 0.5:  # a shelf between the legs
        zs = z0 * uniform(rng, 0.25, 0.45)
        parts.append(
            box_between(
                (-w / 2 + inset, -d / 2 + inset, zs), (w / 2 - inset, d / 2 - inset, zs + 0.025)
            )
        )
    return parts + _fronts(rng, w, -d / 2, z0, h)


def _hutch(rng: Rng) -> Parts:
    w, d, h1 = uniform(rng, 0.8, 1.6), uniform(rng, 0.4, 0.55), uniform(rng, 0.75, 0.95)
    parts, z0 = _base(rng, w, d, {"plinth": 0.5, "feet": 0.3, "none": 0.2})
    h1 += z0
    parts.append(box_between((-w / 2, -d / 2, z0), (w / 2, d / 2, h1)))
    o, top_t = uniform(rng, 0.01, 0.04), 0.03
    parts.append(
        box_between((-w / 2 - o, -d / 2 - o, h1 - OVERLAP_M), (w / 2 + o, d / 2 + o, h1 + top_t))
    )
    parts += _fronts(rng, w, -d / 2, z0, h1)
    # the upper unit: shallow, at the back, maybe raised on end posts over an open counter
    d2, h2 = d * uniform(rng, 0.35, 0.6), uniform(rng, 0.6, 1.1)
    t = uniform(rng, 0.02, 0.03)
    y0 = d / 2 - d2
    zb = h1 + top_t
    if rng.random() < 0.5:
        gap = uniform(rng, 0.2, 0.35)
        for sx in (-1, 1):
            parts.append(
                box_between(
                    (sx * w / 2, y0, zb - OVERLAP_M),
                    (sx * (w / 2 - 0.04), d / 2, zb + gap + OVERLAP_M),
                )
            )
        zb += gap
    if rng.random() < 0.8:  # open shelves
        shelves = _shelf_grid(
            w, d2, zb, zb + h2, t, int(rng.integers(1, 3)), int(rng.integers(2, 4)), True
        )
        parts += [p.apply_translation((0, y0 + d2 / 2, 0)) for p in shelves]
    else:  # glazed doors: a closed box with two door panels
        parts.append(box_between((-w / 2, y0, zb - OVERLAP_M), (w / 2, d / 2, zb + h2)))
        for s in (-1, 1):
            parts.append(
                box_between(
                    (s * 0.005, y0 - 0.012, zb + 0.01),
                    (s * (w / 2 - 0.01), y0 + 0.01, zb + h2 - 0.01),
                )
            )
    if rng.random() < 0.5:  # a cornice
        parts.append(
            box_between(
                (-w / 2 - 0.02, y0 - 0.02, zb + h2 - OVERLAP_M),
                (w / 2 + 0.02, d / 2 + 0.01, zb + h2 + 0.04),
            )
        )
    return parts


_BUILD = {
    "chest": _chest,
    "shelves": _shelves,
    "open_door": _open_door,
    "on_legs": _on_legs,
    "hutch": _hutch,
}


def build_cabinet(rng: Rng) -> Parts:
    return _BUILD[pick_style(rng, CABINET_KINDS)](rng)
