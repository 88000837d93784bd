"""The category -> builder table and :func:`make_shape`, the procedural object factory.

The builders themselves live in :mod:`e2vlib.shapes.vehicles`, :mod:`e2vlib.shapes.furniture`
and :mod:`e2vlib.shapes.devices`; each returns parts that :func:`make_shape` joins
(:func:`e2vlib.shapes.parts._union`) and normalizes (:func:`e2vlib.shapes.meshes.normalize_mesh`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

from e2vlib.paper import CATEGORIES
from e2vlib.shapes.devices import _display, _rifle, _speaker, _telephone
from e2vlib.shapes.furniture import _bench, _cabinet, _chair, _lamp, _sofa, _table
from e2vlib.shapes.meshes import normalize_mesh
from e2vlib.shapes.parts import _union
from e2vlib.shapes.primitives import Parts, Rng
from e2vlib.shapes.vehicles import _airplane, _car, _watercraft

_BUILDERS: dict[str, Callable[[Rng], Parts]] = {
    "airplane": _airplane,
    "bench": _bench,
    "cabinet": _cabinet,
    "car": _car,
    "chair": _chair,
    "display": _display,
    "lamp": _lamp,
    "speaker": _speaker,
    "rifle": _rifle,
    "sofa": _sofa,
    "table": _table,
    "telephone": _telephone,
    "watercraft": _watercraft,
}


def make_shape(category: str, seed: int) -> trimesh.Trimesh:
    """Build a random but recognisable object of one of the 13 :data:`CATEGORIES`.

    Deterministic: the same ``(category, seed)`` gives the same mesh; categories draw from
    independent random streams (``np.random.default_rng([category_index, seed])``). The
    parts (boxes, cylinders, spheres, solids of revolution, convex hulls) are merged by a
    boolean union (manifold3d), so the result is normally watertight; if the union fails
    the parts are concatenated, which :func:`e2vlib.voxels.voxelize` still fills correctly.
    The mesh is normalized (bounding box centred at the origin, longest side 1), z up,
    front towards -y, not randomly rotated: like ShapeNet, objects share one canonical pose.

    Raises ValueError for an unknown category (listing the valid ones) or a negative seed.

    Introduced in notebooks/04_building_the_dataset.ipynb.

    Examples
    --------
    >>> mesh = make_shape("chair", 0)
    >>> mesh.is_watertight, float(mesh.extents.max())
    (True, 1.0)
    >>> mesh.bounds.sum(axis=0).tolist()  # centred: min + max = 0 on every axis
    [0.0, 0.0, 0.0]
    >>> bool((make_shape("chair", 0).vertices == mesh.vertices).all())  # deterministic
    True
    >>> make_shape("chair", -1)
    Traceback (most recent call last):
    ...
    ValueError: seed must be a non-negative int, got -1
    """
    if category not in _BUILDERS:
        raise ValueError(f"unknown category {category!r}; choose one of {', '.join(CATEGORIES)}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    rng = np.random.default_rng([CATEGORIES.index(category), int(seed)])
    parts = _BUILDERS[category](rng)
    return normalize_mesh(_union(parts))
