"""Procedural telephones in five sub-types (:data:`TELEPHONE_KINDS`), the structural variety
of ShapeNet's telephone category rather than one slab of random proportions:

``mobile``    a thin upright slab: a smartphone with a screen and a camera bump
``feature``   a thicker candybar phone with a keypad and maybe a stub antenna
``flip``      an open clamshell: the screen half leaning back from a hinge
``desk``      a desk telephone: a wedge base with keys and a handset resting on a cradle
``cordless``  a handset standing in a charging dock, or in the cradle of a base with keys

Each builder takes a ``numpy.random.Generator`` and returns the parts of one object
(watertight ``trimesh.Trimesh`` solids) in rough metres, z up, front towards -y; parts that
meet overlap by ``OVERLAP_M``. :func:`e2vlib.shapes.builders.make_shape` joins and normalizes them.
The order of the random draws is part of the output: changing it changes every mesh.
"""

from __future__ import annotations

import numpy as np
import trimesh

from e2vlib.shapes.parts import pick_style, uniform
from e2vlib.shapes.primitives import (
    OVERLAP_M,
    Parts,
    Rng,
    box_between,
    centred_box,
    hull_of,
    rod,
    sphere,
    turned,
)

TELEPHONE_KINDS = {"mobile": 0.24, "feature": 0.12, "flip": 0.16, "desk": 0.24, "cordless": 0.24}
"""Telephone sub-types and their probabilities (the first draw of :func:`build_telephone`)."""


def _slab(
    w: float, h: float, t: float, rc: float, y: float = 0.0, z0: float = 0.0
) -> trimesh.Trimesh:
    """An upright slab ``w`` wide, ``h`` high and ``t`` thick with corners rounded by ``rc``
    (seen from the front), centred on ``x = 0, y = y``, from ``z0`` up."""
    corners = [(sx * (w / 2 - rc), sz * (h / 2 - rc)) for sx in (-1, 1) for sz in (-1, 1)]
    return hull_of(
        [
            (x + rc * np.cos(a), y + dy, z0 + h / 2 + z + rc * np.sin(a))
            for (x, z) in corners
            for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)
            for dy in (-t / 2, t / 2)
        ]
    )


def _keys(
    x0: float, x1: float, z0: float, z1: float, y: float, rows: int = 4, cols: int = 3
) -> Parts:
    """A ``rows x cols`` keypad on an upright front face at ``y``, over ``x0..x1, z0..z1``."""
    kw, kh = (x1 - x0) / cols, (z1 - z0) / rows
    return [
        centred_box((x0 + kw * (j + 0.5), y, z0 + kh * (i + 0.5)), (kw * 0.75, 0.004, kh * 0.7))
        for i in range(rows)
        for j in range(cols)
    ]


def _mobile(rng: Rng) -> Parts:
    w = uniform(rng, 0.06, 0.08)
    h, t = w * uniform(rng, 1.9, 2.2), uniform(rng, 0.007, 0.011)
    m = w * 0.05
    parts: Parts = [
        _slab(w, h, t, w * uniform(rng, 0.05, 0.18), 0.0, -h / 2),
        box_between(
            (-w / 2 + m, -t / 2 - 0.0008, -h / 2 + m * 2),
            (w / 2 - m, -t / 2 + 0.001, h / 2 - m * 2),
        ),
    ]
    cam = pick_style(rng, {"corner": 0.6, "strip": 0.2, "none": 0.2})
    if cam != "none":
        cs = w * uniform(rng, 0.25, 0.4) if cam == "corner" else w * 0.2
        x1 = -w / 2 + m + cs if cam == "corner" else w / 2 - m
        ct = uniform(rng, 0.0015, 0.004)
        parts.append(
            box_between((-w / 2 + m, t / 2 - 0.001, h / 2 - m - cs), (x1, t / 2 + ct, h / 2 - m))
        )
    return parts


def _feature(rng: Rng) -> Parts:
    w = uniform(rng, 0.045, 0.06)
    h, t = w * uniform(rng, 2.0, 2.6), uniform(rng, 0.014, 0.022)
    m = w * 0.1
    parts: Parts = [
        _slab(w, h, t, w * uniform(rng, 0.05, 0.2), 0.0, -h / 2),
        box_between(
            (-w / 2 + m, -t / 2 - 0.001, 0.02 * h), (w / 2 - m, -t / 2 + 0.001, h / 2 - m * 1.5)
        ),
    ]
    parts += _keys(-w / 2 + m, w / 2 - m, -h / 2 + m, -m, -t / 2)
    if rng.random() < 0.5:  # a stub antenna
        top = h / 2 + uniform(rng, 0.02, 0.06)
        parts.append(rod((w / 2 - m, 0, h / 2 - 0.01), (w / 2 - m, 0, top), 0.004, 8))
    return parts


