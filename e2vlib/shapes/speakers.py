"""Procedural loudspeakers in six sub-types (:data:`SPEAKER_KINDS`), the structural variety
of ShapeNet's speaker category rather than one box of random proportions:

``box``     a bookshelf or floor-standing (tower) box with its drivers on the front
``stand``   a bookshelf box on a stand (one or two posts, base and top plates)
``round``   a solid of revolution: a cylinder, an orb on a foot, a tall column, a horn
``wedge``   a sloped body: a stage-monitor wedge on the floor or a tapering pyramid
``system``  a slim tower with a separate woofer box, side by side on a base or stacked
``bar``     a long, low sound bar

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
    lathe,
    rod,
    sphere,
)

SPEAKER_KINDS = {
    "box": 0.2,
    "stand": 0.17,
    "round": 0.17,
    "wedge": 0.16,
    "system": 0.16,
    "bar": 0.14,
}
"""Speaker sub-types and their probabilities (the first draw of :func:`build_speaker`)."""


def _enclosure(
    w: float,
    d: float,
    h: float,
    x: float = 0.0,
    z0: float = 0.0,
    slant: float = 0.0,
    bevel: float = 0.0,
) -> trimesh.Trimesh:
    """A box of ``w x d x h`` centred on ``(x, 0)`` from ``z0`` up, its top edge at the back
    pulled forward by ``slant`` and its front edges bevelled by ``bevel``."""
    return hull_of(
        [
            (x + sx, y, z)
            for sx in (-w / 2, w / 2)
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


def _driver(center, normal, r: float) -> Parts:
    """A driver of radius ``r`` on a front face: a ring standing 1.2 cm proud of the face
    through ``center`` (normal ``normal``, pointing out) and a dust cap."""
    c, n = np.asarray(center, float), np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    return [rod(c - n * 0.01, c + n * 0.012, r, 24), sphere(c + n * 0.012, r * 0.35, 1)]


def _front_drivers(
    rng: Rng, w: float, d: float, z0: float, h: float, n_woofers: int, x: float = 0.0
) -> Parts:
    """A tweeter over ``n_woofers`` woofers, stacked on the front face ``y = -d/2``."""
    woofer, tweeter = w * uniform(rng, 0.3, 0.42), w * uniform(rng, 0.1, 0.16)
    z = z0 + h - h * 0.12 - tweeter
    spots = [(z, tweeter)]
    z -= tweeter + woofer * 1.15
    for _ in range(n_woofers):
        spots.append((z, woofer))
        z -= woofer * 2.3
    parts: Parts = []
    for zc, r in spots:
        if zc - r > z0:
            parts += _driver((x, -d / 2, zc), (0, -1, 0), r)
    return parts


def _box_speaker(rng: Rng) -> Parts:
    tower = rng.random() < 0.45
    if tower:
        w, d, h = uniform(rng, 0.18, 0.28), uniform(rng, 0.25, 0.38), uniform(rng, 0.85, 1.15)
    else:
        w, d, h = uniform(rng, 0.16, 0.3), uniform(rng, 0.18, 0.32), uniform(rng, 0.25, 0.45)
    parts: Parts = []
    z0 = 0.0
    if tower and rng.random() < 0.7:  # a plinth on four spikes
        z0 = uniform(rng, 0.04, 0.08)
        pw, pd = w + uniform(rng, 0.04, 0.1), d + uniform(rng, 0.02, 0.06)
        parts.append(box_between((-pw / 2, -pd / 2, z0 - 0.025), (pw / 2, pd / 2, z0 + OVERLAP_M)))
        for sx in (-1, 1):
            for sy in (-1, 1):
                parts.append(
                    rod(
                        (sx * pw / 2.4, sy * pd / 2.4, 0),
                        (sx * pw / 2.4, sy * pd / 2.4, z0 - 0.02),
                        0.012,
                        8,
                    )
                )
    slant = uniform(rng, 0.0, 0.3) * d if rng.random() < 0.35 else 0.0
    parts.append(_enclosure(w, d, h, 0.0, z0, slant, uniform(rng, 0.0, 0.02)))
    parts += _front_drivers(rng, w, d, z0, h, int(rng.integers(2, 4)) if tower else 1)
    return parts


def _stand_speaker(rng: Rng) -> Parts:
    w, d, h = uniform(rng, 0.15, 0.26), uniform(rng, 0.18, 0.3), uniform(rng, 0.25, 0.4)
    zs = uniform(rng, 0.5, 0.8)  # top of the stand
    parts: Parts = [
        centred_box((0, 0, 0.012), (w * uniform(rng, 1.2, 1.6), d * uniform(rng, 1.1, 1.4), 0.024)),
        centred_box((0, 0, zs - 0.01), (w * 0.9, d * 0.9, 0.02)),
    ]
    posts = pick_style(rng, {"one": 0.5, "two": 0.35, "frame": 0.15})
    if posts == "one":
        parts.append(rod((0, 0, 0.02), (0, 0, zs - 0.015), uniform(rng, 0.02, 0.04), 12))
    elif posts == "two":
        for sy in (-1, 1):
            parts.append(centred_box((0, sy * d * 0.3, zs / 2), (0.04, 0.04, zs - 0.02)))
    else:  # a ladder frame: two side posts
        for sx in (-1, 1):
            parts.append(centred_box((sx * w * 0.4, 0, zs / 2), (0.025, d * 0.5, zs - 0.02)))
    parts.append(_enclosure(w, d, h, 0.0, zs - OVERLAP_M, 0.0, uniform(rng, 0.0, 0.015)))
    parts += _front_drivers(rng, w, d, zs, h, 1)
    return parts


def _round_speaker(rng: Rng) -> Parts:
    style = pick_style(rng, {"cylinder": 0.3, "orb": 0.25, "column": 0.25, "horn": 0.2})
    if style == "cylinder":  # a smart speaker: a can with a rounded or tapered top
        r, h = uniform(rng, 0.06, 0.1), uniform(rng, 0.12, 0.35)
        top_r = r * uniform(rng, 0.55, 1.0)
        return [
            lathe([(0, 0), (r * 0.9, 0), (r, 0.02), (r, h * 0.8), (top_r, h), (0, h)], sections=28),
            rod((0, 0, h - OVERLAP_M), (0, 0, h + 0.006), top_r * 0.7, 28),
        ]
    if style == "orb":  # a ball on a short foot or a thin stalk
        r = uniform(rng, 0.08, 0.15)
        stalk = uniform(rng, 0.02, 0.04) if rng.random() < 0.55 else uniform(rng, 0.12, 0.35)
        zc = stalk + r * 0.9
        parts = [
            rod((0, 0, 0), (0, 0, 0.02), r * uniform(rng, 0.5, 0.9), 24),
            rod((0, 0, 0.01), (0, 0, zc), r * 0.15, 12),
            sphere((0, 0, zc), r, 3),
        ]
        return parts + _driver((0, -r * 0.85, zc), (0, -1, 0), r * 0.5)
    if style == "column":  # a tall omnidirectional column on a base disc
        r, h = uniform(rng, 0.05, 0.09), uniform(rng, 0.6, 1.0)
        base_r = r * uniform(rng, 1.4, 2.2)
        return [
            rod((0, 0, 0), (0, 0, 0.03), base_r, 28),
            lathe(
                [(0, 0), (r, 0), (r, h * 0.9), (r * 0.6, h), (0, h)],
                (0, 0, 0.03 - OVERLAP_M),
                sections=28,
            ),
        ]
    # horn: a flare opening forwards from a driver block, held up by a post
    bw, bh = uniform(rng, 0.12, 0.2), uniform(rng, 0.1, 0.18)
    L, mouth = uniform(rng, 0.25, 0.45), uniform(rng, 0.12, 0.22)
    zc = mouth + uniform(rng, 0.02, 0.1)
    flare = [(0, 0), (0.03, 0), (0.035, L * 0.4), (mouth * 0.5, L * 0.8), (mouth, L), (0, L)]
    return [
        box_between((-bw / 2, 0, 0), (bw / 2, bw, zc + bh / 2)),
        lathe(flare, (0, 0.01, zc), (0, -1, 0), 24),
        centred_box((0, -L * 0.45, 0.01), (0.05, L * 0.5, 0.02)),
        box_between((-0.015, -L * 0.45 - 0.015, 0.01), (0.015, -L * 0.45 + 0.015, zc)),
    ]


def _wedge_speaker(rng: Rng) -> Parts:
    if rng.random() < 0.55:  # a stage monitor: lies on the floor, its sloped face up-front
        w, depth = uniform(rng, 0.4, 0.65), uniform(rng, 0.3, 0.5)
        h_front, h_back = uniform(rng, 0.04, 0.1), uniform(rng, 0.22, 0.38)
        y_top = depth / 2 - uniform(rng, 0.05, 0.15)
        body = hull_of(
            [
                (sx * w / 2, y, z)
                for sx in (-1, 1)
                for (y, z) in (
                    (-depth / 2, 0),
                    (depth / 2, 0),
                    (-depth / 2, h_front),
                    (y_top, h_back),
                    (depth / 2, h_back),
                )
            ]
        )
        a = np.array([0, -depth / 2, h_front])
        b = np.array([0, y_top, h_back])
        n = np.array([0, -(b - a)[2], (b - a)[1]])  # out of the sloped face (-y, +z)
        parts = [body]
        woofer = min(w, np.linalg.norm(b - a)) * uniform(rng, 0.28, 0.38)
        for f, r in ((0.45, woofer), (0.85, woofer * 0.35)):
            x = -w * 0.18 if f < 0.5 else w * 0.28
            parts += _driver(a + (b - a) * f + (x, 0, 0), n, r)
        return parts
    # a pyramid: the front leans back and the top is narrower and shallower
    w, d, h = uniform(rng, 0.2, 0.35), uniform(rng, 0.22, 0.35), uniform(rng, 0.3, 0.6)
    tw, td = w * uniform(rng, 0.45, 0.8), d * uniform(rng, 0.35, 0.7)
    body = hull_of(
        [(sx * w / 2, sy * d / 2, 0) for sx in (-1, 1) for sy in (-1, 1)]
        + [(sx * tw / 2, d / 2 - td + (sy + 1) / 2 * td, h) for sx in (-1, 1) for sy in (-1, 1)]
    )
    a, b = np.array([0, -d / 2, 0]), np.array([0, d / 2 - td, h])
    n = np.array([0, -(b - a)[2], (b - a)[1]])
    parts = [body]
    for f, r in ((0.3, w * 0.3), (0.72, w * 0.12)):
        parts += _driver(a + (b - a) * f, n, r)
    return parts


def _system_speaker(rng: Rng) -> Parts:
    tw, td, th = uniform(rng, 0.1, 0.16), uniform(rng, 0.1, 0.16), uniform(rng, 0.55, 1.0)
    s = uniform(rng, 0.3, 0.45)  # the woofer cube's side
    parts: Parts = []
    if rng.random() < 0.35:  # the tower stands on the woofer
        parts.append(_enclosure(s, s, s * uniform(rng, 0.9, 1.15), 0.0, 0.0))
        z_top = parts[-1].bounds[1][2]
        parts.append(_enclosure(tw, td, th * 0.6, 0.0, z_top - OVERLAP_M))
        parts += _front_drivers(rng, tw, td, z_top, th * 0.6, 1)
        parts += _driver((0, -s / 2, z_top / 2), (0, -1, 0), s * uniform(rng, 0.3, 0.4))
        return parts
    gap = uniform(rng, 0.04, 0.2)
    side = 1 if rng.random() < 0.5 else -1
    xt, xw = side * (gap + tw) / 2, -side * (gap + s) / 2
    depth = max(td, s)
    parts.append(
        box_between(
            (min(xt - tw / 2, xw - s / 2) - 0.02, -depth / 2 - 0.02, 0),
            (max(xt + tw / 2, xw + s / 2) + 0.02, depth / 2 + 0.02, 0.025),
        )
    )
    parts.append(_enclosure(tw, td, th, xt, 0.025 - OVERLAP_M))
    parts += _front_drivers(rng, tw, td, 0.025, th, int(rng.integers(1, 4)), xt)
    woofer_box = _enclosure(s, s, s * uniform(rng, 0.9, 1.15), xw, 0.025 - OVERLAP_M)
    parts.append(woofer_box)
    parts += _driver((xw, -s / 2, 0.025 + s / 2), (0, -1, 0), s * uniform(rng, 0.3, 0.4))
    return parts


def _bar_speaker(rng: Rng) -> Parts:
    w, d, h = uniform(rng, 0.8, 1.1), uniform(rng, 0.08, 0.13), uniform(rng, 0.06, 0.1)
    parts: Parts = [_enclosure(w, d, h, 0.0, 0.0, 0.0, uniform(rng, 0.0, 0.02))]
    n = int(rng.integers(2, 5))
    for k in range(n):
        x = -w / 2 + w * (k + 0.5) / n
        parts.append(rod((x, -d / 2 - 0.006, h / 2), (x, -d / 2 + 0.01, h / 2), h * 0.3, 20))
    return parts


_BUILD = {
    "box": _box_speaker,
    "stand": _stand_speaker,
    "round": _round_speaker,
    "wedge": _wedge_speaker,
    "system": _system_speaker,
    "bar": _bar_speaker,
}


def build_speaker(rng: Rng) -> Parts:
    return _BUILD[pick_style(rng, SPEAKER_KINDS)](rng)
