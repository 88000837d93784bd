"""Procedural category builder: the lamp (table, floor, desk and pendant styles).

Like every builder it takes a ``numpy.random.Generator`` and returns the parts of one object
(watertight ``trimesh.Trimesh`` solids) in rough metres, z up, front towards -y; parts that
meet overlap by ``OVERLAP_M``. :func:`e2vlib.shapes.builders.make_shape` joins and normalizes
them. The order of the random draws is part of the output: changing it changes every mesh.
"""

from __future__ import annotations

import numpy as np

from e2vlib.shapes.parts import pick_style, uniform
from e2vlib.shapes.primitives import Parts, Rng, centred_box, lathe, rod, sphere


def build_lamp(rng: Rng) -> Parts:
    kind = pick_style(rng, {"table": 0.35, "floor": 0.25, "desk": 0.25, "pendant": 0.15})
    parts: Parts = []
    sec = 24
    # base
    if kind != "pendant":
        base = pick_style(
            rng,
            {"disc": 0.5, "square": 0.2, "dome": 0.2, "tripod": 0.1 if kind == "floor" else 0.0},
        )
        br = uniform(rng, 0.08, 0.16) if kind != "floor" else uniform(rng, 0.14, 0.22)
        bh = uniform(rng, 0.015, 0.04)
        if base == "disc":
            parts.append(rod((0, 0, 0), (0, 0, bh), br, sec))
        elif base == "square":
            parts.append(centred_box((0, 0, bh / 2), (1.6 * br, 1.6 * br, bh)))
        elif base == "dome":
            bh *= 2
            parts.append(
                lathe(
                    [(0, 0), (br, 0), (br * 0.8, bh * 0.6), (br * 0.25, bh), (0, bh)], sections=sec
                )
            )
        else:
            bh = uniform(rng, 0.2, 0.35)
            for k in range(3):
                a = 2 * np.pi * k / 3 + np.pi / 2
                parts.append(rod((br * np.cos(a), br * np.sin(a), 0), (0, 0, bh), 0.01, 8))
    if kind in ("table", "floor"):
        height = uniform(rng, 0.35, 0.6) if kind == "table" else uniform(rng, 1.2, 1.8)
        if kind == "table" and rng.random() < 0.45:  # vase-shaped body
            vr = uniform(rng, 0.06, 0.12)
            vh = height * uniform(rng, 0.4, 0.6)
            parts.append(
                lathe(
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
        parts.append(rod((0, 0, 0), (0, 0, height), uniform(rng, 0.008, 0.018), 10))
        z_top = height
    elif kind == "desk":
        l1 = uniform(rng, 0.25, 0.4)
        l2 = uniform(rng, 0.25, 0.4)
        a1 = np.radians(uniform(rng, 60, 85))
        a2 = np.radians(uniform(rng, -20, 25))
        p0 = np.array([0, 0.04, bh])
        p1 = p0 + l1 * np.array([0, np.cos(a1), np.sin(a1)])
        p2 = p1 + l2 * np.array([0, -np.cos(a2), np.sin(a2)])
        for a, b in ((p0, p1), (p1, p2)):
            for sx in (-0.012, 0.012):
                parts.append(rod(a + (sx, 0, 0), b + (sx, 0, 0), 0.007, 8))
        parts.append(sphere(p1, 0.02, 1))
        parts.append(sphere(p0, 0.022, 1))
        # shade: a cone opening downwards and forwards
        sr = uniform(rng, 0.06, 0.1)
        sl = uniform(rng, 0.08, 0.16)
        axis = np.array([0, -np.sin(np.radians(30)), -np.cos(np.radians(30))])
        parts.append(lathe([(0, 0), (0.025, 0), (sr, sl), (0, sl)], p2 - axis * 0.02, axis, sec))
        return parts
    else:  # pendant: canopy at the top, cord, shade below
        height = uniform(rng, 0.8, 1.3)
        parts.append(rod((0, 0, height - 0.03), (0, 0, height), 0.06, sec))
        z_top = height * uniform(rng, 0.35, 0.6)
        parts.append(rod((0, 0, z_top - 0.02), (0, 0, height), 0.006, 8))
    # shade (hangs from or sits on z_top)
    shades = {"frustum": 0.45, "drum": 0.2, "globe": 0.12, "dome": 0.23}
    if kind == "floor":
        shades = {"frustum": 0.55, "drum": 0.25, "globe": 0.08, "dome": 0.12}
    shade = pick_style(rng, shades)
    sr = uniform(rng, 0.12, 0.25) if kind != "table" else uniform(rng, 0.1, 0.2)
    sh = uniform(rng, 0.12, 0.3) if kind != "table" else uniform(rng, 0.1, 0.22)
    if kind == "table" or kind == "floor":
        z_shade = z_top - sh * 0.7
    else:
        z_shade = z_top - sh
    if shade == "frustum":
        top_r = sr * uniform(rng, 0.4, 0.75)
        parts.append(lathe([(0, 0), (sr, 0), (top_r, sh), (0, sh)], (0, 0, z_shade), sections=sec))
    elif shade == "drum":
        parts.append(rod((0, 0, z_shade), (0, 0, z_shade + sh), sr * 0.85, sec))
    elif shade == "globe":
        r = {"table": uniform(rng, 0.07, 0.12), "floor": uniform(rng, 0.13, 0.2)}.get(
            kind, uniform(rng, 0.08, 0.15)
        )
        parts.append(
            sphere((0, 0, z_top + r * (0.3 if kind == "pendant" else -0.3) - r * 0.5), r, 2)
        )
    else:
        n = 6
        prof = [(0, 0)] + [(sr * np.cos(a), sh * np.sin(a)) for a in np.linspace(0, np.pi / 2, n)]
        parts.append(lathe(prof, (0, 0, z_shade), sections=sec))
    return parts
