"""Procedural category builders. Devices with a front: display, rifle, speaker and telephone.

Each builder takes a ``numpy.random.Generator`` and returns the parts of one object
(watertight ``trimesh.Trimesh`` solids) in rough metres, z up, front towards -y; parts that
meet overlap by ``_EPS``. :func:`e2vlib.shapes.builders.make_shape` joins and normalizes them.
The order of the random draws is part of the output: changing it changes every mesh.
"""

from __future__ import annotations

import numpy as np

from e2vlib.shapes.parts import _pick, _u
from e2vlib.shapes.primitives import (
    _EPS,
    Parts,
    Rng,
    _beam,
    _box,
    _cbox,
    _hull,
    _lathe,
    _rod,
    _sphere,
)


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
