"""Objects to reconstruct: procedural stand-ins for the paper's 13 ShapeNet categories,
mesh normalization, mesh files, and a ShapeNetCore folder reader.

The paper (Chen et al., ICVR 2023) renders ShapeNetCore objects of 13 categories. ShapeNet
cannot be downloaded here, so :func:`make_shape` builds a recognisable object of each
category from trimesh primitives (boxes, cylinders, spheres, solids of revolution, convex
hulls) with randomized proportions and parts. Every mesh follows the project's frame:

* normalized: bounding box centred at the origin, longest side 1 (metres);
* z is up, the object's front faces -y (a chair's seat opens towards -y, a car's bonnet,
  an airplane's nose, a rifle's muzzle and a display's screen point to -y), x is left-right.
  This is ShapeNetCore v2's canonical pose (y up, front -z) turned by
  :func:`shapenet_to_zup`, so procedural and real objects line up.

Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np
import trimesh

CATEGORIES: tuple[str, ...] = (
    "airplane",
    "bench",
    "cabinet",
    "car",
    "chair",
    "display",
    "lamp",
    "speaker",
    "rifle",
    "sofa",
    "table",
    "telephone",
    "watercraft",
)
"""The paper's 13 ShapeNet categories, in the order of its results table."""

SHAPENET_SYNSETS: dict[str, str] = {
    "02691156": "airplane",
    "02828884": "bench",
    "02933112": "cabinet",
    "02958343": "car",
    "03001627": "chair",
    "03211117": "display",
    "03636649": "lamp",
    "03691459": "speaker",
    "04090263": "rifle",
    "04256520": "sofa",
    "04379243": "table",
    "04401088": "telephone",
    "04530566": "watercraft",
}
"""ShapeNetCore synset id (WordNet offset, folder name) -> category name, for the 13."""

MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")
"""File types :func:`load_mesh` reads."""

Rng = np.random.Generator
Parts = list[trimesh.Trimesh]

_EPS = 0.005  # parts that meet overlap by this much (metres), so the union joins them


# --------------------------------------------------------------------------- primitives


def _box(lo: Iterable[float], hi: Iterable[float]) -> trimesh.Trimesh:
    """Axis-aligned box between two opposite corners."""
    lo_, hi_ = np.asarray(list(lo), float), np.asarray(list(hi), float)
    return trimesh.creation.box(bounds=np.stack([np.minimum(lo_, hi_), np.maximum(lo_, hi_)]))


def _cbox(center: Iterable[float], size: Iterable[float]) -> trimesh.Trimesh:
    """Axis-aligned box from its centre and full extents."""
    c, s = np.asarray(list(center), float), np.asarray(list(size), float) / 2
    return _box(c - s, c + s)


def _rod(p0: Iterable[float], p1: Iterable[float], radius: float, sections: int = 12):
    """Cylinder of ``radius`` from point ``p0`` to point ``p1``."""
    seg = np.array([list(p0), list(p1)], float)
    return trimesh.creation.cylinder(radius=radius, segment=seg, sections=sections)


def _hull(points: Iterable[Iterable[float]]) -> trimesh.Trimesh:
    """Convex hull of a point set (a watertight, outward-facing solid)."""
    return trimesh.convex.convex_hull(np.asarray([list(p) for p in points], float))


def _beam(p0: Iterable[float], p1: Iterable[float], half: float) -> trimesh.Trimesh:
    """Square-section bar of half-width ``half`` from ``p0`` to ``p1`` (slanted legs)."""
    a, b = np.asarray(list(p0), float), np.asarray(list(p1), float)
    d = (b - a) / np.linalg.norm(b - a)
    ref = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(d, ref)
    u /= np.linalg.norm(u)
    v = np.cross(d, u)
    corners = [s * u * half + t * v * half for s in (-1, 1) for t in (-1, 1)]
    return _hull([p + c for p in (a, b) for c in corners])


def _sphere(center: Iterable[float], radius: float, subdivisions: int = 2) -> trimesh.Trimesh:
    return trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius).apply_translation(
        np.asarray(list(center), float)
    )


def _lathe(
    profile: Iterable[Iterable[float]],
    base: Iterable[float] = (0, 0, 0),
    axis: Iterable[float] = (0, 0, 1),
    sections: int = 24,
) -> trimesh.Trimesh:
    """Solid of revolution of ``(radius, height)`` points (first and last radius 0)
    around ``axis`` through ``base``."""
    mesh = trimesh.creation.revolve(
        np.asarray([list(p) for p in profile], float), sections=sections
    )
    ax = np.asarray(list(axis), float)
    if not np.allclose(ax / np.linalg.norm(ax), (0, 0, 1)):
        mesh.apply_transform(trimesh.geometry.align_vectors([0, 0, 1], ax))
    return mesh.apply_translation(np.asarray(list(base), float))


def _panel(
    root: Iterable[float],
    span: Iterable[float],
    chord_root: float,
    chord_tip: float,
    sweep: float,
    thick_root: float,
    thick_tip: float,
    chord_dir: Iterable[float] = (0, 1, 0),
) -> trimesh.Trimesh:
    """A tapered, swept, airfoil-ish slab (wing, tail, fin, sail).

    ``root`` is the leading edge at the root, ``span`` the vector to the tip's leading edge
    before sweep, ``sweep`` how far the tip's leading edge moves along ``chord_dir``.
    """
    r, s, c = (np.asarray(list(v), float) for v in (root, span, chord_dir))
    n = np.cross(s, c)
    n /= np.linalg.norm(n)
    pts = []
    for le, chord, thick in (
        (r, chord_root, thick_root),
        (r + s + c * sweep, chord_tip, thick_tip),
    ):
        for frac, t in ((0.0, 0.35), (0.3, 0.5), (1.0, 0.08)):
            for sign in (-1, 1):
                pts.append(le + c * chord * frac + n * sign * t * thick)
    return _hull(pts)


