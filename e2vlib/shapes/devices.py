"""Procedural category builder: the rifle. (The other devices, with their sub-types, have a
module each: :mod:`e2vlib.shapes.displays`, :mod:`e2vlib.shapes.speakers` and
:mod:`e2vlib.shapes.telephones`.)

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
    hull_of,
    lathe,
    rod,
)


def build_rifle(rng: Rng) -> Parts:
    # muzzle towards -y, butt towards +y
    parts: Parts = []
    kind = pick_style(rng, {"sniper": 0.3, "assault": 0.4, "shotgun": 0.3})
    rec_len = uniform(rng, 0.18, 0.28)
    rec_h = uniform(rng, 0.05, 0.08)
    rec_w = uniform(rng, 0.03, 0.045)
    barrel = {
        "sniper": uniform(rng, 0.4, 0.55),
        "assault": uniform(rng, 0.25, 0.4),
        "shotgun": uniform(rng, 0.35, 0.5),
    }[kind]
    br = {"shotgun": uniform(rng, 0.012, 0.018)}.get(kind, uniform(rng, 0.007, 0.012))
    y_rec0 = 0.0  # receiver front
    zc = 0.0  # bore height
    parts.append(
        box_between(
            (-rec_w / 2, y_rec0, zc - rec_h * 0.6), (rec_w / 2, y_rec0 + rec_len, zc + rec_h * 0.4)
        )
    )
    parts.append(rod((0, y_rec0 - barrel, zc), (0, y_rec0 + 0.01, zc), br, 12))
    if rng.random() < 0.5:  # muzzle device
        parts.append(
            rod((0, y_rec0 - barrel - 0.03, zc), (0, y_rec0 - barrel + 0.01, zc), br * 1.5, 12)
        )
    # fore-end / handguard
    hg = barrel * uniform(rng, 0.35, 0.6)
    if kind == "shotgun":
        parts.append(
            rod(
                (0, y_rec0 - barrel * 0.9, zc - br * 1.8),
                (0, y_rec0 + 0.02, zc - br * 1.8),
                br * 0.9,
                12,
            )
        )
        parts.append(
            rod((0, y_rec0 - hg - 0.05, zc - br * 2), (0, y_rec0 - 0.08, zc - br * 2), br * 1.8, 12)
        )
    else:
        hr = uniform(rng, 0.016, 0.026)
        parts.append(
            box_between((-hr, y_rec0 - hg, zc - hr * 1.3), (hr, y_rec0 + 0.01, zc + hr * 0.8))
        )
    # stock: butt drops below the bore line
    y_s0 = y_rec0 + rec_len
    s_len = uniform(rng, 0.22, 0.32)
    drop = uniform(rng, 0.02, 0.07)
    butt_h = uniform(rng, 0.1, 0.15)
    sw = rec_w * 0.9
    grip_style = pick_style(rng, {"pistol": 0.55, "straight": 0.45})
    stock_kind = pick_style(rng, {"solid": 0.7, "skeleton": 0.3 if kind == "assault" else 0.05})
    top0 = zc + rec_h * 0.3
    if stock_kind == "solid":
        neck_h = rec_h * (0.9 if grip_style == "pistol" else 1.4)
        parts.append(
            hull_of(
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
            parts.append(rod(p, q, r, 8))
        parts.append(
            box_between(
                (-sw / 2, y_s0 + s_len - 0.02, top0 - drop - butt_h),
                (sw / 2, y_s0 + s_len, top0 - drop),
            )
        )
    if grip_style == "pistol":
        g0 = np.array([0, y_s0 - 0.05, zc - rec_h * 0.5])
        g1 = g0 + np.array([0, uniform(rng, 0.03, 0.05), -uniform(rng, 0.08, 0.11)])
        parts.append(beam_between(g0, g1, 0.015))
    # trigger guard: a bar under the receiver held by two posts
    zg = zc - rec_h * 0.6
    parts.append(box_between((-0.004, y_s0 - 0.11, zg - 0.03), (0.004, y_s0 - 0.06, zg - 0.022)))
    for yg in (y_s0 - 0.11, y_s0 - 0.068):
        parts.append(box_between((-0.004, yg, zg - 0.03), (0.004, yg + 0.008, zg + OVERLAP_M)))
    if kind != "shotgun" and rng.random() < 0.75:  # magazine
        m_len = uniform(rng, 0.04, 0.06)
        m_h = uniform(rng, 0.06, 0.14)
        curve = uniform(rng, 0.0, 0.05)
        ym = y_rec0 + rec_len * 0.25
        parts.append(
            hull_of(
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
        sr = uniform(rng, 0.014, 0.022)
        s_l = uniform(rng, 0.18, 0.3)
        zsc = zc + rec_h * 0.4 + sr + uniform(rng, 0.015, 0.03)
        ys = y_rec0 + rec_len / 2 - s_l / 2
        parts.append(rod((0, ys, zsc), (0, ys + s_l, zsc), sr, 14))
        parts.append(
            lathe(
                [(0, 0), (sr * 1.6, 0), (sr * 1.6, 0.04), (sr, 0.07), (0, 0.07)],
                (0, ys, zsc),
                (0, 1, 0),
                14,
            )
        )
        for f in (0.3, 0.7):
            y = ys + s_l * f
            parts.append(box_between((-0.006, y - 0.01, zc + rec_h * 0.35), (0.006, y + 0.01, zsc)))
    elif kind != "shotgun":  # iron sights / carry handle
        parts.append(
            box_between((-0.005, y_rec0 - hg, zc), (0.005, y_rec0 - hg + 0.015, zc + 0.04))
        )
    if kind == "sniper" and rng.random() < 0.4:  # bipod
        y_b = y_rec0 - hg * 0.8
        for s in (-1, 1):
            parts.append(rod((0, y_b, zc - 0.02), (s * 0.05, y_b - 0.04, zc - 0.2), 0.005, 8))
    return parts