def _flip(rng: Rng) -> Parts:
    w = uniform(rng, 0.045, 0.056)
    h1, t1, t2 = uniform(rng, 0.08, 0.1), uniform(rng, 0.012, 0.017), uniform(rng, 0.007, 0.011)
    h2 = h1 * uniform(rng, 0.9, 1.05)
    rc = w * uniform(rng, 0.08, 0.25)
    hr = t1 * 0.5  # the hinge barrel along the top back edge of the lower half
    hinge = np.array([0.0, t1 / 2 - hr, h1])
    lower: Parts = [
        _slab(w, h1, t1, rc, 0.0, 0.0),
        rod(hinge - (w / 2, 0, 0), hinge + (w / 2, 0, 0), hr, 12),
    ]
    m = w * 0.1
    lower += _keys(-w / 2 + m, w / 2 - m, h1 * 0.08, h1 * 0.62, -t1 / 2)
    lower.append(
        centred_box((0, -t1 / 2, h1 * 0.78), (w * 0.45, 0.004, h1 * 0.12))
    )  # navigation pad
    y2 = t1 / 2 - t2 / 2  # the upper half's back flush with the lower half's back
    upper: Parts = [
        _slab(w, h2 + hr, t2, rc, y2, h1 - hr),
        box_between(
            (-w / 2 + m, y2 - t2 / 2 - 0.0008, h1 + h2 * 0.2),
            (w / 2 - m, y2 - t2 / 2 + 0.001, h1 + h2 - m),
        ),
    ]
    return lower + turned(upper, -(180.0 - uniform(rng, 140.0, 170.0)), (1, 0, 0), hinge)


def _desk(rng: Rng) -> Parts:
    side = rng.random() < 0.35  # the handset lies along the left side, not across the back
    w = uniform(rng, 0.18, 0.25) + (0.07 if side else 0.0)
    d, hf, hb = uniform(rng, 0.18, 0.24), uniform(rng, 0.03, 0.05), uniform(rng, 0.07, 0.11)
    parts: Parts = [
        hull_of(
            [
                (s * w / 2, y, z)
                for s in (-1, 1)
                for (y, z) in ((-d / 2, 0), (d / 2, 0), (-d / 2, hf), (d / 2, hb))
            ]
        )
    ]

    def z_top(y: float) -> float:  # the sloped top of the base
        return hf + (y + d / 2) / d * (hb - hf)

    length, r = uniform(rng, 0.19, 0.23), uniform(rng, 0.011, 0.015)
    cup_r, cup_h, prong = (
        uniform(rng, 0.02, 0.027),
        uniform(rng, 0.018, 0.03),
        uniform(rng, 0.01, 0.025),
    )
    if side:
        xh = -w / 2 + cup_r + 0.01
        length = min(length, d * 1.1)
        ends = [np.array([xh, s * (length / 2 - cup_r), 0.0]) for s in (-1, 1)]
        keys_x = w * 0.12
    else:
        yh = d / 2 - cup_r - uniform(rng, 0.005, 0.02)
        length = min(length, w * 1.1)
        ends = [np.array([s * (length / 2 - cup_r), yh, 0.0]) for s in (-1, 1)]
        keys_x = 0.0
    tops = []
    for e in ends:  # a cradle prong, then the ear or mouth cup resting on it
        zs = z_top(e[1])
        parts.append(
            centred_box(
                (e[0], e[1], zs + prong / 2 - OVERLAP_M),
                (cup_r * 1.2, cup_r * 1.2, prong + 2 * OVERLAP_M),
            )
        )
        parts.append(
            rod((e[0], e[1], zs + prong - OVERLAP_M), (e[0], e[1], zs + prong + cup_h), cup_r, 16)
        )
        tops.append(np.array([e[0], e[1], zs + prong + cup_h]))
    parts.append(rod(tops[0], tops[1], r, 12))  # the handle, arching over the gap
    parts += [sphere(p, r * 1.15, 1) for p in tops]
    # keys (or a rotary dial) on the sloped front, in front of the cradle
    if rng.random() < 0.8:
        for i in range(4):
            for j in range(3):
                y = -d / 2 + 0.025 + i * 0.02
                parts.append(
                    centred_box(
                        (keys_x + (j - 1) * 0.024, y, z_top(y) + 0.002), (0.016, 0.013, 0.01)
                    )
                )
        if rng.random() < 0.5:  # a small screen above the keys
            y = -d / 2 + 0.025 + 4 * 0.02 + 0.01
            parts.append(centred_box((keys_x, y, z_top(y) + 0.004), (0.07, 0.02, 0.014)))
    else:
        y = -d / 2 + 0.065
        parts.append(rod((keys_x, y, z_top(y) - 0.01), (keys_x, y, z_top(y) + 0.008), 0.045, 24))
    if rng.random() < 0.5:  # a coiled cord from the mouth cup down to the base's side
        e = ends[1]
        if side:
            out, into = (-w / 2 - 0.03, e[1] + 0.02, 0.02), (-w / 2 + 0.01, e[1] - 0.04, 0.02)
        else:
            out, into = (w / 2 + 0.03, e[1] - 0.03, 0.02), (w / 2 - 0.01, e[1] - 0.06, 0.02)
        path = [tops[1] - (0, 0, cup_h / 2), np.array(out), np.array(into)]
        for p0, p1 in zip(path[:-1], path[1:], strict=True):
            parts.append(rod(p0, p1, 0.005, 8))
        parts.append(sphere(out, 0.007, 1))
    return parts