def _u(rng: Rng, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _pick(rng: Rng, options: dict[str, float]) -> str:
    names = list(options)
    p = np.asarray(list(options.values()), float)
    return names[int(rng.choice(len(names), p=p / p.sum()))]


# --------------------------------------------------------------------------- categories
# Each builder returns the parts of one object in rough metres, z up, front towards -y.


def _airplane(rng: Rng) -> Parts:
    length = 1.0
    r = _u(rng, 0.04, 0.075)
    nose = _u(rng, 0.08, 0.18)
    tail_up = _u(rng, 0.0, 0.8) * r  # upswept tail cone
    y0 = -length / 2
    fuselage = [
        (0, 0),
        (0.55 * r, nose * 0.25),
        (0.9 * r, nose * 0.7),
        (r, nose),
        (r, 0.68 * length),
        (0.45 * r, 0.97 * length),
        (0, length),
    ]
    parts = [_lathe(fuselage, (0, y0, 0), (0, 1, 0), sections=20)]
    if tail_up > 0:  # raise the rear with an upswept cone
        parts.append(
            _hull(
                [
                    (x, y, z)
                    for x in (-0.4 * r, 0.4 * r)
                    for (y, z) in (
                        (0.45 * length, 0.2 * r),
                        (0.5 * length, tail_up),
                        (0.5 * length, 0.0),
                    )
                ]
            )
        )
    kind = _pick(rng, {"airliner": 0.55, "delta": 0.2, "straight": 0.25})
    z_wing = {"low": -0.55 * r, "mid": 0.0, "high": 0.65 * r}[
        _pick(rng, {"low": 0.5, "mid": 0.2, "high": 0.3})
    ]
    if kind == "delta":
        half_span = _u(rng, 0.25, 0.38)
        chord_root = _u(rng, 0.45, 0.6)
        chord_tip = _u(rng, 0.02, 0.08)
        sweep = half_span * np.tan(np.radians(_u(rng, 45, 62)))
        y_le = _u(rng, -0.12, 0.0)
        dihedral = 0.0
    else:
        half_span = _u(rng, 0.42, 0.65) if kind == "airliner" else _u(rng, 0.5, 0.7)
        chord_root = _u(rng, 0.16, 0.26)
        taper = _u(rng, 0.25, 0.5) if kind == "airliner" else _u(rng, 0.6, 1.0)
        chord_tip = chord_root * taper
        sweep_deg = _u(rng, 22, 38) if kind == "airliner" else _u(rng, -3, 8)
        sweep = half_span * np.tan(np.radians(sweep_deg))
        y_le = _u(rng, -0.2, -0.05)
        dihedral = half_span * np.tan(np.radians(_u(rng, -2, 7)))
    t_wing = 0.1 * chord_root
    for side in (-1, 1):
        parts.append(
            _panel(
                (0, y_le, z_wing),
                (side * half_span, 0, dihedral),
                chord_root,
                chord_tip,
                sweep,
                t_wing,
                0.7 * t_wing * chord_tip / chord_root + 0.004,
            )
        )
    # engines under the wings
    n_eng = int(rng.choice([0, 2, 4], p=[0.3, 0.5, 0.2])) if kind != "delta" else 0
    spans = [0.35] if n_eng == 2 else ([0.3, 0.62] if n_eng == 4 else [])
    r_eng = _u(rng, 0.5, 0.8) * r
    for frac in spans:
        for side in (-1, 1):
            x = side * frac * half_span
            y_front = y_le + frac * sweep - 0.5 * r_eng * 2.5
            z = z_wing + frac * dihedral - r_eng * 1.3
            parts.append(_rod((x, y_front, z), (x, y_front + 5 * r_eng, z), r_eng, 16))
            parts.append(
                _cbox(
                    (x, y_front + 3 * r_eng, z + 0.8 * r_eng),
                    (0.2 * r_eng, 2.5 * r_eng, 1.2 * r_eng),
                )
            )
    # tail: vertical fin and horizontal stabilizers (conventional or T-tail)
    fin_h = _u(rng, 0.12, 0.22)
    fin_c = _u(rng, 0.12, 0.22)
    fin_sweep = fin_h * np.tan(np.radians(_u(rng, 25, 50)))
    y_fin = length / 2 - fin_c - fin_sweep * 0.7
    y_fin = min(y_fin, length / 2 - fin_c * 0.9)
    z_base = 0.3 * r + tail_up * 0.5
    parts.append(
        _panel(
            (0, y_fin, z_base),
            (0, 0, fin_h),
            fin_c,
            0.5 * fin_c,
            fin_sweep,
            0.08 * fin_c,
            0.05 * fin_c,
        )
    )
    if kind != "delta":
        t_tail = rng.random() < 0.25
        hs_span = _u(rng, 0.14, 0.24)
        hs_c = _u(rng, 0.08, 0.14)
        z_hs = z_base + fin_h * 0.95 if t_tail else 0.2 * r + tail_up * 0.6
        y_hs = y_fin + fin_sweep * 0.95 if t_tail else length / 2 - hs_c - 0.05
        for side in (-1, 1):
            parts.append(
                _panel(
                    (0, y_hs, z_hs),
                    (side * hs_span, 0, 0.02),
                    hs_c,
                    0.5 * hs_c,
                    hs_span * np.tan(np.radians(30)),
                    0.1 * hs_c,
                    0.06 * hs_c,
                )
            )
    return parts


def _bench(rng: Rng) -> Parts:
    width = _u(rng, 1.1, 1.8)
    depth = _u(rng, 0.3, 0.45)
    h = _u(rng, 0.38, 0.48)
    t = _u(rng, 0.03, 0.06)
    parts: Parts = []
    slats = int(rng.choice([1, 3, 4]))
    if slats == 1:
        parts.append(_box((-width / 2, -depth / 2, h - t), (width / 2, depth / 2, h)))
    else:
        gap = 0.012
        w = (depth - gap * (slats - 1)) / slats
        for k in range(slats):
            y = -depth / 2 + k * (w + gap)
            parts.append(_box((-width / 2, y, h - t), (width / 2, y + w, h)))
        # cross bearers under the slats
        for x in (-0.35 * width, 0.35 * width):
            parts.append(
                _box((x - 0.025, -depth / 2, h - t - 0.04), (x + 0.025, depth / 2, h - t + _EPS))
            )
    legs = _pick(rng, {"posts": 0.45, "panels": 0.35, "frame": 0.2})
    inset = _u(rng, 0.03, 0.15) * width
    lw = _u(rng, 0.035, 0.06)
    xs = (-width / 2 + inset, width / 2 - inset)
    if legs == "posts":
        for x in xs:
            for y in (-depth / 2 + lw, depth / 2 - lw):
                parts.append(
                    _box((x - lw / 2, y - lw / 2, 0), (x + lw / 2, y + lw / 2, h - t + _EPS))
                )
        if rng.random() < 0.5:  # stretcher between the back legs
            parts.append(_cbox((0, depth / 2 - lw, 0.12), (width - 2 * inset, lw * 0.7, lw * 0.7)))
    elif legs == "panels":
        pw = _u(rng, 0.04, 0.08)
        for x in xs:
            pd = depth * _u(rng, 0.8, 1.0)
            parts.append(_box((x - pw / 2, -pd / 2, 0), (x + pw / 2, pd / 2, h - t + _EPS)))
    else:  # A-frames
        for x in xs:
            for sy in (-1, 1):
                parts.append(
                    _beam((x, sy * depth * 0.55, 0), (x, sy * depth * 0.15, h - t / 2), lw / 2)
                )
            parts.append(_cbox((x, 0, 0.15), (lw, depth, lw)))
    if rng.random() < 0.6:  # backrest
        back_h = _u(rng, 0.25, 0.42)
        tilt = _u(rng, 0.0, 0.12)
        y_back = depth / 2 - 0.03
        if rng.random() < 0.5:
            parts.append(
                _hull(
                    [
                        (x, y_back + dy, z)
                        for x in (-width / 2, width / 2)
                        for (dy, z) in (
                            (0, h - t),
                            (0.03, h - t),
                            (tilt, h + back_h),
                            (tilt + 0.03, h + back_h),
                        )
                    ]
                )
            )
        else:
            for x in xs:
                parts.append(_beam((x, y_back, h - t), (x, y_back + tilt, h + back_h), lw / 2))
            n_rails = int(rng.integers(2, 4))
            for k in range(n_rails):
                f = (k + 1) / n_rails
                parts.append(
                    _cbox(
                        (0, y_back + tilt * f, h + back_h * f - 0.04),
                        (width, 0.03, back_h / (n_rails + 1.5)),
                    )
                )
        if rng.random() < 0.5:  # arm rests
            arm_z = h + _u(rng, 0.18, 0.25)
            for x in (-width / 2 + 0.03, width / 2 - 0.03):
                parts.append(_cbox((x, 0.0, arm_z), (0.05, depth + 0.04, 0.04)))
                parts.append(
                    _cbox((x, -depth / 2 + 0.03, (arm_z + h) / 2), (0.04, 0.04, arm_z - h + 0.04))
                )
    return parts


def _cabinet(rng: Rng) -> Parts:
    kind = _pick(rng, {"tall": 0.3, "sideboard": 0.3, "nightstand": 0.2, "bookcase": 0.2})
    w, d, h = {
        "tall": (_u(rng, 0.5, 1.1), _u(rng, 0.4, 0.6), _u(rng, 1.4, 2.0)),
        "sideboard": (_u(rng, 1.0, 1.8), _u(rng, 0.4, 0.55), _u(rng, 0.6, 0.95)),
        "nightstand": (_u(rng, 0.4, 0.6), _u(rng, 0.35, 0.5), _u(rng, 0.45, 0.7)),
        "bookcase": (_u(rng, 0.6, 1.2), _u(rng, 0.25, 0.4), _u(rng, 0.9, 2.0)),
    }[kind]
    base = _pick(rng, {"legs": 0.4, "plinth": 0.35, "none": 0.25})
    z0 = {"legs": _u(rng, 0.08, 0.2), "plinth": _u(rng, 0.05, 0.1), "none": 0.0}[base]
    parts: Parts = []
    if base == "legs":
        lw = 0.04
        for sx in (-1, 1):
            for sy in (-1, 1):
                parts.append(
                    _cbox((sx * (w / 2 - lw), sy * (d / 2 - lw), z0 / 2), (lw, lw, z0 + 2 * _EPS))
                )
    elif base == "plinth":
        parts.append(_box((-w / 2 + 0.03, -d / 2 + 0.04, 0), (w / 2 - 0.03, d / 2, z0 + _EPS)))
    if kind == "bookcase":
        t = 0.025
        parts.append(_box((-w / 2, -d / 2, z0), (-w / 2 + t, d / 2, h)))
        parts.append(_box((w / 2 - t, -d / 2, z0), (w / 2, d / 2, h)))
        parts.append(_box((-w / 2, d / 2 - t, z0), (w / 2, d / 2, h)))
        n_shelves = int(rng.integers(2, 6))
        for k in range(n_shelves + 2):
            z = z0 + (h - z0 - t) * k / (n_shelves + 1)
            parts.append(_box((-w / 2, -d / 2, z), (w / 2, d / 2, z + t)))
        if rng.random() < 0.4:  # doors on the lower part
            z_top = z0 + (h - z0 - t) / (n_shelves + 1) + t
            # a closed cupboard: fill it, so the mesh has no inner cavity
            parts.append(_box((-w / 2, -d / 2 - 0.015, z0), (w / 2, d / 2, z_top)))
        return parts
    parts.append(_box((-w / 2, -d / 2, z0), (w / 2, d / 2, h)))
    if rng.random() < 0.5:  # top with an overhang
        o = _u(rng, 0.01, 0.04)
        parts.append(_box((-w / 2 - o, -d / 2 - o, h - _EPS), (w / 2 + o, d / 2 + o, h + 0.03)))
    fy = -d / 2  # front face
    front = _pick(rng, {"doors": 0.45, "drawers": 0.3, "mixed": 0.25})
    n_cols = int(rng.integers(1, 4)) if w > 0.8 else int(rng.integers(1, 3))
    gap = 0.01
    z_split = (
        h
        if front == "doors"
        else (z0 if front == "drawers" else z0 + (h - z0) * _u(rng, 0.55, 0.75))
    )
    handle_r = 0.008
    if z_split > z0 + 0.05:  # doors from z0 to z_split
        cw = w / n_cols
        for k in range(n_cols):
            x0, x1 = -w / 2 + k * cw + gap, -w / 2 + (k + 1) * cw - gap
            parts.append(_box((x0, fy - 0.015, z0 + gap), (x1, fy + 0.01, z_split - gap)))
            hx = x1 - 0.04 if k % 2 == 0 else x0 + 0.04
            zc = z0 + (z_split - z0) * 0.6
            hl = min(0.15, (z_split - z0) * 0.25)
            parts.append(
                _rod((hx, fy - 0.035, zc - hl / 2), (hx, fy - 0.035, zc + hl / 2), handle_r, 8)
            )
            parts.append(_cbox((hx, fy - 0.025, zc), (0.012, 0.03, 0.012)))
    if z_split < h - 0.05:  # drawers from z_split to h
        n_rows = max(1, int(round((h - z_split) / _u(rng, 0.15, 0.3))))
        rh = (h - z_split) / n_rows
        for k in range(n_rows):
            z_lo, z_hi = z_split + k * rh + gap, z_split + (k + 1) * rh - gap
            parts.append(_box((-w / 2 + gap, fy - 0.015, z_lo), (w / 2 - gap, fy + 0.01, z_hi)))
            zc = (z_lo + z_hi) / 2
            hl = min(0.25, w * 0.3)
            parts.append(_rod((-hl / 2, fy - 0.035, zc), (hl / 2, fy - 0.035, zc), handle_r, 8))
            parts.append(_cbox((0, fy - 0.025, zc), (0.012, 0.03, 0.012)))
    return parts


def _car(rng: Rng) -> Parts:
    kind = _pick(rng, {"sedan": 0.3, "hatchback": 0.2, "suv": 0.2, "pickup": 0.15, "sports": 0.15})
    length = 1.0
    y_f, y_r = -length / 2, length / 2
    w = _u(rng, 0.38, 0.46)
    rw = {"suv": _u(rng, 0.085, 0.11), "pickup": _u(rng, 0.085, 0.11)}.get(
        kind, _u(rng, 0.07, 0.09)
    )
    clear = rw * _u(rng, 0.55, 0.85)
    belt = clear + {
        "suv": _u(rng, 0.17, 0.22),
        "pickup": _u(rng, 0.16, 0.2),
        "sports": _u(rng, 0.1, 0.13),
    }.get(kind, _u(rng, 0.13, 0.17))
    roof = belt + {
        "suv": _u(rng, 0.14, 0.19),
        "pickup": _u(rng, 0.13, 0.17),
        "sports": _u(rng, 0.07, 0.1),
    }.get(kind, _u(rng, 0.1, 0.14))
    nose_drop = _u(rng, 0.02, 0.06)
    hw = w / 2
    parts: Parts = []
    # lower body: side profile extruded across the width, slightly narrower at the top
    profile_lo = [
        (y_f + 0.01, clear + 0.01),
        (y_f, clear + 0.06),
        (y_f + 0.04, belt - nose_drop),
        (y_f + 0.22, belt),
        (y_r - 0.04, belt),
        (y_r, belt - 0.03),
        (y_r, clear + 0.02),
        (y_r - 0.02, clear),
    ]
    parts.append(
        _hull(
            [
                (s * hw * (0.93 if z > belt - 0.02 else 1.0), y, z)
                for (y, z) in profile_lo
                for s in (-1, 1)
            ]
        )
    )
    # cabin (greenhouse)
    cab = {
        "sedan": (_u(rng, -0.22, -0.12), _u(rng, 0.18, 0.3)),
        "hatchback": (_u(rng, -0.18, -0.08), y_r - 0.04),
        "suv": (_u(rng, -0.22, -0.14), y_r - 0.02),
        "pickup": (_u(rng, -0.22, -0.14), _u(rng, 0.0, 0.08)),
        "sports": (_u(rng, -0.15, -0.05), _u(rng, 0.15, 0.3)),
    }[kind]
    ws_rake = {"suv": 0.12, "pickup": 0.1, "sports": 0.25}.get(kind, 0.18) * _u(rng, 0.8, 1.2)
    rear_rake = {"sedan": 0.17, "sports": 0.2}.get(kind, 0.04) * _u(rng, 0.7, 1.3)
    if kind == "pickup":
        rear_rake = 0.01
    yb0, yb1 = cab
    top0, top1 = yb0 + ws_rake, max(yb0 + ws_rake + 0.1, yb1 - rear_rake)
    cw = hw * _u(rng, 0.8, 0.9)
    parts.append(
        _hull(
            [
                (s * ww, y, z)
                for s in (-1, 1)
                for (ww, y, z) in (
                    (hw * 0.93, yb0, belt - 0.01),
                    (hw * 0.93, yb1, belt - 0.01),
                    (cw, top0, roof),
                    (cw, top1, roof),
                )
            ]
        )
    )
    if kind == "pickup":  # open bed: side walls and tailgate
        bed_h = _u(rng, 0.06, 0.1)
        for s in (-1, 1):
            parts.append(
                _box(
                    (s * hw * 0.93, yb1 + 0.01, belt - 0.01),
                    (s * (hw * 0.93 - 0.025), y_r - 0.01, belt + bed_h),
                )
            )
        parts.append(
            _box((-hw * 0.93, y_r - 0.035, belt - 0.01), (hw * 0.93, y_r - 0.01, belt + bed_h))
        )
    if kind == "sports" and rng.random() < 0.6:  # rear wing
        z_w = belt + _u(rng, 0.04, 0.08)
        parts.append(_cbox((0, y_r - 0.05, z_w), (w * 0.9, 0.07, 0.012)))
        for s in (-1, 1):
            parts.append(
                _cbox((s * w * 0.3, y_r - 0.05, (z_w + belt) / 2), (0.015, 0.04, z_w - belt + 0.01))
            )
    # wheels
    wheelbase = _u(rng, 0.56, 0.66)
    y_shift = _u(rng, -0.03, 0.03)
    tw = _u(rng, 0.055, 0.08)
    for y in (-wheelbase / 2 + y_shift, wheelbase / 2 + y_shift):
        for s in (-1, 1):
            parts.append(_rod((s * (hw - tw + 0.012), y, rw), (s * (hw + 0.012), y, rw), rw, 20))
    return parts


def _chair(rng: Rng) -> Parts:
    w = _u(rng, 0.4, 0.56)
    d = _u(rng, 0.4, 0.55)
    h = _u(rng, 0.4, 0.5)
    t = _u(rng, 0.03, 0.08)
    parts: Parts = []
    round_seat = rng.random() < 0.15
    if round_seat:
        parts.append(_rod((0, 0, h - t), (0, 0, h), max(w, d) / 2, 24))
    else:
        parts.append(_box((-w / 2, -d / 2, h - t), (w / 2, d / 2, h)))
    legs = _pick(
        rng,
        {
            "four": 0.5,
            "pedestal": 0.2,
            "sled": 0.0 if round_seat else 0.15,
            "panel": 0.0 if round_seat else 0.15,
        },
    )
    lw = _u(rng, 0.025, 0.05)
    splay = _u(rng, 0.0, 0.06) if rng.random() < 0.4 else 0.0
    if legs == "four":
        round_legs = rng.random() < 0.4
        leg_x, leg_y = (w / 2 - lw, d / 2 - lw) if not round_seat else (0.3 * w, 0.3 * d)
        for sx in (-1, 1):
            for sy in (-1, 1):
                top = (sx * leg_x, sy * leg_y, h - t / 2)
                bot = (sx * (leg_x + splay), sy * (leg_y + splay), 0)
                parts.append(_rod(bot, top, lw / 2, 10) if round_legs else _beam(bot, top, lw / 2))
        if rng.random() < 0.35:  # stretchers
            zs = _u(rng, 0.1, 0.2)
            out = splay * (1 - zs / (h - t / 2))  # how far the splayed legs lean out at zs
            for sx in (-1, 1):
                parts.append(
                    _cbox((sx * (leg_x + out), 0, zs), (lw * 0.6, 2 * (leg_y + out), lw * 0.6))
                )
    elif legs == "pedestal":
        col_h = h - t / 2
        parts.append(_rod((0, 0, 0.06), (0, 0, col_h), _u(rng, 0.02, 0.035), 14))
        n_spokes = 5
        reach = _u(rng, 0.25, 0.33)
        a0 = _u(rng, 0, 2 * np.pi / n_spokes)
        for k in range(n_spokes):
            a = a0 + 2 * np.pi * k / n_spokes
            end = (reach * np.cos(a), reach * np.sin(a), 0.04)
            parts.append(_beam((0, 0, 0.06), end, 0.018))
            parts.append(_sphere((end[0], end[1], 0.025), 0.025, 1))
        parts.append(_box((-0.09, -0.09, h - t - 0.04), (0.09, 0.09, h - t + _EPS)))
    elif legs == "sled":
        for sx in (-1, 1):
            x = sx * (w / 2 - 0.02)
            r = 0.012
            parts.append(_rod((x, -d / 2, 0.012), (x, d / 2, 0.012), r, 8))
            parts.append(_rod((x, -d / 2 + 0.02, 0.012), (x, -d / 2 + 0.04, h - t / 2), r, 8))
            parts.append(_rod((x, d / 2 - 0.02, 0.012), (x, d / 2 - 0.06, h - t / 2), r, 8))
    else:  # solid side panels
        pt = _u(rng, 0.03, 0.05)
        for sx in (-1, 1):
            parts.append(
                _box(
                    (sx * w / 2, -d / 2 + 0.02, 0), (sx * (w / 2 - pt), d / 2 - 0.02, h - t + _EPS)
                )
            )
    # back
    back = _pick(
        rng,
        {
            "panel": 0.45,
            "slats": 0.0 if round_seat else 0.2,
            "rails": 0.0 if round_seat else 0.2,
            "low": 0.15,
        },
    )
    bh = _u(rng, 0.12, 0.2) if back == "low" else _u(rng, 0.35, 0.6)
    tilt = _u(rng, 0.0, 0.12)
    bt = _u(rng, 0.025, 0.06)
    yb = d / 2 - bt
    z0 = h
    if back in ("panel", "low"):
        bw = w * (_u(rng, 0.85, 1.0) if not round_seat else _u(rng, 0.5, 0.7))
        rounded = rng.random() < 0.3
        top_w = bw * (_u(rng, 0.55, 0.8) if rounded else 1.0)
        parts.append(
            _hull(
                [
                    (s * ww, yb + dy, z)
                    for s in (-1, 1)
                    for (ww, dy, z) in (
                        (bw / 2, 0, z0 - t),
                        (bw / 2, bt, z0 - t),
                        (bw / 2, tilt * 0.8, z0 + bh * 0.8),
                        (bw / 2, tilt * 0.8 + bt, z0 + bh * 0.8),
                        (top_w / 2, tilt, z0 + bh),
                        (top_w / 2, tilt + bt, z0 + bh),
                    )
                ]
            )
        )
    else:
        pw = max(lw, 0.03)
        for sx in (-1, 1):
            parts.append(
                _beam(
                    (sx * (w / 2 - pw / 2), yb + bt / 2, z0 - t),
                    (sx * (w / 2 - pw / 2), yb + bt / 2 + tilt, z0 + bh),
                    pw / 2,
                )
            )
        top_h = _u(rng, 0.05, 0.12)
        parts.append(_box((-w / 2, yb + tilt, z0 + bh - top_h), (w / 2, yb + tilt + bt, z0 + bh)))
        if back == "slats":
            n = int(rng.integers(2, 6))
            for k in range(n):
                x = -w / 2 + pw + (w - 2 * pw) * (k + 0.5) / n
                parts.append(
                    _beam(
                        (x, yb + bt / 2, z0 - t / 2),
                        (x, yb + bt / 2 + tilt * (1 - top_h / bh), z0 + bh - top_h / 2),
                        0.012,
                    )
                )
        else:
            n = int(rng.integers(1, 3))
            for k in range(n):
                f = (k + 1) / (n + 1)
                z = z0 + (bh - top_h) * f
                parts.append(
                    _box(
                        (-w / 2, yb + tilt * f, z - 0.025),
                        (w / 2, yb + tilt * f + bt * 0.7, z + 0.025),
                    )
                )
    if rng.random() < 0.35 and not round_seat:  # arms
        za = h + _u(rng, 0.18, 0.26)
        for sx in (-1, 1):
            x = sx * (w / 2 + 0.005)
            parts.append(_box((x - 0.025, -d / 2 + 0.02, za - 0.03), (x + 0.025, d / 2, za)))
            parts.append(_box((x - 0.015, -d / 2 + 0.04, h - t), (x + 0.015, -d / 2 + 0.08, za)))
            parts.append(_box((x - 0.015, d / 2 - 0.06, h - t), (x + 0.015, d / 2 - 0.02, za)))
    return parts


def _display(rng: Rng) -> Parts:
    aspect = float(rng.choice([16 / 9, 16 / 10, 4 / 3, 21 / 9]))
    kind = _pick(rng, {"monitor": 0.45, "tv": 0.3, "crt": 0.15, "imac": 0.1})
    w = _u(rng, 0.6, 1.0)
    h = w / aspect
    t = _u(rng, 0.015, 0.04)
    parts: Parts = []
    z0 = {"tv": _u(rng, 0.03, 0.1), "imac": h * 0.18 + _u(rng, 0.06, 0.15)}.get(
        kind, _u(rng, 0.08, 0.22)
    )
    if kind == "crt":
        w = h * _u(rng, 1.15, 1.35)
        depth = h * _u(rng, 0.8, 1.05)
        back_w, back_h = w * _u(rng, 0.4, 0.55), h * _u(rng, 0.4, 0.55)
        front = 0.06
        parts.append(_box((-w / 2, 0, z0), (w / 2, front, z0 + h)))
        parts.append(_box((-w / 2 + 0.04, -0.008, z0 + 0.04), (w / 2 - 0.04, 0.001, z0 + h - 0.04)))
        parts.append(
            _hull(
                [
                    (s * w * 0.45, front - 0.01, z0 + h / 2 + u * h * 0.45)
                    for s in (-1, 1)
                    for u in (-1, 1)
                ]
                + [
                    (s * back_w / 2, depth, z0 + h * 0.55 + u * back_h / 2)
                    for s in (-1, 1)
                    for u in (-1, 1)
                ]
            )
        )
        parts.append(_box((-w * 0.3, 0.0, 0), (w * 0.3, depth * 0.5, z0 + _EPS)))
        return parts
    # front panel and a thin screen plate inside its bezel (an iMac-style panel has a chin)
    chin = h * 0.18 if kind == "imac" else 0.0
    parts.append(_box((-w / 2, 0, z0 - chin), (w / 2, t, z0 + h)))
    bezel = _u(rng, 0.01, 0.04)
    parts.append(_box((-w / 2 + bezel, -0.004, z0 + bezel), (w / 2 - bezel, 0.001, z0 + h - bezel)))
    z0 -= chin
    if rng.random() < 0.5:  # electronics box at the back
        parts.append(
            _box(
                (-w * 0.3, t - _EPS, z0 + h * 0.25),
                (w * 0.3, t + _u(rng, 0.03, 0.08), z0 + h * 0.75),
            )
        )
    base_d = _u(rng, 0.15, 0.3)
    stand = _pick(rng, {"neck": 0.6, "feet": 0.25 if kind == "tv" else 0.05, "arm": 0.15})
    if stand == "feet":
        for s in (-1, 1):
            x = s * w * _u(rng, 0.3, 0.42)
            parts.append(_beam((x, -base_d * 0.4, 0.01), (x, t / 2, z0 + 0.02), 0.012))
            parts.append(_beam((x, base_d * 0.4, 0.01), (x, t / 2, z0 + 0.02), 0.012))
        return parts
    neck_w = _u(rng, 0.04, 0.12)
    y_neck = t + 0.02
    top = z0 + h * _u(rng, 0.3, 0.6)
    if stand == "arm":  # L-shaped arm from the back of the base
        parts.append(_box((-neck_w / 2, y_neck, 0), (neck_w / 2, y_neck + 0.025, top)))
        parts.append(_box((-neck_w / 2, t - _EPS, top - 0.04), (neck_w / 2, y_neck + 0.025, top)))
    else:
        if kind == "imac":
            parts.append(
                _hull(
                    [
                        (s * neck_w, y, z)
                        for s in (-1, 1)
                        for (y, z) in (
                            (t - _EPS, top),
                            (t + 0.015, top),
                            (base_d * 0.4, 0.01),
                            (base_d * 0.4 + 0.015, 0.01),
                        )
                    ]
                )
            )
        else:
            parts.append(_box((-neck_w / 2, t - _EPS, 0), (neck_w / 2, t + 0.025, top)))
    if rng.random() < 0.5:
        parts.append(_rod((0, t, 0), (0, t, 0.012), base_d / 2, 24))
    else:
        bw = _u(rng, 0.2, 0.45) * w
        parts.append(_box((-bw / 2, t - base_d / 2, 0), (bw / 2, t + base_d / 2, 0.015)))
    return parts


def _lamp(rng: Rng) -> Parts:
    kind = _pick(rng, {"table": 0.35, "floor": 0.25, "desk": 0.25, "pendant": 0.15})
    parts: Parts = []
    sec = 24
    # base
    if kind != "pendant":
        base = _pick(
            rng,
            {"disc": 0.5, "square": 0.2, "dome": 0.2, "tripod": 0.1 if kind == "floor" else 0.0},
        )
        br = _u(rng, 0.08, 0.16) if kind != "floor" else _u(rng, 0.14, 0.22)
        bh = _u(rng, 0.015, 0.04)
        if base == "disc":
            parts.append(_rod((0, 0, 0), (0, 0, bh), br, sec))
        elif base == "square":
            parts.append(_cbox((0, 0, bh / 2), (1.6 * br, 1.6 * br, bh)))
        elif base == "dome":
            bh *= 2
            parts.append(
                _lathe(
                    [(0, 0), (br, 0), (br * 0.8, bh * 0.6), (br * 0.25, bh), (0, bh)], sections=sec
                )
            )
        else:
            bh = _u(rng, 0.2, 0.35)
            for k in range(3):
                a = 2 * np.pi * k / 3 + np.pi / 2
                parts.append(_rod((br * np.cos(a), br * np.sin(a), 0), (0, 0, bh), 0.01, 8))
    if kind in ("table", "floor"):
        height = _u(rng, 0.35, 0.6) if kind == "table" else _u(rng, 1.2, 1.8)
        if kind == "table" and rng.random() < 0.45:  # vase-shaped body
            vr = _u(rng, 0.06, 0.12)
            vh = height * _u(rng, 0.4, 0.6)
            parts.append(
                _lathe(
                    [
                        (0, 0),
                        (vr * 0.6, 0),
                        (vr, vh * 0.35),
                        (vr * 0.9, vh * 0.7),
                        (vr * 0.3, vh),
                        (0, vh),
                    ],
                    (0, 0, bh),
                    sections=sec,
                )
            )
        parts.append(_rod((0, 0, 0), (0, 0, height), _u(rng, 0.008, 0.018), 10))
        z_top = height
    elif kind == "desk":
        l1 = _u(rng, 0.25, 0.4)
        l2 = _u(rng, 0.25, 0.4)
        a1 = np.radians(_u(rng, 60, 85))
        a2 = np.radians(_u(rng, -20, 25))
        p0 = np.array([0, 0.04, bh])
        p1 = p0 + l1 * np.array([0, np.cos(a1), np.sin(a1)])
        p2 = p1 + l2 * np.array([0, -np.cos(a2), np.sin(a2)])
        for a, b in ((p0, p1), (p1, p2)):
            for sx in (-0.012, 0.012):
                parts.append(_rod(a + (sx, 0, 0), b + (sx, 0, 0), 0.007, 8))
        parts.append(_sphere(p1, 0.02, 1))
        parts.append(_sphere(p0, 0.022, 1))
        # shade: a cone opening downwards and forwards
        sr = _u(rng, 0.06, 0.1)
        sl = _u(rng, 0.08, 0.16)
        axis = np.array([0, -np.sin(np.radians(30)), -np.cos(np.radians(30))])
        parts.append(_lathe([(0, 0), (0.025, 0), (sr, sl), (0, sl)], p2 - axis * 0.02, axis, sec))
        return parts
    else:  # pendant: canopy at the top, cord, shade below
        height = _u(rng, 0.8, 1.3)
        parts.append(_rod((0, 0, height - 0.03), (0, 0, height), 0.06, sec))
        z_top = height * _u(rng, 0.35, 0.6)
        parts.append(_rod((0, 0, z_top - 0.02), (0, 0, height), 0.006, 8))
    # shade (hangs from or sits on z_top)
    shades = {"frustum": 0.45, "drum": 0.2, "globe": 0.12, "dome": 0.23}
    if kind == "floor":
        shades = {"frustum": 0.55, "drum": 0.25, "globe": 0.08, "dome": 0.12}
    shade = _pick(rng, shades)
    sr = _u(rng, 0.12, 0.25) if kind != "table" else _u(rng, 0.1, 0.2)
    sh = _u(rng, 0.12, 0.3) if kind != "table" else _u(rng, 0.1, 0.22)
    if kind == "table" or kind == "floor":
        z_shade = z_top - sh * 0.7
    else:
        z_shade = z_top - sh
    if shade == "frustum":
        top_r = sr * _u(rng, 0.4, 0.75)
        parts.append(_lathe([(0, 0), (sr, 0), (top_r, sh), (0, sh)], (0, 0, z_shade), sections=sec))
    elif shade == "drum":
        parts.append(_rod((0, 0, z_shade), (0, 0, z_shade + sh), sr * 0.85, sec))
    elif shade == "globe":
        r = {"table": _u(rng, 0.07, 0.12), "floor": _u(rng, 0.13, 0.2)}.get(
            kind, _u(rng, 0.08, 0.15)
        )
        parts.append(
            _sphere((0, 0, z_top + r * (0.3 if kind == "pendant" else -0.3) - r * 0.5), r, 2)
        )
    else:
        n = 6
        prof = [(0, 0)] + [(sr * np.cos(a), sh * np.sin(a)) for a in np.linspace(0, np.pi / 2, n)]
        parts.append(_lathe(prof, (0, 0, z_shade), sections=sec))
    return parts


def _speaker(rng: Rng) -> Parts:
    kind = _pick(rng, {"bookshelf": 0.3, "tower": 0.3, "sub": 0.15, "bar": 0.1, "round": 0.15})
    parts: Parts = []
    if kind == "round":
        r = _u(rng, 0.06, 0.1)
        h = _u(rng, 0.15, 0.35)
        top_r = r * _u(rng, 0.6, 1.0)
        parts.append(
            _lathe([(0, 0), (r * 0.9, 0), (r, 0.02), (r, h * 0.8), (top_r, h), (0, h)], sections=28)
        )
        parts.append(_rod((0, 0, h - _EPS), (0, 0, h + 0.005), top_r * 0.7, 28))
        return parts
    w, d, h = {
        "bookshelf": (_u(rng, 0.16, 0.25), _u(rng, 0.18, 0.3), _u(rng, 0.26, 0.4)),
        "tower": (_u(rng, 0.18, 0.26), _u(rng, 0.22, 0.35), _u(rng, 0.8, 1.1)),
        "sub": (_u(rng, 0.3, 0.45), _u(rng, 0.3, 0.45), _u(rng, 0.3, 0.45)),
        "bar": (_u(rng, 0.8, 1.1), _u(rng, 0.08, 0.13), _u(rng, 0.06, 0.1)),
    }[kind]
    z0 = 0.0
    if kind == "tower" and rng.random() < 0.6:  # plinth/feet
        z0 = _u(rng, 0.02, 0.05)
        parts.append(
            _box((-w / 2 - 0.02, -d / 2 - 0.02, 0), (w / 2 + 0.02, d / 2 + 0.02, z0 + _EPS))
        )
    elif kind == "bookshelf" and rng.random() < 0.35:  # on a stand
        z0 = _u(rng, 0.5, 0.7)
        parts.append(_rod((0, 0, 0.01), (0, 0, z0 + _EPS), 0.025, 10))
        parts.append(_cbox((0, 0, 0.01), (w * 1.3, d * 1.2, 0.02)))
        parts.append(_cbox((0, 0, z0 - 0.01), (w * 0.9, d * 0.9, 0.02)))
    slant = _u(rng, 0.0, 0.3) * d if rng.random() < 0.4 and kind != "bar" else 0.0
    bevel = _u(rng, 0.0, 0.02)
    parts.append(
        _hull(
            [
                (x, y, z)
                for x in (-w / 2, w / 2)
                for (y, z) in (
                    (-d / 2, z0 + bevel),
                    (-d / 2, z0 + h - bevel),
                    (-d / 2 + bevel, z0 + h),
                    (-d / 2 + bevel, z0),
                    (d / 2, z0),
                    (d / 2 - slant, z0 + h),
                )
            ]
        )
    )
    fy = -d / 2
    if kind == "bar":
        n = int(rng.integers(2, 5))
        for k in range(n):
            x = -w / 2 + w * (k + 0.5) / n
            parts.append(_rod((x, fy - 0.006, z0 + h / 2), (x, fy + 0.01, z0 + h / 2), h * 0.3, 20))
        return parts
    # drivers on the front, stacked vertically
    woofer = w * _u(rng, 0.3, 0.42)
    n_woofers = {"tower": int(rng.integers(1, 4)), "sub": 1}.get(kind, 1)
    tweeter = w * _u(rng, 0.1, 0.16)
    zs = []
    top_margin = h * 0.12
    z = z0 + h - top_margin - tweeter
    if kind != "sub":
        zs.append((z, tweeter))
        z -= tweeter + woofer * 1.15
    for _ in range(n_woofers):
        zs.append((z, woofer))
        z -= woofer * 2.3
    if kind == "sub":
        zs = [(z0 + h / 2, min(w, h) * _u(rng, 0.3, 0.4))]
    for zc, r in zs:
        if zc - r < z0:
            continue
        parts.append(_rod((0, fy - 0.012, zc), (0, fy + 0.01, zc), r, 24))
        parts.append(_sphere((0, fy - 0.012, zc), r * 0.35, 1))
    return parts


def _rifle(rng: Rng) -> Parts:
    # muzzle towards -y, butt towards +y
    parts: Parts = []
    kind = _pick(rng, {"sniper": 0.3, "assault": 0.4, "shotgun": 0.3})
    rec_len = _u(rng, 0.18, 0.28)
    rec_h = _u(rng, 0.05, 0.08)
    rec_w = _u(rng, 0.03, 0.045)
    barrel = {
        "sniper": _u(rng, 0.4, 0.55),
        "assault": _u(rng, 0.25, 0.4),
        "shotgun": _u(rng, 0.35, 0.5),
    }[kind]
    br = {"shotgun": _u(rng, 0.012, 0.018)}.get(kind, _u(rng, 0.007, 0.012))
    y_rec0 = 0.0  # receiver front
    zc = 0.0  # bore height
    parts.append(
        _box(
            (-rec_w / 2, y_rec0, zc - rec_h * 0.6), (rec_w / 2, y_rec0 + rec_len, zc + rec_h * 0.4)
        )
    )
    parts.append(_rod((0, y_rec0 - barrel, zc), (0, y_rec0 + 0.01, zc), br, 12))
    if rng.random() < 0.5:  # muzzle device
        parts.append(
            _rod((0, y_rec0 - barrel - 0.03, zc), (0, y_rec0 - barrel + 0.01, zc), br * 1.5, 12)
        )
    # fore-end / handguard
    hg = barrel * _u(rng, 0.35, 0.6)
    if kind == "shotgun":
        parts.append(
            _rod(
                (0, y_rec0 - barrel * 0.9, zc - br * 1.8),
                (0, y_rec0 + 0.02, zc - br * 1.8),
                br * 0.9,
                12,
            )
        )
        parts.append(
            _rod(
                (0, y_rec0 - hg - 0.05, zc - br * 2), (0, y_rec0 - 0.08, zc - br * 2), br * 1.8, 12
            )
        )
    else:
        hr = _u(rng, 0.016, 0.026)
        parts.append(_box((-hr, y_rec0 - hg, zc - hr * 1.3), (hr, y_rec0 + 0.01, zc + hr * 0.8)))
    # stock: butt drops below the bore line
    y_s0 = y_rec0 + rec_len
    s_len = _u(rng, 0.22, 0.32)
    drop = _u(rng, 0.02, 0.07)
    butt_h = _u(rng, 0.1, 0.15)
    sw = rec_w * 0.9
    grip_style = _pick(rng, {"pistol": 0.55, "straight": 0.45})
    stock_kind = _pick(rng, {"solid": 0.7, "skeleton": 0.3 if kind == "assault" else 0.05})
    top0 = zc + rec_h * 0.3
    if stock_kind == "solid":
        neck_h = rec_h * (0.9 if grip_style == "pistol" else 1.4)
        parts.append(
            _hull(
                [
                    (s * sw / 2, y, z)
                    for s in (-1, 1)
                    for (y, z) in (
                        (y_s0 - 0.01, top0),
                        (y_s0 - 0.01, top0 - neck_h),
                        (y_s0 + s_len, top0 - drop),
                        (y_s0 + s_len, top0 - drop - butt_h),
                        (y_s0 + s_len * 0.45, top0 - drop * 0.5 - butt_h * 0.8),
                    )
                ]
            )
        )
    else:
        r = 0.008
        a = np.array([0, y_s0 - 0.01, top0 - 0.01])
        b = np.array([0, y_s0 + s_len, top0 - drop])
        c = np.array([0, y_s0 + s_len, top0 - drop - butt_h])
        e = np.array([0, y_s0 - 0.01, top0 - rec_h * 0.9])
        for p, q in ((a, b), (e, c), (b, c)):
            parts.append(_rod(p, q, r, 8))
        parts.append(
            _box(
                (-sw / 2, y_s0 + s_len - 0.02, top0 - drop - butt_h),
                (sw / 2, y_s0 + s_len, top0 - drop),
            )
        )
    if grip_style == "pistol":
        g0 = np.array([0, y_s0 - 0.05, zc - rec_h * 0.5])
        g1 = g0 + np.array([0, _u(rng, 0.03, 0.05), -_u(rng, 0.08, 0.11)])
        parts.append(_beam(g0, g1, 0.015))
    # trigger guard: a bar under the receiver held by two posts
    zg = zc - rec_h * 0.6
    parts.append(_box((-0.004, y_s0 - 0.11, zg - 0.03), (0.004, y_s0 - 0.06, zg - 0.022)))
    for yg in (y_s0 - 0.11, y_s0 - 0.068):
        parts.append(_box((-0.004, yg, zg - 0.03), (0.004, yg + 0.008, zg + _EPS)))
    if kind != "shotgun" and rng.random() < 0.75:  # magazine
        m_len = _u(rng, 0.04, 0.06)
        m_h = _u(rng, 0.06, 0.14)
        curve = _u(rng, 0.0, 0.05)
        ym = y_rec0 + rec_len * 0.25
        parts.append(
            _hull(
                [
                    (s * rec_w * 0.4, y, z)
                    for s in (-1, 1)
                    for (y, z) in (
                        (ym, zc - rec_h * 0.5),
                        (ym + m_len, zc - rec_h * 0.5),
                        (ym - curve, zc - rec_h * 0.5 - m_h),
                        (ym + m_len - curve, zc - rec_h * 0.5 - m_h),
                    )
                ]
            )
        )
    if rng.random() < (0.85 if kind == "sniper" else 0.3):  # scope
        sr = _u(rng, 0.014, 0.022)
        s_l = _u(rng, 0.18, 0.3)
        zsc = zc + rec_h * 0.4 + sr + _u(rng, 0.015, 0.03)
        ys = y_rec0 + rec_len / 2 - s_l / 2
        parts.append(_rod((0, ys, zsc), (0, ys + s_l, zsc), sr, 14))
        parts.append(
            _lathe(
                [(0, 0), (sr * 1.6, 0), (sr * 1.6, 0.04), (sr, 0.07), (0, 0.07)],
                (0, ys, zsc),
                (0, 1, 0),
                14,
            )
        )
        for f in (0.3, 0.7):
            y = ys + s_l * f
            parts.append(_box((-0.006, y - 0.01, zc + rec_h * 0.35), (0.006, y + 0.01, zsc)))
    elif kind != "shotgun":  # iron sights / carry handle
        parts.append(_box((-0.005, y_rec0 - hg, zc), (0.005, y_rec0 - hg + 0.015, zc + 0.04)))
    if kind == "sniper" and rng.random() < 0.4:  # bipod
        y_b = y_rec0 - hg * 0.8
        for s in (-1, 1):
            parts.append(_rod((0, y_b, zc - 0.02), (s * 0.05, y_b - 0.04, zc - 0.2), 0.005, 8))
    return parts


def _sofa(rng: Rng) -> Parts:
    w = _u(rng, 1.3, 2.3)
    d = _u(rng, 0.75, 0.95)
    seat = _u(rng, 0.38, 0.46)
    leg_h = _u(rng, 0.05, 0.15) if rng.random() < 0.6 else 0.0
    cush = _u(rng, 0.08, 0.15)
    back_t = _u(rng, 0.15, 0.25)
    back_top = _u(rng, 0.7, 0.95)
    arm = _pick(rng, {"none": 0.1, "low": 0.3, "high": 0.35, "rolled": 0.25})
    arm_w = _u(rng, 0.1, 0.22) if arm != "none" else 0.0
    parts: Parts = []
    z_base = seat - cush
    parts.append(_box((-w / 2, -d / 2, max(leg_h, 0.0)), (w / 2, d / 2, z_base)))
    tilt = _u(rng, 0.0, 0.1)
    parts.append(
        _hull(
            [
                (x, y, z)
                for x in (-w / 2, w / 2)
                for (y, z) in (
                    (d / 2 - back_t, leg_h),
                    (d / 2, leg_h),
                    (d / 2 - back_t + tilt, back_top),
                    (d / 2, back_top),
                )
            ]
        )
    )
    if arm != "none":
        arm_top = {
            "low": seat + _u(rng, 0.1, 0.18),
            "high": seat + _u(rng, 0.2, 0.3),
            "rolled": seat + _u(rng, 0.15, 0.25),
        }[arm]
        for s in (-1, 1):
            x_out, x_in = s * w / 2, s * (w / 2 - arm_w)
            parts.append(_box((x_in, -d / 2, max(leg_h, 0.0)), (x_out, d / 2, arm_top)))
            if arm == "rolled":
                parts.append(
                    _rod(
                        ((x_in + x_out) / 2, -d / 2 - 0.01, arm_top),
                        ((x_in + x_out) / 2, d / 2, arm_top),
                        arm_w * 0.6,
                        16,
                    )
                )
    inner = w - 2 * arm_w
    n_seats = int(np.clip(round(inner / _u(rng, 0.55, 0.8)), 1, 4))
    cw = inner / n_seats
    back_cush = rng.random() < 0.5
    for k in range(n_seats):
        x0 = -inner / 2 + k * cw + 0.01
        parts.append(
            _box((x0, -d / 2 - 0.02, z_base - _EPS), (x0 + cw - 0.02, d / 2 - back_t + _EPS, seat))
        )
        if back_cush:
            parts.append(
                _box(
                    (x0, d / 2 - back_t - 0.12, seat - _EPS),
                    (x0 + cw - 0.02, d / 2 - back_t + 0.02, seat + (back_top - seat) * 0.8),
                )
            )
    if rng.random() < 0.25:  # chaise longue (L-shape) on one side
        s = 1 if rng.random() < 0.5 else -1
        ext = _u(rng, 0.5, 0.8)
        x0, x1 = s * (w / 2 - arm_w - cw), s * (w / 2)
        parts.append(_box((x0, -d / 2 - ext, max(leg_h, 0.0)), (x1, -d / 2 + 0.01, z_base)))
        parts.append(
            _box(
                (x0 - s * 0.01, -d / 2 - ext + 0.01, z_base - _EPS),
                (x1 - s * (arm_w + 0.01), -d / 2, seat),
            )
        )
    if leg_h > 0:
        lr = _u(rng, 0.015, 0.03)
        xs = [-w / 2 + 0.06, w / 2 - 0.06] + ([0.0] if w > 1.8 else [])
        for x in xs:
            for y in (-d / 2 + 0.06, d / 2 - 0.06):
                parts.append(_rod((x, y, 0), (x, y, leg_h + 0.01), lr, 8))
    return parts


def _table(rng: Rng) -> Parts:
    kind = _pick(rng, {"dining": 0.4, "coffee": 0.25, "bar": 0.1, "desk": 0.25})
    top = _pick(
        rng, {"rect": 0.55, "round": 0.3, "oval": 0.15} if kind != "desk" else {"rect": 1.0}
    )
    h = {
        "dining": _u(rng, 0.7, 0.78),
        "coffee": _u(rng, 0.35, 0.5),
        "bar": _u(rng, 0.95, 1.1),
        "desk": _u(rng, 0.7, 0.78),
    }[kind]
    if top == "round":
        w = d = 2 * (_u(rng, 0.25, 0.4) if kind == "bar" else _u(rng, 0.4, 0.65))
    else:
        w = _u(rng, 0.9, 1.9)
        d = w * _u(rng, 0.4, 0.75)
    t = _u(rng, 0.02, 0.06)
    parts: Parts = []
    if top == "rect":
        parts.append(_box((-w / 2, -d / 2, h - t), (w / 2, d / 2, h)))
    else:
        disc = _rod((0, 0, h - t), (0, 0, h), 0.5, 40)
        disc.apply_scale((w, d, 1.0))
        parts.append(disc)
    legs = _pick(
        rng,
        {
            "four": 0.55,
            "pedestal": 0.25 if top != "rect" or kind == "coffee" else 0.1,
            "trestle": 0.2 if top == "rect" else 0.0,
        },
    )
    lw = _u(rng, 0.03, 0.07)
    if kind == "desk" and rng.random() < 0.6:  # drawer pedestal on one side, legs on the other
        s = 1 if rng.random() < 0.5 else -1
        pw = _u(rng, 0.3, 0.45)
        parts.append(
            _box(
                (s * (w / 2 - 0.02), -d / 2 + 0.03, 0),
                (s * (w / 2 - pw), d / 2 - 0.02, h - t + _EPS),
            )
        )
        for y in (-d / 2 + lw, d / 2 - lw):
            parts.append(
                _box(
                    (-s * (w / 2 - lw) - lw / 2, y - lw / 2, 0),
                    (-s * (w / 2 - lw) + lw / 2, y + lw / 2, h - t + _EPS),
                )
            )
        return parts
    if legs == "four":
        inset = _u(rng, 0.02, 0.12) * min(w, d) + lw
        if top == "rect":
            corners = [
                (sx * (w / 2 - inset), sy * (d / 2 - inset)) for sx in (-1, 1) for sy in (-1, 1)
            ]
        else:
            n = 4 if rng.random() < 0.6 else 3
            a0 = np.pi / 4 if n == 4 else np.pi / 2
            corners = [
                (
                    (w / 2 - inset) * np.cos(a0 + 2 * np.pi * k / n),
                    (d / 2 - inset) * np.sin(a0 + 2 * np.pi * k / n),
                )
                for k in range(n)
            ]
        round_legs = rng.random() < 0.4
        splay = _u(rng, 0.0, 0.06) if rng.random() < 0.3 else 0.0
        for x, y in corners:
            nrm = np.hypot(x, y)
            bot = (x + splay * x / nrm, y + splay * y / nrm, 0)
            if round_legs:
                parts.append(_rod(bot, (x, y, h - t / 2), lw / 2, 10))
            else:
                parts.append(_beam(bot, (x, y, h - t / 2), lw / 2))
        if top == "rect" and rng.random() < 0.5:  # apron
            ah = _u(rng, 0.05, 0.12)
            for s in (-1, 1):
                parts.append(
                    _box(
                        (-w / 2 + inset, s * (d / 2 - inset) - 0.01, h - t - ah),
                        (w / 2 - inset, s * (d / 2 - inset) + 0.01, h - t + _EPS),
                    )
                )
                parts.append(
                    _box(
                        (s * (w / 2 - inset) - 0.01, -d / 2 + inset, h - t - ah),
                        (s * (w / 2 - inset) + 0.01, d / 2 - inset, h - t + _EPS),
                    )
                )
        if rng.random() < (0.5 if kind == "coffee" else 0.15):  # lower shelf
            zs = _u(rng, 0.08, 0.2)
            out = splay * (1 - zs / (h - t / 2))  # how far the splayed legs lean out at zs
            ex, ey = w / 2 - inset + out, d / 2 - inset + out
            if top == "rect":
                parts.append(_box((-ex, -ey, zs), (ex, ey, zs + 0.02)))
            else:
                shelf = _rod((0, 0, zs), (0, 0, zs + 0.02), 1.0, 32)
                shelf.apply_scale((ex, ey, 1.0))
                parts.append(shelf)
    elif legs == "pedestal":
        cr = _u(rng, 0.03, 0.08)
        parts.append(_rod((0, 0, 0), (0, 0, h - t / 2), cr, 16))
        if rng.random() < 0.5:
            parts.append(_rod((0, 0, 0), (0, 0, 0.03), _u(rng, 0.2, 0.35) * max(w, d) + 0.1, 28))
        else:
            reach = 0.35 * max(w, d)
            n = int(rng.choice([3, 4]))
            for k in range(n):
                a = 2 * np.pi * k / n + np.pi / 4
                parts.append(
                    _beam((0, 0, 0.03), (reach * np.cos(a), reach * np.sin(a), 0.03), 0.025)
                )
    else:  # trestle: two end frames and a stretcher
        inset = _u(rng, 0.05, 0.2) * w
        for s in (-1, 1):
            x = s * (w / 2 - inset)
            if rng.random() < 0.5:
                parts.append(
                    _box((x - lw / 2, -d / 2 + 0.05, 0), (x + lw / 2, d / 2 - 0.05, h - t + _EPS))
                )
            else:
                parts.append(_box((x - lw / 2, -lw, 0), (x + lw / 2, lw, h - t + _EPS)))
                parts.append(_box((x - lw / 2, -d / 2 + 0.05, 0), (x + lw / 2, d / 2 - 0.05, 0.05)))
                parts.append(
                    _box(
                        (x - lw / 2, -d / 2 + 0.08, h - t - 0.05),
                        (x + lw / 2, d / 2 - 0.08, h - t + _EPS),
                    )
                )
        parts.append(_box((-w / 2 + inset, -0.02, h * 0.3), (w / 2 - inset, 0.02, h * 0.3 + 0.05)))
    return parts


def _telephone(rng: Rng) -> Parts:
    kind = _pick(rng, {"smartphone": 0.5, "feature": 0.25, "desk": 0.25})
    parts: Parts = []
    if kind == "desk":
        w = _u(rng, 0.18, 0.25)
        d = _u(rng, 0.18, 0.24)
        h_front, h_back = _u(rng, 0.03, 0.05), _u(rng, 0.07, 0.11)
        parts.append(
            _hull(
                [
                    (s * w / 2, y, z)
                    for s in (-1, 1)
                    for (y, z) in ((-d / 2, 0), (d / 2, 0), (-d / 2, h_front), (d / 2, h_back))
                ]
            )
        )
        # handset lying across the top at the back (earpiece left, mouthpiece right)
        L = w * _u(rng, 1.0, 1.25)
        yh = d / 2 - 0.04
        z_surf = h_front + (yh + d / 2) / d * (h_back - h_front)
        zh = z_surf + 0.022
        parts.append(_rod((-L / 2 + 0.03, yh, zh), (L / 2 - 0.03, yh, zh), 0.014, 12))
        for s in (-1, 1):  # earpiece and mouthpiece resting in the cradle
            parts.append(
                _box(
                    (s * (L / 2 - 0.06), yh - 0.025, z_surf - _EPS),
                    (s * L / 2, yh + 0.025, zh + 0.012),
                )
            )
        # keypad on the sloped front: 4 x 3 keys
        slope = np.arctan2(h_back - h_front, d)
        if rng.random() < 0.8:
            for i in range(4):
                for j in range(3):
                    y = -d / 2 + 0.03 + i * 0.022
                    z = h_front + (y + d / 2) * np.tan(slope)
                    parts.append(_cbox(((j - 1) * 0.025, y, z + 0.002), (0.016, 0.014, 0.01)))
        else:  # rotary dial
            y = -d / 2 + 0.07
            z = h_front + 0.07 * np.tan(slope)
            parts.append(_rod((0, y, z - 0.01), (0, y, z + 0.008), 0.045, 24))
        return parts
    # upright handheld: screen faces -y
    w = _u(rng, 0.06, 0.08)
    h = w * (_u(rng, 1.9, 2.2) if kind == "smartphone" else _u(rng, 2.0, 2.6))
    t = _u(rng, 0.007, 0.011) if kind == "smartphone" else _u(rng, 0.014, 0.022)
    rc = w * _u(rng, 0.05, 0.18)
    corners = [(sx * (w / 2 - rc), sz * (h / 2 - rc)) for sx in (-1, 1) for sz in (-1, 1)]
    ring = [
        (x + rc * np.cos(a), y, z + rc * np.sin(a))
        for (x, z) in corners
        for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)
        for y in (-t / 2, t / 2)
    ]
    parts.append(_hull(ring))
    if kind == "smartphone":
        m = w * 0.05
        parts.append(
            _box(
                (-w / 2 + m, -t / 2 - 0.0008, -h / 2 + m * 2),
                (w / 2 - m, -t / 2 + 0.001, h / 2 - m * 2),
            )
        )
        cam = _pick(rng, {"corner": 0.6, "strip": 0.2, "none": 0.2})
        if cam == "corner":
            cs = w * _u(rng, 0.25, 0.4)
            parts.append(
                _box(
                    (-w / 2 + m, t / 2 - 0.001, h / 2 - m - cs),
                    (-w / 2 + m + cs, t / 2 + 0.0015, h / 2 - m),
                )
            )
        elif cam == "strip":
            parts.append(
                _box(
                    (-w / 2 + m, t / 2 - 0.001, h / 2 - m - w * 0.2),
                    (w / 2 - m, t / 2 + 0.0015, h / 2 - m),
                )
            )
    else:
        # screen on the upper half, keypad on the lower half, maybe an antenna
        m = w * 0.1
        parts.append(
            _box(
                (-w / 2 + m, -t / 2 - 0.001, 0.02 * h), (w / 2 - m, -t / 2 + 0.001, h / 2 - m * 1.5)
            )
        )
        kw, kh = (w - 2 * m) / 3, (h / 2 - m * 1.5) / 5
        for i in range(4):
            for j in range(3):
                x = -w / 2 + m + kw * (j + 0.5)
                z = -h / 2 + m + kh * (i + 0.5)
                parts.append(_cbox((x, -t / 2, z), (kw * 0.75, 0.004, kh * 0.7)))
        if rng.random() < 0.5:
            parts.append(
                _rod(
                    (w / 2 - m, 0, h / 2 - 0.01),
                    (w / 2 - m, 0, h / 2 + _u(rng, 0.02, 0.06)),
                    0.004,
                    8,
                )
            )
    return parts


