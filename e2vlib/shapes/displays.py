"""Procedural displays in five sub-types (:data:`DISPLAY_KINDS`), the structural variety of
ShapeNet's display category rather than one slab on a box:

``monitor``     a thin (flat or curved) panel on a neck and a foot, tilted back a little
``arm``         a thin panel held up by an articulated arm from a desk base or a wall plate
``tv``          a wide panel on two feet, on a wide pedestal, or on a low TV bench
``crt``         a deep tube set (monitor on a swivel base, or a TV, maybe with rabbit ears)
``all_in_one``  a panel with a chin over the computer, on a slanted foot or a hinged arm

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
    centred_box,
    hull_of,
    rod,
    sphere,
    turned,
)

DISPLAY_KINDS = {"monitor": 0.24, "arm": 0.18, "tv": 0.22, "crt": 0.18, "all_in_one": 0.18}
"""Display sub-types and their probabilities (the first draw of :func:`build_display`)."""


def _screen(rng: Rng, w: float, h: float, t: float, z0: float, curved: bool) -> Parts:
    """A panel ``w`` wide and ``h`` high from ``z0`` up, its front at ``y = 0`` and its back
    at ``y = t``: a flat box with a screen plate inside the bezel, or curved (the edges
    brought forwards on an arc), maybe with an electronics hump at the back."""
    if curved:
        radius = w * uniform(rng, 1.0, 1.8)
        half = np.arcsin(w / 2 / radius)
        edges = np.linspace(-half, half, 9)
        parts: Parts = []
        for a0, a1 in zip(edges[:-1], edges[1:], strict=True):
            pts = []
            for a in (a0 - 0.01, a1 + 0.01):  # neighbours overlap by 0.01 rad
                front = np.array([radius * np.sin(a), radius * np.cos(a) - radius])
                back = front + t * np.array([np.sin(a), np.cos(a)])
                pts += [(p[0], p[1], z) for p in (front, back) for z in (z0, z0 + h)]
            parts.append(hull_of(pts))
    else:
        bezel = uniform(rng, 0.008, 0.03)
        parts = [
            box_between((-w / 2, 0, z0), (w / 2, t, z0 + h)),
            box_between(
                (-w / 2 + bezel, -0.004, z0 + bezel), (w / 2 - bezel, 0.001, z0 + h - bezel)
            ),
        ]
    if rng.random() < 0.5:  # electronics at the back
        depth = uniform(rng, 0.02, 0.06)
        parts.append(
            box_between(
                (-w * 0.3, t - OVERLAP_M, z0 + h * 0.25), (w * 0.3, t + depth, z0 + h * 0.75)
            )
        )
    return parts


def _mounted(
    rng: Rng, w: float, h: float, t: float, z0: float, curved: bool, tilt: float
) -> tuple[Parts, np.ndarray]:
    """A :func:`_screen` with a mounting plate at its back, tilted back by ``tilt`` degrees
    about the plate's centre; returns the parts and that centre (where a neck or an arm
    ends: it stays inside the plate whatever the tilt)."""
    zm = z0 + h * uniform(rng, 0.4, 0.6)
    pivot = np.array([0.0, t + 0.012, zm])
    parts = _screen(rng, w, h, t, z0, curved) + [
        centred_box(pivot, (0.1, 0.024 + 2 * OVERLAP_M, 0.1))
    ]
    return turned(parts, -tilt, (1, 0, 0), pivot), pivot


def _foot(rng: Rng, w: float, y: float) -> Parts:
    """A foot on the floor under a neck at ``y``: a disc, a plate or a V of two prongs."""
    style = pick_style(rng, {"disc": 0.35, "plate": 0.4, "v": 0.25})
    fd = uniform(rng, 0.15, 0.28)
    if style == "disc":
        return [rod((0, y - fd * 0.2, 0), (0, y - fd * 0.2, 0.014), fd * 0.6, 28)]
    if style == "plate":
        bw = w * uniform(rng, 0.25, 0.45)
        return [box_between((-bw / 2, y - fd * 0.75, 0), (bw / 2, y + fd * 0.25, 0.016))]
    spread = w * uniform(rng, 0.15, 0.3)
    return [beam_between((0, y, 0.012), (s * spread, y - fd, 0.012), 0.012) for s in (-1, 1)] + [
        centred_box((0, y, 0.012), (0.06, 0.06, 0.024))
    ]


def _monitor(rng: Rng) -> Parts:
    aspect = float(rng.choice([16 / 9, 16 / 10, 21 / 9, 4 / 3]))
    w, t = uniform(rng, 0.5, 0.8), uniform(rng, 0.015, 0.035)
    h = w / aspect
    curved = rng.random() < (0.6 if aspect > 2 else 0.15)
    z0 = uniform(rng, 0.06, 0.16)
    parts, pivot = _mounted(rng, w, h, t, z0, curved, uniform(rng, 0.0, 12.0))
    nw, nd = uniform(rng, 0.04, 0.1), uniform(rng, 0.02, 0.035)
    y_neck = pivot[1] + 0.005 + nd / 2
    parts.append(
        box_between((-nw / 2, y_neck - nd / 2, 0.01), (nw / 2, y_neck + nd / 2, pivot[2] + 0.02))
    )
    return parts + _foot(rng, w, y_neck)


def _arm_display(rng: Rng) -> Parts:
    aspect = float(rng.choice([16 / 9, 16 / 10, 21 / 9]))
    w, t = uniform(rng, 0.5, 0.8), uniform(rng, 0.012, 0.03)
    h = w / aspect
    curved = rng.random() < (0.5 if aspect > 2 else 0.1)
    z0 = uniform(rng, 0.15, 0.35)
    parts, pivot = _mounted(rng, w, h, t, z0, curved, uniform(rng, 0.0, 15.0))
    r = uniform(rng, 0.018, 0.03)
    side = 1 if rng.random() < 0.5 else -1
    xb = side * w * uniform(rng, 0.0, 0.35)
    yb = pivot[1] + uniform(rng, 0.2, 0.4)
    if rng.random() < 0.7:  # a pole on a desk base (or a clamp), then an elbow
        z_top = pivot[2] + uniform(rng, -0.1, 0.15)
        parts.append(centred_box((xb, yb, 0.012), (0.16, 0.16, 0.024)))
        parts.append(rod((xb, yb, 0.01), (xb, yb, z_top), r * 1.3, 12))
        joints = [np.array([xb, yb, z_top])]
    else:  # a wall plate behind the panel
        zw = pivot[2] + uniform(rng, -0.1, 0.1)
        parts.append(centred_box((xb, yb + 0.01, zw), (0.1, 0.02, 0.16)))
        joints = [np.array([xb, yb, zw])]
    elbow = np.array(
        [xb + side * uniform(rng, 0.15, 0.3), (yb + pivot[1]) / 2, (joints[0][2] + pivot[2]) / 2]
    )
    joints += [elbow, pivot]
    for a, b in zip(joints[:-1], joints[1:], strict=True):
        parts.append(rod(a, b, r, 12))
    parts += [sphere(p, r * 1.5, 1) for p in joints[:2]]
    return parts


def _tv(rng: Rng) -> Parts:
    aspect = float(rng.choice([16 / 9, 16 / 9, 21 / 9]))
    w, t = uniform(rng, 0.9, 1.3), uniform(rng, 0.02, 0.06)
    h = w / aspect
    stand = pick_style(rng, {"feet": 0.4, "pedestal": 0.35, "bench": 0.25})
    parts: Parts = []
    if stand == "bench":  # a low, wide TV bench: top slab on end panels or four posts
        hb, bw, bd = uniform(rng, 0.25, 0.45), w * uniform(rng, 0.9, 1.2), uniform(rng, 0.3, 0.45)
        y_b = t / 2
        parts.append(box_between((-bw / 2, y_b - bd / 2, hb - 0.03), (bw / 2, y_b + bd / 2, hb)))
        if rng.random() < 0.5:
            for s in (-1, 1):
                parts.append(
                    box_between(
                        (s * bw / 2, y_b - bd / 2, 0), (s * (bw / 2 - 0.03), y_b + bd / 2, hb)
                    )
                )
        else:
            for sx in (-1, 1):
                for sy in (-1, 1):
                    parts.append(
                        centred_box(
                            (sx * (bw / 2 - 0.04), y_b + sy * (bd / 2 - 0.04), hb / 2),
                            (0.04, 0.04, hb),
                        )
                    )
        if rng.random() < 0.4:  # a sound bar in front of the TV
            parts.append(
                box_between(
                    (-w * 0.3, y_b - bd / 2 + 0.01, hb - OVERLAP_M),
                    (w * 0.3, y_b - bd / 2 + 0.09, hb + 0.07),
                )
            )
        floor = hb
    else:
        floor = 0.0
    z0 = floor + uniform(rng, 0.04, 0.12)
    curved = rng.random() < 0.1 and stand != "feet"  # feet hold the ends: a flat panel
    parts += _screen(rng, w, h, t, z0, curved)
    if stand == "feet":  # two blade feet near the ends, splayed front and back
        fd = uniform(rng, 0.2, 0.35)
        for s in (-1, 1):
            x = s * w * uniform(rng, 0.3, 0.45)
            for sy in (-1, 1):
                parts.append(beam_between((x, sy * fd / 2, 0.01), (x, t / 2, z0 + 0.03), 0.02))
    else:  # a short neck on a wide base plate (on the floor or on the bench)
        nw, bw, bd = uniform(rng, 0.06, 0.15), w * uniform(rng, 0.3, 0.6), uniform(rng, 0.18, 0.3)
        parts.append(box_between((-nw / 2, t - OVERLAP_M, floor), (nw / 2, t + 0.03, z0 + h * 0.3)))
        parts.append(
            box_between(
                (-bw / 2, t / 2 - bd / 2, floor - OVERLAP_M), (bw / 2, t / 2 + bd / 2, floor + 0.02)
            )
        )
    return parts


def _crt(rng: Rng) -> Parts:
    style = pick_style(rng, {"monitor": 0.5, "tv": 0.5})
    h = uniform(rng, 0.3, 0.45)
    w, depth = h * uniform(rng, 1.15, 1.35), h * uniform(rng, 0.8, 1.1)
    taper = uniform(rng, 0.4, 0.55) if style == "monitor" else uniform(rng, 0.6, 0.8)
    front = uniform(rng, 0.05, 0.08)
    parts: Parts = []
    if style == "monitor":  # a swivel base under the body
        z0 = uniform(rng, 0.04, 0.08)
        parts.append(
            rod((0, depth * 0.3, 0), (0, depth * 0.3, 0.015), w * uniform(rng, 0.25, 0.35), 24)
        )
        parts.append(
            box_between((-w * 0.2, front * 0.5, 0.01), (w * 0.2, depth * 0.5, z0 + 0.06 * h))
        )
    else:
        z0 = 0.0
    parts.append(box_between((-w / 2, 0, z0), (w / 2, front, z0 + h)))
    m = 0.04 if style == "monitor" else uniform(rng, 0.03, 0.05)
    x_off = -w * 0.08 if style == "tv" and rng.random() < 0.5 else 0.0
    screen_w = w - 2 * m - (w * 0.16 if x_off else 0.0)
    parts.append(centred_box((x_off, -0.0035, z0 + h / 2), (screen_w, 0.009, h - 2 * m)))
    if x_off:  # a column of knobs right of the screen
        for k in range(2):
            zk = z0 + h * (0.65 - 0.3 * k)
            parts.append(
                rod((w / 2 - w * 0.08, 0.01, zk), (w / 2 - w * 0.08, -0.02, zk), 0.015, 12)
            )
    bw, bh = w * taper, h * taper
    parts.append(
        hull_of(
            [
                (s * w * 0.45, front - 0.01, z0 + h / 2 + u * h * 0.45)
                for s in (-1, 1)
                for u in (-1, 1)
            ]
            + [(s * bw / 2, depth, z0 + h * 0.55 + u * bh / 2) for s in (-1, 1) for u in (-1, 1)]
        )
    )
    if style == "tv" and rng.random() < 0.6:  # rabbit-ear antenna on the top
        yt = depth * uniform(rng, 0.55, 0.8)  # the top of the tube falls linearly to the back
        zt = z0 + 0.95 * h + (bh / 2 - 0.4 * h) * (yt - front) / (depth - front)
        parts.append(centred_box((0, yt, zt), (0.08, 0.06, 0.04)))
        length, a = uniform(rng, 0.25, 0.45), np.radians(uniform(rng, 20, 40))
        for s in (-1, 1):
            tip = (s * length * np.sin(a), yt + 0.02, zt + length * np.cos(a))
            parts.append(rod((0, yt, zt), tip, 0.005, 8))
    return parts


def _all_in_one(rng: Rng) -> Parts:
    aspect = float(rng.choice([16 / 9, 16 / 10, 21 / 9]))
    w, t = uniform(rng, 0.5, 0.75), uniform(rng, 0.012, 0.03)
    h = w / aspect
    chin = h * uniform(rng, 0.12, 0.22)
    z0 = uniform(rng, 0.06, 0.15)  # bottom of the chin
    bezel = uniform(rng, 0.008, 0.02)
    parts: Parts = [
        box_between((-w / 2, 0, z0), (w / 2, t, z0 + chin + h)),
        box_between(
            (-w / 2 + bezel, -0.004, z0 + chin + bezel),
            (w / 2 - bezel, 0.001, z0 + chin + h - bezel),
        ),
    ]
    tilt = uniform(rng, 0.0, 10.0)
    parts = turned(parts, -tilt, (1, 0, 0), (0, t, z0))
    top = z0 + chin + h * uniform(rng, 0.3, 0.5)
    y_back = t + (top - z0) * np.tan(np.radians(tilt))  # the tilted panel's back at ``top``
    base_d = uniform(rng, 0.15, 0.25)
    nw = w * uniform(rng, 0.15, 0.3)
    if rng.random() < 0.6:  # a slanted foot from the back of the panel to the desk
        parts.append(
            hull_of(
                [
                    (s * nw / 2, y, z)
                    for s in (-1, 1)
                    for (y, z) in (
                        (y_back - 0.01, top),
                        (y_back + 0.015, top),
                        (base_d * 0.6, 0),
                        (base_d * 0.6 + 0.02, 0),
                        (-base_d * 0.2, 0),
                        (-base_d * 0.2, 0.012),
                    )
                ]
            )
        )
    else:  # a base plate and a hinged arm rising to the panel's back
        parts.append(box_between((-nw, -base_d * 0.3, 0), (nw, base_d * 0.7, 0.02)))
        hinge = np.array([0, base_d * 0.6, 0.02])
        parts.append(beam_between(hinge, (0, y_back + 0.005, top), 0.015))
        parts.append(rod(hinge - (nw / 2, 0, 0), hinge + (nw / 2, 0, 0), 0.02, 12))
    return parts


_BUILD = {
    "monitor": _monitor,
    "arm": _arm_display,
    "tv": _tv,
    "crt": _crt,
    "all_in_one": _all_in_one,
}


def build_display(rng: Rng) -> Parts:
    return _BUILD[pick_style(rng, DISPLAY_KINDS)](rng)
