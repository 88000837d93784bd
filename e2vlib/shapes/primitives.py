"""Mesh primitives the procedural objects are built from: boxes, rods (cylinders), convex
hulls, square beams, spheres, solids of revolution, tapered panels and oriented boxes
(bricks); and :func:`turned`, which rotates parts about an axis (an open door, a tilted screen).

Every primitive returns a watertight ``trimesh.Trimesh`` in metres; points are ``(x, y, z)``
with z up. ``Rng`` and ``Parts`` are the types the category builders take and return.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import trimesh

Rng = np.random.Generator
Parts = list[trimesh.Trimesh]

OVERLAP_M = 0.005  # parts that meet overlap by this much (metres), so the union joins them


def box_between(lo: Iterable[float], hi: Iterable[float]) -> trimesh.Trimesh:
    """Axis-aligned box between two opposite corners."""
    lo_, hi_ = np.asarray(list(lo), float), np.asarray(list(hi), float)
    return trimesh.creation.box(bounds=np.stack([np.minimum(lo_, hi_), np.maximum(lo_, hi_)]))


def centred_box(center: Iterable[float], size: Iterable[float]) -> trimesh.Trimesh:
    """Axis-aligned box from its centre and full extents."""
    c, s = np.asarray(list(center), float), np.asarray(list(size), float) / 2
    return box_between(c - s, c + s)


def rod(
    p0: Iterable[float], p1: Iterable[float], radius: float, sections: int = 12
) -> trimesh.Trimesh:
    """Cylinder of ``radius`` from point ``p0`` to point ``p1``."""
    seg = np.array([list(p0), list(p1)], float)
    return trimesh.creation.cylinder(radius=radius, segment=seg, sections=sections)


def hull_of(points: Iterable[Iterable[float]]) -> trimesh.Trimesh:
    """Convex hull of a point set (a watertight, outward-facing solid)."""
    return trimesh.convex.convex_hull(np.asarray([list(p) for p in points], float))


def beam_between(p0: Iterable[float], p1: Iterable[float], half: float) -> trimesh.Trimesh:
    """Square-section bar of half-width ``half`` from ``p0`` to ``p1`` (slanted legs)."""
    a, b = np.asarray(list(p0), float), np.asarray(list(p1), float)
    d = (b - a) / np.linalg.norm(b - a)
    ref = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(d, ref)
    u /= np.linalg.norm(u)
    v = np.cross(d, u)
    corners = [s * u * half + t * v * half for s in (-1, 1) for t in (-1, 1)]
    return hull_of([p + c for p in (a, b) for c in corners])


def sphere(center: Iterable[float], radius: float, subdivisions: int = 2) -> trimesh.Trimesh:
    """Icosphere of ``radius`` centred at ``center``."""
    return trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius).apply_translation(
        np.asarray(list(center), float)
    )


def lathe(
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


def panel_mesh(
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
    return hull_of(pts)


def brick(
    corner: Iterable[float], a: Iterable[float], b: Iterable[float], c: Iterable[float]
) -> trimesh.Trimesh:
    """Parallelepiped with one ``corner`` and edge vectors ``a``, ``b``, ``c`` from it (an
    oriented box: an open door, a tilted screen, one half of a flip phone)."""
    o, ea, eb, ec = (np.asarray(list(v), float) for v in (corner, a, b, c))
    return hull_of([o + i * ea + j * eb + k * ec for i in (0, 1) for j in (0, 1) for k in (0, 1)])


def turned(parts: Parts, degrees: float, axis: Iterable[float], point: Iterable[float]) -> Parts:
    """The parts rotated by ``degrees`` (right-handed) about ``axis`` through ``point``."""
    m = trimesh.transformations.rotation_matrix(
        np.radians(degrees), np.asarray(list(axis), float), np.asarray(list(point), float)
    )
    return [p.copy().apply_transform(m) for p in parts]