def _watercraft(rng: Rng) -> Parts:
    kind = _pick(
        rng, {"ship": 0.3, "sailboat": 0.25, "speedboat": 0.2, "canoe": 0.1, "cargo": 0.15}
    )
    length = 1.0
    beam = {
        "canoe": _u(rng, 0.1, 0.14),
        "cargo": _u(rng, 0.14, 0.2),
        "ship": _u(rng, 0.12, 0.18),
    }.get(kind, _u(rng, 0.2, 0.3))
    depth = {"canoe": _u(rng, 0.05, 0.07), "cargo": _u(rng, 0.08, 0.11)}.get(
        kind, _u(rng, 0.07, 0.12)
    )
    bow = {"canoe": 0.4, "cargo": 0.15}.get(kind, _u(rng, 0.3, 0.45))  # fraction of length tapering
    stern_w = 0.0 if kind == "canoe" else _u(rng, 0.6, 0.95)
    keel = _u(rng, 0.25, 0.55)
    sheer = _u(rng, 0.0, 0.04)
    pts = []
    for u in np.linspace(0, 1, 13):
        y = -length / 2 + u * length
        if u < bow:
            hw = beam / 2 * np.sin(np.pi / 2 * u / bow) ** 0.8
        elif kind == "canoe" and u > 1 - bow:
            hw = beam / 2 * np.sin(np.pi / 2 * (1 - u) / bow) ** 0.8
        else:
            f = (u - bow) / (1 - bow)
            hw = beam / 2 * (1 - (1 - stern_w) * f**2)
        hw = max(hw, 0.002)
        z_deck = depth + sheer * max(0.0, 1 - u / bow) ** 2
        z_keel = 0.6 * depth * max(0.0, 1 - u / (bow * 0.8)) ** 2
        if kind == "canoe":
            z_keel = max(z_keel, 0.6 * depth * max(0.0, 1 - (1 - u) / (bow * 0.8)) ** 2)
        pts += [(s * hw, y, z_deck) for s in (-1, 1)]
        pts += [(s * hw * keel, y, z_keel) for s in (-1, 1)]
    hull = _hull(pts)
    if kind == "canoe":  # open boat: hollow the hull out from above
        inner = hull.copy()
        inner.apply_scale((0.8, 0.94, 1.0))
        inner.apply_translation((0, 0, 0.25 * depth))
        try:
            hollow = trimesh.boolean.difference([hull, inner], engine="manifold")
            if hollow.is_watertight and len(hollow.faces):
                hull = hollow
        except Exception:  # keep the solid hull if the engine fails
            pass
    parts: Parts = [hull]
    deck = depth
    if kind == "ship":
        n = int(rng.integers(1, 4))
        y0 = _u(rng, -0.15, 0.15)
        sl, sw, sh = _u(rng, 0.2, 0.35), beam * 0.75, _u(rng, 0.05, 0.08)
        z = deck
        for _ in range(n):
            parts.append(_box((-sw / 2, y0 - sl / 2, z - 0.01), (sw / 2, y0 + sl / 2, z + sh)))
            y_top = y0
            z += sh
            sl *= _u(rng, 0.5, 0.8)
            sw *= 0.85
            y0 -= sl * 0.1
        for k in range(int(rng.integers(0, 3))):
            yf = y0 + 0.12 + 0.07 * k
            parts.append(
                _rod(
                    (0, yf, deck - _EPS), (0, yf, z + _u(rng, 0.03, 0.08)), _u(rng, 0.02, 0.03), 16
                )
            )
        parts.append(_rod((0, y_top, z - _EPS), (0, y_top, z + _u(rng, 0.08, 0.2)), 0.006, 8))
    elif kind == "cargo":
        yb = _u(rng, 0.25, 0.35)
        parts.append(
            _box(
                (-beam * 0.4, yb - 0.05, deck - 0.01),
                (beam * 0.4, yb + 0.05, deck + _u(rng, 0.12, 0.2)),
            )
        )
        n_stacks = int(rng.integers(3, 7))
        span = (yb - 0.08) - (-0.3)
        for k in range(n_stacks):
            y = -0.3 + span * (k + 0.5) / n_stacks
            hgt = _u(rng, 0.02, 0.07)
            parts.append(
                _cbox((0, y, deck + hgt / 2), (beam * 0.8, span / n_stacks * 0.9, hgt + 0.01))
            )
    elif kind == "sailboat":
        mast_h = _u(rng, 0.7, 1.2)
        ym = _u(rng, -0.15, 0.0)
        parts.append(_rod((0, ym, deck - _EPS), (0, ym, deck + mast_h), 0.008, 8))
        boom = _u(rng, 0.3, 0.45)
        zb = deck + _u(rng, 0.06, 0.12)
        parts.append(_rod((0, ym, zb), (0, ym + boom, zb), 0.006, 8))
        # main sail: a thin triangle behind the mast; jib in front
        parts.append(
            _hull(
                [
                    (s * 0.003, y, z)
                    for s in (-1, 1)
                    for (y, z) in ((ym, zb), (ym + boom, zb), (ym, deck + mast_h * 0.95))
                ]
            )
        )
        if rng.random() < 0.7:
            yj = -length / 2 + 0.05
            parts.append(
                _hull(
                    [
                        (s * 0.003, y, z)
                        for s in (-1, 1)
                        for (y, z) in (
                            (yj, deck - _EPS),
                            (ym, deck - _EPS),
                            (ym, deck + mast_h * 0.8),
                        )
                    ]
                )
            )
        parts.append(
            _box(
                (-beam * 0.3, ym + 0.03, deck - 0.01),
                (beam * 0.3, ym + _u(rng, 0.15, 0.3), deck + 0.04),
            )
        )
    elif kind == "speedboat":
        yc = _u(rng, -0.1, 0.1)
        cl = _u(rng, 0.2, 0.35)
        ch = _u(rng, 0.05, 0.1)
        parts.append(
            _hull(
                [
                    (s * ww, y, z)
                    for s in (-1, 1)
                    for (ww, y, z) in (
                        (beam * 0.4, yc - cl / 2, deck - 0.01),
                        (beam * 0.4, yc + cl / 2, deck - 0.01),
                        (beam * 0.35, yc - cl / 2 + ch * 1.2, deck + ch),
                        (beam * 0.35, yc + cl / 2, deck + ch),
                    )
                ]
            )
        )
        if rng.random() < 0.6:  # outboard motor
            parts.append(
                _box(
                    (-0.025, length / 2 - 0.01, deck * 0.2), (0.025, length / 2 + 0.05, deck + 0.06)
                )
            )
    else:  # canoe thwarts
        for y in (-0.2, 0.0, 0.2):
            parts.append(_cbox((0, y, deck - 0.012), (beam * 0.9, 0.02, 0.01)))
    return parts


