"""Procedural category builders. Vehicles: airplane, car and watercraft.

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
    panel_mesh,
    rod,
)


def build_airplane(rng: Rng) -> Parts:
    length = 1.0
    r = uniform(rng, 0.04, 0.075)
    nose = uniform(rng, 0.08, 0.18)
    tail_up = uniform(rng, 0.0, 0.8) * r  # upswept tail cone
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
    parts = [lathe(fuselage, (0, y0, 0), (0, 1, 0), sections=20)]
    if tail_up > 0:  # raise the rear with an upswept cone
        parts.append(
            hull_of(
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
    kind = pick_style(rng, {"airliner": 0.55, "delta": 0.2, "straight": 0.25})
    z_wing = {"low": -0.55 * r, "mid": 0.0, "high": 0.65 * r}[
        pick_style(rng, {"low": 0.5, "mid": 0.2, "high": 0.3})
    ]
    if kind == "delta":
        half_span = uniform(rng, 0.25, 0.38)
        chord_root = uniform(rng, 0.45, 0.6)
        chord_tip = uniform(rng, 0.02, 0.08)
        sweep = half_span * np.tan(np.radians(uniform(rng, 45, 62)))
        y_le = uniform(rng, -0.12, 0.0)
        dihedral = 0.0
    else:
        half_span = uniform(rng, 0.42, 0.65) if kind == "airliner" else uniform(rng, 0.5, 0.7)
        chord_root = uniform(rng, 0.16, 0.26)
        taper = uniform(rng, 0.25, 0.5) if kind == "airliner" else uniform(rng, 0.6, 1.0)
        chord_tip = chord_root * taper
        sweep_deg = uniform(rng, 22, 38) if kind == "airliner" else uniform(rng, -3, 8)
        sweep = half_span * np.tan(np.radians(sweep_deg))
        y_le = uniform(rng, -0.2, -0.05)
        dihedral = half_span * np.tan(np.radians(uniform(rng, -2, 7)))
    t_wing = 0.1 * chord_root
    for side in (-1, 1):
        parts.append(
            panel_mesh(
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
    r_eng = uniform(rng, 0.5, 0.8) * r
    for frac in spans:
        for side in (-1, 1):
            x = side * frac * half_span
            y_front = y_le + frac * sweep - 0.5 * r_eng * 2.5
            z = z_wing + frac * dihedral - r_eng * 1.3
            parts.append(rod((x, y_front, z), (x, y_front + 5 * r_eng, z), r_eng, 16))
            parts.append(
                centred_box(
                    (x, y_front + 3 * r_eng, z + 0.8 * r_eng),
                    (0.2 * r_eng, 2.5 * r_eng, 1.2 * r_eng),
                )
            )
    # tail: vertical fin and horizontal stabilizers (conventional or T-tail)
    fin_h = uniform(rng, 0.12, 0.22)
    fin_c = uniform(rng, 0.12, 0.22)
    fin_sweep = fin_h * np.tan(np.radians(uniform(rng, 25, 50)))
    y_fin = length / 2 - fin_c - fin_sweep * 0.7
    y_fin = min(y_fin, length / 2 - fin_c * 0.9)
    z_base = 0.3 * r + tail_up * 0.5
    parts.append(
        panel_mesh(
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
        hs_span = uniform(rng, 0.14, 0.24)
        hs_c = uniform(rng, 0.08, 0.14)
        z_hs = z_base + fin_h * 0.95 if t_tail else 0.2 * r + tail_up * 0.6
        y_hs = y_fin + fin_sweep * 0.95 if t_tail else length / 2 - hs_c - 0.05
        for side in (-1, 1):
            parts.append(
                panel_mesh(
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


def build_car(rng: Rng) -> Parts:
    kind = pick_style(
        rng, {"sedan": 0.3, "hatchback": 0.2, "suv": 0.2, "pickup": 0.15, "sports": 0.15}
    )
    length = 1.0
    y_f, y_r = -length / 2, length / 2
    w = uniform(rng, 0.38, 0.46)
    rw = {"suv": uniform(rng, 0.085, 0.11), "pickup": uniform(rng, 0.085, 0.11)}.get(
        kind, uniform(rng, 0.07, 0.09)
    )
    clear = rw * uniform(rng, 0.55, 0.85)
    belt = clear + {
        "suv": uniform(rng, 0.17, 0.22),
        "pickup": uniform(rng, 0.16, 0.2),
        "sports": uniform(rng, 0.1, 0.13),
    }.get(kind, uniform(rng, 0.13, 0.17))
    roof = belt + {
        "suv": uniform(rng, 0.14, 0.19),
        "pickup": uniform(rng, 0.13, 0.17),
        "sports": uniform(rng, 0.07, 0.1),
    }.get(kind, uniform(rng, 0.1, 0.14))
    nose_drop = uniform(rng, 0.02, 0.06)
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
        hull_of(
            [
                (s * hw * (0.93 if z > belt - 0.02 else 1.0), y, z)
                for (y, z) in profile_lo
                for s in (-1, 1)
            ]
        )
    )
    # cabin (greenhouse)
    cab = {
        "sedan": (uniform(rng, -0.22, -0.12), uniform(rng, 0.18, 0.3)),
        "hatchback": (uniform(rng, -0.18, -0.08), y_r - 0.04),
        "suv": (uniform(rng, -0.22, -0.14), y_r - 0.02),
        "pickup": (uniform(rng, -0.22, -0.14), uniform(rng, 0.0, 0.08)),
        "sports": (uniform(rng, -0.15, -0.05), uniform(rng, 0.15, 0.3)),
    }[kind]
    ws_rake = {"suv": 0.12, "pickup": 0.1, "sports": 0.25}.get(kind, 0.18) * uniform(rng, 0.8, 1.2)
    rear_rake = {"sedan": 0.17, "sports": 0.2}.get(kind, 0.04) * uniform(rng, 0.7, 1.3)
    if kind == "pickup":
        rear_rake = 0.01
    yb0, yb1 = cab
    top0, top1 = yb0 + ws_rake, max(yb0 + ws_rake + 0.1, yb1 - rear_rake)
    cw = hw * uniform(rng, 0.8, 0.9)
    parts.append(
        hull_of(
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
        bed_h = uniform(rng, 0.06, 0.1)
        for s in (-1, 1):
            parts.append(
                box_between(
                    (s * hw * 0.93, yb1 + 0.01, belt - 0.01),
                    (s * (hw * 0.93 - 0.025), y_r - 0.01, belt + bed_h),
                )
            )
        parts.append(
            box_between(
                (-hw * 0.93, y_r - 0.035, belt - 0.01), (hw * 0.93, y_r - 0.01, belt + bed_h)
            )
        )
    if kind == "sports" and rng.random() < 0.6:  # rear wing
        z_w = belt + uniform(rng, 0.04, 0.08)
        parts.append(centred_box((0, y_r - 0.05, z_w), (w * 0.9, 0.07, 0.012)))
        for s in (-1, 1):
            parts.append(
                centred_box(
                    (s * w * 0.3, y_r - 0.05, (z_w + belt) / 2), (0.015, 0.04, z_w - belt + 0.01)
                )
            )
    # wheels
    wheelbase = uniform(rng, 0.56, 0.66)
    y_shift = uniform(rng, -0.03, 0.03)
    tw = uniform(rng, 0.055, 0.08)
    for y in (-wheelbase / 2 + y_shift, wheelbase / 2 + y_shift):
        for s in (-1, 1):
            parts.append(rod((s * (hw - tw + 0.012), y, rw), (s * (hw + 0.012), y, rw), rw, 20))
    return parts


def build_watercraft(rng: Rng) -> Parts:
    kind = pick_style(
        rng, {"ship": 0.3, "sailboat": 0.25, "speedboat": 0.2, "canoe": 0.1, "cargo": 0.15}
    )
    length = 1.0
    beam = {
        "canoe": uniform(rng, 0.1, 0.14),
        "cargo": uniform(rng, 0.14, 0.2),
        "ship": uniform(rng, 0.12, 0.18),
    }.get(kind, uniform(rng, 0.2, 0.3))
    depth = {"canoe": uniform(rng, 0.05, 0.07), "cargo": uniform(rng, 0.08, 0.11)}.get(
        kind, uniform(rng, 0.07, 0.12)
    )
    bow = {"canoe": 0.4, "cargo": 0.15}.get(
        kind, uniform(rng, 0.3, 0.45)
    )  # fraction of length tapering
    stern_w = 0.0 if kind == "canoe" else uniform(rng, 0.6, 0.95)
    keel = uniform(rng, 0.25, 0.55)
    sheer = uniform(rng, 0.0, 0.04)
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
    hull = hull_of(pts)
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
        y0 = uniform(rng, -0.15, 0.15)
        sl, sw, sh = uniform(rng, 0.2, 0.35), beam * 0.75, uniform(rng, 0.05, 0.08)
        z = deck
        for _ in range(n):
            parts.append(
                box_between((-sw / 2, y0 - sl / 2, z - 0.01), (sw / 2, y0 + sl / 2, z + sh))
            )
            y_top = y0
            z += sh
            sl *= uniform(rng, 0.5, 0.8)
            sw *= 0.85
            y0 -= sl * 0.1
        for k in range(int(rng.integers(0, 3))):
            yf = y0 + 0.12 + 0.07 * k
            parts.append(
                rod(
                    (0, yf, deck - OVERLAP_M),
                    (0, yf, z + uniform(rng, 0.03, 0.08)),
                    uniform(rng, 0.02, 0.03),
                    16,
                )
            )
        parts.append(
            rod((0, y_top, z - OVERLAP_M), (0, y_top, z + uniform(rng, 0.08, 0.2)), 0.006, 8)
        )
    elif kind == "cargo":
        yb = uniform(rng, 0.25, 0.35)
        parts.append(
            box_between(
                (-beam * 0.4, yb - 0.05, deck - 0.01),
                (beam * 0.4, yb + 0.05, deck + uniform(rng, 0.12, 0.2)),
            )
        )
        n_stacks = int(rng.integers(3, 7))
        span = (yb - 0.08) - (-0.3)
        for k in range(n_stacks):
            y = -0.3 + span * (k + 0.5) / n_stacks
            hgt = uniform(rng, 0.02, 0.07)
            parts.append(
                centred_box((0, y, deck + hgt / 2), (beam * 0.8, span / n_stacks * 0.9, hgt + 0.01))
            )
    elif kind == "sailboat":
        mast_h = uniform(rng, 0.7, 1.2)
        ym = uniform(rng, -0.15, 0.0)
        parts.append(rod((0, ym, deck - OVERLAP_M), (0, ym, deck + mast_h), 0.008, 8))
        boom = uniform(rng, 0.3, 0.45)
        zb = deck + uniform(rng, 0.06, 0.12)
        parts.append(rod((0, ym, zb), (0, ym + boom, zb), 0.006, 8))
        # main sail: a thin triangle behind the mast; jib in front
        parts.append(
            hull_of(
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
                hull_of(
                    [
                        (s * 0.003, y, z)
                        for s in (-1, 1)
                        for (y, z) in (
                            (yj, deck - OVERLAP_M),
                            (ym, deck - OVERLAP_M),
                            (ym, deck + mast_h * 0.8),
                        )
                    ]
                )
            )
        parts.append(
            box_between(
                (-beam * 0.3, ym + 0.03, deck - 0.01),
                (beam * 0.3, ym + uniform(rng, 0.15, 0.3), deck + 0.04),
            )
        )
    elif kind == "speedboat":
        yc = uniform(rng, -0.1, 0.1)
        cl = uniform(rng, 0.2, 0.35)
        ch = uniform(rng, 0.05, 0.1)
        parts.append(
            hull_of(
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
                box_between(
                    (-0.025, length / 2 - 0.01, deck * 0.2), (0.025, length / 2 + 0.05, deck + 0.06)
                )
            )
    else:  # canoe thwarts
        for y in (-0.2, 0.0, 0.2):
            parts.append(centred_box((0, y, deck - 0.012), (beam * 0.9, 0.02, 0.01)))
    return parts
