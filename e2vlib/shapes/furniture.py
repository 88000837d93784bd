"""Procedural category builders. Furniture: bench, chair, sofa and table (lamps are in
:mod:`e2vlib.shapes.lamps`, cabinets with their sub-types in :mod:`e2vlib.shapes.cabinets`).

Each builder takes a ``numpy.random.Generator`` and returns the parts of one object
(watertight ``trimesh.Trimesh`` solids) in rough metres, z up, front towards -y; parts that
meet overlap by ``OVERLAP_M``. :func:`e2vlib.shapes.builders.make_shape` joins and normalizes
them.
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
)


def build_bench(rng: Rng) -> Parts:
    width = uniform(rng, 1.1, 1.8)
    depth = uniform(rng, 0.3, 0.45)
    h = uniform(rng, 0.38, 0.48)
    t = uniform(rng, 0.03, 0.06)
    parts: Parts = []
    slats = int(rng.choice([1, 3, 4]))
    if slats == 1:
        parts.append(box_between((-width / 2, -depth / 2, h - t), (width / 2, depth / 2, h)))
    else:
        gap = 0.012
        w = (depth - gap * (slats - 1)) / slats
        for k in range(slats):
            y = -depth / 2 + k * (w + gap)
            parts.append(box_between((-width / 2, y, h - t), (width / 2, y + w, h)))
        # cross bearers under the slats
        for x in (-0.35 * width, 0.35 * width):
            parts.append(
                box_between(
                    (x - 0.025, -depth / 2, h - t - 0.04), (x + 0.025, depth / 2, h - t + OVERLAP_M)
                )
            )
    legs = pick_style(rng, {"posts": 0.45, "panels": 0.35, "frame": 0.2})
    inset = uniform(rng, 0.03, 0.15) * width
    lw = uniform(rng, 0.035, 0.06)
    xs = (-width / 2 + inset, width / 2 - inset)
    if legs == "posts":
        for x in xs:
            for y in (-depth / 2 + lw, depth / 2 - lw):
                parts.append(
                    box_between(
                        (x - lw / 2, y - lw / 2, 0), (x + lw / 2, y + lw / 2, h - t + OVERLAP_M)
                    )
                )
        if rng.random() < 0.5:  # stretcher between the back legs
            parts.append(
                centred_box((0, depth / 2 - lw, 0.12), (width - 2 * inset, lw * 0.7, lw * 0.7))
            )
    elif legs == "panels":
        pw = uniform(rng, 0.04, 0.08)
        for x in xs:
            pd = depth * uniform(rng, 0.8, 1.0)
            parts.append(
                box_between((x - pw / 2, -pd / 2, 0), (x + pw / 2, pd / 2, h - t + OVERLAP_M))
            )
    else:  # A-frames
        for x in xs:
            for sy in (-1, 1):
                parts.append(
                    beam_between(
                        (x, sy * depth * 0.55, 0), (x, sy * depth * 0.15, h - t / 2), lw / 2
                    )
                )
            parts.append(centred_box((x, 0, 0.15), (lw, depth, lw)))
    if rng.random() < 0.6:  # backrest
        back_h = uniform(rng, 0.25, 0.42)
        tilt = uniform(rng, 0.0, 0.12)
        y_back = depth / 2 - 0.03
        if rng.random() < 0.5:
            parts.append(
                hull_of(
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
                parts.append(
                    beam_between((x, y_back, h - t), (x, y_back + tilt, h + back_h), lw / 2)
                )
            n_rails = int(rng.integers(2, 4))
            for k in range(n_rails):
                f = (k + 1) / n_rails
                parts.append(
                    centred_box(
                        (0, y_back + tilt * f, h + back_h * f - 0.04),
                        (width, 0.03, back_h / (n_rails + 1.5)),
                    )
                )
        if rng.random() < 0.5:  # arm rests
            arm_z = h + uniform(rng, 0.18, 0.25)
            for x in (-width / 2 + 0.03, width / 2 - 0.03):
                parts.append(centred_box((x, 0.0, arm_z), (0.05, depth + 0.04, 0.04)))
                parts.append(
                    centred_box(
                        (x, -depth / 2 + 0.03, (arm_z + h) / 2), (0.04, 0.04, arm_z - h + 0.04)
                    )
                )
    return parts


def build_chair(rng: Rng) -> Parts:
    w = uniform(rng, 0.4, 0.56)
    d = uniform(rng, 0.4, 0.55)
    h = uniform(rng, 0.4, 0.5)
    t = uniform(rng, 0.03, 0.08)
    parts: Parts = []
    round_seat = rng.random() < 0.15
    if round_seat:
        parts.append(rod((0, 0, h - t), (0, 0, h), max(w, d) / 2, 24))
    else:
        parts.append(box_between((-w / 2, -d / 2, h - t), (w / 2, d / 2, h)))
    legs = pick_style(
        rng,
        {
            "four": 0.5,
            "pedestal": 0.2,
            "sled": 0.0 if round_seat else 0.15,
            "panel": 0.0 if round_seat else 0.15,
        },
    )
    lw = uniform(rng, 0.025, 0.05)
    splay = uniform(rng, 0.0, 0.06) if rng.random() < 0.4 else 0.0
    if legs == "four":
        round_legs = rng.random() < 0.4
        leg_x, leg_y = (w / 2 - lw, d / 2 - lw) if not round_seat else (0.3 * w, 0.3 * d)
        for sx in (-1, 1):
            for sy in (-1, 1):
                top = (sx * leg_x, sy * leg_y, h - t / 2)
                bot = (sx * (leg_x + splay), sy * (leg_y + splay), 0)
                parts.append(
                    rod(bot, top, lw / 2, 10) if round_legs else beam_between(bot, top, lw / 2)
                )
        if rng.random() < 0.35:  # stretchers
            zs = uniform(rng, 0.1, 0.2)
            out = splay * (1 - zs / (h - t / 2))  # how far the splayed legs lean out at zs
            for sx in (-1, 1):
                parts.append(
                    centred_box(
                        (sx * (leg_x + out), 0, zs), (lw * 0.6, 2 * (leg_y + out), lw * 0.6)
                    )
                )
    elif legs == "pedestal":
        col_h = h - t / 2
        parts.append(rod((0, 0, 0.06), (0, 0, col_h), uniform(rng, 0.02, 0.035), 14))
        n_spokes = 5
        reach = uniform(rng, 0.25, 0.33)
        a0 = uniform(rng, 0, 2 * np.pi / n_spokes)
        for k in range(n_spokes):
            a = a0 + 2 * np.pi * k / n_spokes
            end = (reach * np.cos(a), reach * np.sin(a), 0.04)
            parts.append(beam_between((0, 0, 0.06), end, 0.018))
            parts.append(sphere((end[0], end[1], 0.025), 0.025, 1))
        parts.append(box_between((-0.09, -0.09, h - t - 0.04), (0.09, 0.09, h - t + OVERLAP_M)))
    elif legs == "sled":
        for sx in (-1, 1):
            x = sx * (w / 2 - 0.02)
            r = 0.012
            parts.append(rod((x, -d / 2, 0.012), (x, d / 2, 0.012), r, 8))
            parts.append(rod((x, -d / 2 + 0.02, 0.012), (x, -d / 2 + 0.04, h - t / 2), r, 8))
            parts.append(rod((x, d / 2 - 0.02, 0.012), (x, d / 2 - 0.06, h - t / 2), r, 8))
    else:  # solid side panels
        pt = uniform(rng, 0.03, 0.05)
        for sx in (-1, 1):
            parts.append(
                box_between(
                    (sx * w / 2, -d / 2 + 0.02, 0),
                    (sx * (w / 2 - pt), d / 2 - 0.02, h - t + OVERLAP_M),
                )
            )
    # back
    back = pick_style(
        rng,
        {
            "panel": 0.45,
            "slats": 0.0 if round_seat else 0.2,
            "rails": 0.0 if round_seat else 0.2,
            "low": 0.15,
        },
    )
    bh = uniform(rng, 0.12, 0.2) if back == "low" else uniform(rng, 0.35, 0.6)
    tilt = uniform(rng, 0.0, 0.12)
    bt = uniform(rng, 0.025, 0.06)
    yb = d / 2 - bt
    z0 = h
    if back in ("panel", "low"):
        bw = w * (uniform(rng, 0.85, 1.0) if not round_seat else uniform(rng, 0.5, 0.7))
        rounded = rng.random() < 0.3
        top_w = bw * (uniform(rng, 0.55, 0.8) if rounded else 1.0)
        parts.append(
            hull_of(
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
                beam_between(
                    (sx * (w / 2 - pw / 2), yb + bt / 2, z0 - t),
                    (sx * (w / 2 - pw / 2), yb + bt / 2 + tilt, z0 + bh),
                    pw / 2,
                )
            )
        top_h = uniform(rng, 0.05, 0.12)
        parts.append(
            box_between((-w / 2, yb + tilt, z0 + bh - top_h), (w / 2, yb + tilt + bt, z0 + bh))
        )
        if back == "slats":
            n = int(rng.integers(2, 6))
            for k in range(n):
                x = -w / 2 + pw + (w - 2 * pw) * (k + 0.5) / n
                parts.append(
                    beam_between(
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
                    box_between(
                        (-w / 2, yb + tilt * f, z - 0.025),
                        (w / 2, yb + tilt * f + bt * 0.7, z + 0.025),
                    )
                )
    if rng.random() < 0.35 and not round_seat:  # arms
        za = h + uniform(rng, 0.18, 0.26)
        for sx in (-1, 1):
            x = sx * (w / 2 + 0.005)
            parts.append(box_between((x - 0.025, -d / 2 + 0.02, za - 0.03), (x + 0.025, d / 2, za)))
            parts.append(
                box_between((x - 0.015, -d / 2 + 0.04, h - t), (x + 0.015, -d / 2 + 0.08, za))
            )
            parts.append(
                box_between((x - 0.015, d / 2 - 0.06, h - t), (x + 0.015, d / 2 - 0.02, za))
            )
    return parts


def build_sofa(rng: Rng) -> Parts:
    w = uniform(rng, 1.3, 2.3)
    d = uniform(rng, 0.75, 0.95)
    seat = uniform(rng, 0.38, 0.46)
    leg_h = uniform(rng, 0.05, 0.15) if rng.random() < 0.6 else 0.0
    cush = uniform(rng, 0.08, 0.15)
    back_t = uniform(rng, 0.15, 0.25)
    back_top = uniform(rng, 0.7, 0.95)
    arm = pick_style(rng, {"none": 0.1, "low": 0.3, "high": 0.35, "rolled": 0.25})
    arm_w = uniform(rng, 0.1, 0.22) if arm != "none" else 0.0
    parts: Parts = []
    z_base = seat - cush
    parts.append(box_between((-w / 2, -d / 2, max(leg_h, 0.0)), (w / 2, d / 2, z_base)))
    tilt = uniform(rng, 0.0, 0.1)
    parts.append(
        hull_of(
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
            "low": seat + uniform(rng, 0.1, 0.18),
            "high": seat + uniform(rng, 0.2, 0.3),
            "rolled": seat + uniform(rng, 0.15, 0.25),
        }[arm]
        for s in (-1, 1):
            x_out, x_in = s * w / 2, s * (w / 2 - arm_w)
            parts.append(box_between((x_in, -d / 2, max(leg_h, 0.0)), (x_out, d / 2, arm_top)))
            if arm == "rolled":
                parts.append(
                    rod(
                        ((x_in + x_out) / 2, -d / 2 - 0.01, arm_top),
                        ((x_in + x_out) / 2, d / 2, arm_top),
                        arm_w * 0.6,
                        16,
                    )
                )
    inner = w - 2 * arm_w
    n_seats = int(np.clip(round(inner / uniform(rng, 0.55, 0.8)), 1, 4))
    cw = inner / n_seats
    back_cush = rng.random() < 0.5
    for k in range(n_seats):
        x0 = -inner / 2 + k * cw + 0.01
        parts.append(
            box_between(
                (x0, -d / 2 - 0.02, z_base - OVERLAP_M),
                (x0 + cw - 0.02, d / 2 - back_t + OVERLAP_M, seat),
            )
        )
        if back_cush:
            parts.append(
                box_between(
                    (x0, d / 2 - back_t - 0.12, seat - OVERLAP_M),
                    (x0 + cw - 0.02, d / 2 - back_t + 0.02, seat + (back_top - seat) * 0.8),
                )
            )
    if rng.random() < 0.25:  # chaise longue (L-shape) on one side
        s = 1 if rng.random() < 0.5 else -1
        ext = uniform(rng, 0.5, 0.8)
        x0, x1 = s * (w / 2 - arm_w - cw), s * (w / 2)
        parts.append(box_between((x0, -d / 2 - ext, max(leg_h, 0.0)), (x1, -d / 2 + 0.01, z_base)))
        parts.append(
            box_between(
                (x0 - s * 0.01, -d / 2 - ext + 0.01, z_base - OVERLAP_M),
                (x1 - s * (arm_w + 0.01), -d / 2, seat),
            )
        )
    if leg_h > 0:
        lr = uniform(rng, 0.015, 0.03)
        xs = [-w / 2 + 0.06, w / 2 - 0.06] + ([0.0] if w > 1.8 else [])
        for x in xs:
            for y in (-d / 2 + 0.06, d / 2 - 0.06):
                parts.append(rod((x, y, 0), (x, y, leg_h + 0.01), lr, 8))
    return parts


def build_table(rng: Rng) -> Parts:
    kind = pick_style(rng, {"dining": 0.4, "coffee": 0.25, "bar": 0.1, "desk": 0.25})
    top = pick_style(
        rng, {"rect": 0.55, "round": 0.3, "oval": 0.15} if kind != "desk" else {"rect": 1.0}
    )
    h = {
        "dining": uniform(rng, 0.7, 0.78),
        "coffee": uniform(rng, 0.35, 0.5),
        "bar": uniform(rng, 0.95, 1.1),
        "desk": uniform(rng, 0.7, 0.78),
    }[kind]
    if top == "round":
        w = d = 2 * (uniform(rng, 0.25, 0.4) if kind == "bar" else uniform(rng, 0.4, 0.65))
    else:
        w = uniform(rng, 0.9, 1.9)
        d = w * uniform(rng, 0.4, 0.75)
    t = uniform(rng, 0.02, 0.06)
    parts: Parts = []
    if top == "rect":
        parts.append(box_between((-w / 2, -d / 2, h - t), (w / 2, d / 2, h)))
    else:
        disc = rod((0, 0, h - t), (0, 0, h), 0.5, 40)
        disc.apply_scale((w, d, 1.0))
        parts.append(disc)
    legs = pick_style(
        rng,
        {
            "four": 0.55,
            "pedestal": 0.25 if top != "rect" or kind == "coffee" else 0.1,
            "trestle": 0.2 if top == "rect" else 0.0,
        },
    )
    lw = uniform(rng, 0.03, 0.07)
    if kind == "desk" and rng.random() < 0.6:  # drawer pedestal on one side, legs on the other
        s = 1 if rng.random() < 0.5 else -1
        pw = uniform(rng, 0.3, 0.45)
        parts.append(
            box_between(
                (s * (w / 2 - 0.02), -d / 2 + 0.03, 0),
                (s * (w / 2 - pw), d / 2 - 0.02, h - t + OVERLAP_M),
            )
        )
        for y in (-d / 2 + lw, d / 2 - lw):
            parts.append(
                box_between(
                    (-s * (w / 2 - lw) - lw / 2, y - lw / 2, 0),
                    (-s * (w / 2 - lw) + lw / 2, y + lw / 2, h - t + OVERLAP_M),
                )
            )
        return parts
    if legs == "four":
        inset = uniform(rng, 0.02, 0.12) * min(w, d) + lw
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
        splay = uniform(rng, 0.0, 0.06) if rng.random() < 0.3 else 0.0
        for x, y in corners:
            nrm = np.hypot(x, y)
            bot = (x + splay * x / nrm, y + splay * y / nrm, 0)
            if round_legs:
                parts.append(rod(bot, (x, y, h - t / 2), lw / 2, 10))
            else:
                parts.append(beam_between(bot, (x, y, h - t / 2), lw / 2))
        if top == "rect" and rng.random() < 0.5:  # apron
            ah = uniform(rng, 0.05, 0.12)
            for s in (-1, 1):
                parts.append(
                    box_between(
                        (-w / 2 + inset, s * (d / 2 - inset) - 0.01, h - t - ah),
                        (w / 2 - inset, s * (d / 2 - inset) + 0.01, h - t + OVERLAP_M),
                    )
                )
                parts.append(
                    box_between(
                        (s * (w / 2 - inset) - 0.01, -d / 2 + inset, h - t - ah),
                        (s * (w / 2 - inset) + 0.01, d / 2 - inset, h - t + OVERLAP_M),
                    )
                )
        if rng.random() < (0.5 if kind == "coffee" else 0.15):  # lower shelf
            zs = uniform(rng, 0.08, 0.2)
            out = splay * (1 - zs / (h - t / 2))  # how far the splayed legs lean out at zs
            ex, ey = w / 2 - inset + out, d / 2 - inset + out
            if top == "rect":
                parts.append(box_between((-ex, -ey, zs), (ex, ey, zs + 0.02)))
            else:
                shelf = rod((0, 0, zs), (0, 0, zs + 0.02), 1.0, 32)
                shelf.apply_scale((ex, ey, 1.0))
                parts.append(shelf)
    elif legs == "pedestal":
        cr = uniform(rng, 0.03, 0.08)
        parts.append(rod((0, 0, 0), (0, 0, h - t / 2), cr, 16))
        if rng.random() < 0.5:
            parts.append(
                rod((0, 0, 0), (0, 0, 0.03), uniform(rng, 0.2, 0.35) * max(w, d) + 0.1, 28)
            )
        else:
            reach = 0.35 * max(w, d)
            n = int(rng.choice([3, 4]))
            for k in range(n):
                a = 2 * np.pi * k / n + np.pi / 4
                parts.append(
                    beam_between((0, 0, 0.03), (reach * np.cos(a), reach * np.sin(a), 0.03), 0.025)
                )
    else:  # trestle: two end frames and a stretcher
        inset = uniform(rng, 0.05, 0.2) * w
        for s in (-1, 1):
            x = s * (w / 2 - inset)
            if rng.random() < 0.5:
                parts.append(
                    box_between(
                        (x - lw / 2, -d / 2 + 0.05, 0),
                        (x + lw / 2, d / 2 - 0.05, h - t + OVERLAP_M),
                    )
                )
            else:
                parts.append(box_between((x - lw / 2, -lw, 0), (x + lw / 2, lw, h - t + OVERLAP_M)))
                parts.append(
                    box_between((x - lw / 2, -d / 2 + 0.05, 0), (x + lw / 2, d / 2 - 0.05, 0.05))
                )
                parts.append(
                    box_between(
                        (x - lw / 2, -d / 2 + 0.08, h - t - 0.05),
                        (x + lw / 2, d / 2 - 0.08, h - t + OVERLAP_M),
                    )
                )
        parts.append(
            box_between((-w / 2 + inset, -0.02, h * 0.3), (w / 2 - inset, 0.02, h * 0.3 + 0.05))
        )
    return parts