_BUILDERS: dict[str, Callable[[Rng], Parts]] = {
    "airplane": _airplane,
    "bench": _bench,
    "cabinet": _cabinet,
    "car": _car,
    "chair": _chair,
    "display": _display,
    "lamp": _lamp,
    "speaker": _speaker,
    "rifle": _rifle,
    "sofa": _sofa,
    "table": _table,
    "telephone": _telephone,
    "watercraft": _watercraft,
}


# --------------------------------------------------------------------------- public API


def _union(parts: Parts) -> trimesh.Trimesh:
    """Boolean union of watertight parts with manifold3d; concatenation if that fails."""
    try:
        mesh = trimesh.boolean.union(parts, engine="manifold")
        if len(mesh.faces) and mesh.is_watertight:
            return mesh
    except Exception:  # any engine failure falls back to concatenation
        pass
    return trimesh.util.concatenate(parts)


def make_shape(category: str, seed: int) -> trimesh.Trimesh:
    """Build a random but recognisable object of one of the 13 :data:`CATEGORIES`.

    Deterministic: the same ``(category, seed)`` gives the same mesh; categories draw from
    independent random streams (``np.random.default_rng([category_index, seed])``). The
    parts (boxes, cylinders, spheres, solids of revolution, convex hulls) are merged by a
    boolean union (manifold3d), so the result is normally watertight; if the union fails
    the parts are concatenated, which :func:`e2vlib.voxels.voxelize` still fills correctly.
    The mesh is normalized (bounding box centred at the origin, longest side 1), z up,
    front towards -y, not randomly rotated: like ShapeNet, objects share one canonical pose.

    Raises ValueError for an unknown category (listing the valid ones) or a negative seed.

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    if category not in _BUILDERS:
        raise ValueError(f"unknown category {category!r}; choose one of {', '.join(CATEGORIES)}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    rng = np.random.default_rng([CATEGORIES.index(category), int(seed)])
    parts = _BUILDERS[category](rng)
    return normalize_mesh(_union(parts))


def normalize_mesh(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Return a copy moved and scaled so its bounding box is centred at the origin with
    longest side 1 (the paper's objects "fit within 1 m^3"). Orientation is unchanged.

    Raises ValueError for an empty mesh, NaN/inf vertices or a mesh of zero extent.

    Introduced in notebooks/04_building_the_dataset.ipynb.
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
        loaded = trimesh.load(str(p), force="mesh", process=True, skip_materials=True)
    except Exception as err:  # parsers raise many types
        raise ValueError(f"{p}: could not read mesh ({type(err).__name__}: {err})") from err
    if isinstance(loaded, trimesh.Scene):  # defensive: force="mesh" normally merges
        loaded = loaded.to_geometry()
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError(f"{p}: file holds no triangles (corrupt, empty, or a point cloud)")
    if not np.all(np.isfinite(loaded.vertices)):
        raise ValueError(f"{p}: mesh has NaN/inf vertex coordinates")
    return loaded


def shapenet_to_zup(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Turn a ShapeNetCore v2 mesh (y up, front -z) into our frame (z up, front -y).

    ShapeNetCore v2's ``model_normalized.obj`` files are aligned with +y up and the front
    towards -z. The proper rotation ``(x, y, z) -> (-x, z, y)`` (180 degrees about the axis
    ``(0, 1, 1)``) sends up to +z and front to -y; x flips sign, which is harmless for the
    many categories symmetric about the y-z plane and keeps the mesh un-mirrored. Returns a
    copy. (ShapeNetCore v1 used a different, partly mirrored alignment; check visually.)

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    out = mesh.copy()
    rot = np.array([[-1.0, 0, 0, 0], [0, 0, 1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
    out.apply_transform(rot)
    return out


def iter_shapenet(
    root: str | os.PathLike, categories: Iterable[str] | None = None
) -> Iterator[tuple[str, str, Path]]:
    """Yield ``(category, model_id, mesh_path)`` for the 13 categories in a ShapeNetCore folder.

    Reads ShapeNetCore v2 (``root/<synset>/<model_id>/models/model_normalized.obj``) and
    v1 (``root/<synset>/<model_id>/model.obj``) layouts; synset folders of other categories
    are skipped, models without a mesh file are skipped. ``categories`` limits the output to
    some names of :data:`CATEGORIES`. Output is sorted by category order, then model id.

    Raises FileNotFoundError if ``root`` is not a folder, ValueError for unknown categories.

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    root_p = Path(root)
    if not root_p.is_dir():
        raise FileNotFoundError(f"ShapeNetCore folder not found: {root_p}")
    if categories is None:
        wanted = list(CATEGORIES)
    else:
        wanted = [categories] if isinstance(categories, str) else list(categories)
        bad = [c for c in wanted if c not in CATEGORIES]
        if bad:
            raise ValueError(f"unknown categories {bad}; choose from {', '.join(CATEGORIES)}")
    by_name = {name: synset for synset, name in SHAPENET_SYNSETS.items()}
    for name in CATEGORIES:
        if name not in wanted:
            continue
        folder = root_p / by_name[name]
        if not folder.is_dir():
            continue
        for model_dir in sorted(p for p in folder.iterdir() if p.is_dir()):
            for candidate in (
                model_dir / "models" / "model_normalized.obj",
                model_dir / "model.obj",
            ):
                if candidate.is_file():
                    yield name, model_dir.name, candidate
                    break