def _cordless(rng: Rng) -> Parts:
    w, h, t = uniform(rng, 0.04, 0.052), uniform(rng, 0.13, 0.17), uniform(rng, 0.018, 0.026)
    m = w * 0.12
    handset: Parts = [
        _slab(w, h, t, w * uniform(rng, 0.15, 0.4)),
        box_between(
            (-w / 2 + m, -t / 2 - 0.001, h * 0.6), (w / 2 - m, -t / 2 + 0.001, h - m * 1.5)
        ),
    ]
    handset += _keys(-w / 2 + m, w / 2 - m, h * 0.15, h * 0.52, -t / 2)
    if rng.random() < 0.35:  # a stub antenna
        handset.append(
            rod(
                (w / 2 - 0.008, 0, h - 0.01),
                (w / 2 - 0.008, 0, h + uniform(rng, 0.015, 0.03)),
                0.005,
                8,
            )
        )
    lean = uniform(rng, 5.0, 20.0)
    if rng.random() < 0.6:  # a charging dock with sloped sides, maybe a back rest
        bw, bd, bh = uniform(rng, 0.08, 0.12), uniform(rng, 0.08, 0.11), uniform(rng, 0.025, 0.04)
        parts: Parts = [
            hull_of(
                [(sx * bw / 2, sy * bd / 2, 0) for sx in (-1, 1) for sy in (-1, 1)]
                + [
                    (sx * (bw / 2 - 0.01), sy * (bd / 2 - 0.01), bh)
                    for sx in (-1, 1)
                    for sy in (-1, 1)
                ]
            )
        ]
        sunk = uniform(rng, 0.01, 0.02)
        pivot = np.array([0.0, 0.0, bh - sunk])
        if rng.random() < 0.5:
            rest = uniform(rng, 0.03, 0.06)
            parts.append(
                hull_of(
                    [
                        (sx * (bw / 2 - 0.01), y, z)
                        for sx in (-1, 1)
                        for (y, z) in (
                            (t / 2 + 0.004, bh - OVERLAP_M),
                            (bd / 2 - 0.01, bh - OVERLAP_M),
                            (bd / 2 - 0.01, bh + rest),
                            (
                                min(
                                    t / 2 + 0.004 + rest * np.tan(np.radians(lean)), bd / 2 - 0.015
                                ),
                                bh + rest,
                            ),
                        )
                    ]
                )
            )
    else:  # a base with its own keys; the handset stands in a cradle at its left
        bw, bd = uniform(rng, 0.15, 0.2), uniform(rng, 0.12, 0.16)
        hf, hb = uniform(rng, 0.025, 0.04), uniform(rng, 0.05, 0.07)
        parts = [
            hull_of(
                [
                    (s * bw / 2, y, z)
                    for s in (-1, 1)
                    for (y, z) in ((-bd / 2, 0), (bd / 2, 0), (-bd / 2, hf), (bd / 2, hb))
                ]
            )
        ]
        xc, yc = -bw / 2 + w / 2 + 0.015, bd * 0.15
        zc = hf + (yc + bd / 2) / bd * (hb - hf)
        parts.append(centred_box((xc, yc, zc), (w + 0.02, t + 0.02, 0.03)))  # the cradle
        pivot = np.array([xc, yc, zc - 0.01])
        for i in range(3):
            for j in range(3):
                y = -bd / 2 + 0.025 + i * 0.02
                parts.append(
                    centred_box(
                        (
                            bw * 0.15 + (j - 1) * 0.022,
                            y,
                            hf + (y + bd / 2) / bd * (hb - hf) + 0.002,
                        ),
                        (0.015, 0.012, 0.01),
                    )
                )
    handset = [p.apply_translation(pivot) for p in handset]
    return parts + turned(handset, -lean, (1, 0, 0), pivot)


_BUILD = {
    "mobile": _mobile,
    "feature": _feature,
    "flip": _flip,
    "desk": _desk,
    "cordless": _cordless,
}


def build_telephone(rng: Rng) -> Parts:
    return _BUILD[pick_style(rng, TELEPHONE_KINDS)](rng)
