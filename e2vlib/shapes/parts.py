"""Helpers every category builder shares: drawing a part's proportions (:func:`uniform`) and
style (:func:`pick_style`) from the random stream, and joining the parts into one mesh
(:func:`union_parts`).
"""

from __future__ import annotations

import numpy as np
import trimesh

from e2vlib.shapes.primitives import Parts, Rng


def uniform(rng: Rng, lo: float, hi: float) -> float:
    """One uniform draw in ``[lo, hi)`` as a Python float."""
    return float(rng.uniform(lo, hi))


def pick_style(rng: Rng, options: dict[str, float]) -> str:
    """One name of ``options`` drawn with probability proportional to its weight."""
    names = list(options)
    p = np.asarray(list(options.values()), float)
    return names[int(rng.choice(len(names), p=p / p.sum()))]


def union_parts(parts: Parts) -> trimesh.Trimesh:
    """Boolean union of watertight parts with manifold3d; concatenation if that fails."""
    try:
        mesh = trimesh.boolean.union(parts, engine="manifold")
        if len(mesh.faces) and mesh.is_watertight:
            return mesh
    except Exception:  # any engine failure falls back to concatenation
        pass
    return trimesh.util.concatenate(parts)
