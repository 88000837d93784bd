"""The category -> builder table, :func:`make_shape` (the procedural object factory) and
:func:`shape_kind` (which sub-type of its category an object is, :data:`SUB_TYPES`).

The builders themselves live in :mod:`e2vlib.shapes.vehicles`, :mod:`e2vlib.shapes.furniture`,
:mod:`e2vlib.shapes.cabinets`, :mod:`e2vlib.shapes.displays`, :mod:`e2vlib.shapes.speakers`,
:mod:`e2vlib.shapes.telephones` and :mod:`e2vlib.shapes.devices`; each returns parts that
:func:`make_shape` joins (:func:`e2vlib.shapes.parts._union`) and normalizes
(:func:`e2vlib.shapes.meshes.normalize_mesh`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

from e2vlib.paper import CATEGORIES
from e2vlib.shapes.cabinets import CABINET_KINDS, build_cabinet
from e2vlib.shapes.devices import build_rifle
from e2vlib.shapes.displays import DISPLAY_KINDS, build_display
from e2vlib.shapes.furniture import build_bench, build_chair, build_sofa, build_table
from e2vlib.shapes.lamps import build_lamp
from e2vlib.shapes.meshes import normalize_mesh
from e2vlib.shapes.parts import pick_style, union_parts
from e2vlib.shapes.primitives import Parts, Rng
from e2vlib.shapes.speakers import SPEAKER_KINDS, build_speaker
from e2vlib.shapes.telephones import TELEPHONE_KINDS, build_telephone
from e2vlib.shapes.vehicles import build_airplane, build_car, build_watercraft

_BUILDERS: dict[str, Callable[[Rng], Parts]] = {
    "airplane": build_airplane,
    "bench": build_bench,
    "cabinet": build_cabinet,
    "car": build_car,
    "chair": build_chair,
    "display": build_display,
    "lamp": build_lamp,
    "speaker": build_speaker,
    "rifle": build_rifle,
    "sofa": build_sofa,
    "table": build_table,
    "telephone": build_telephone,
    "watercraft": build_watercraft,
}

SUB_TYPES: dict[str, dict[str, float]] = {
    "cabinet": CABINET_KINDS,
    "display": DISPLAY_KINDS,
    "speaker": SPEAKER_KINDS,
    "telephone": TELEPHONE_KINDS,
}
"""Categories built from named sub-types: category -> {sub-type: probability}. Each builder
draws its sub-type first, so :func:`shape_kind` knows it without building the mesh. (The
other categories vary their parts and styles too, without a named sub-type.)"""


def _check(category: str, seed: int) -> np.random.Generator:
    """The random stream of ``(category, seed)``, or ValueError for bad input."""
    if category not in _BUILDERS:
        raise ValueError(f"unknown category {category!r}; choose one of {', '.join(CATEGORIES)}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    return np.random.default_rng([CATEGORIES.index(category), int(seed)])


def make_shape(category: str, seed: int) -> trimesh.Trimesh:
    """Build a random but recognisable object of one of the 13 :data:`CATEGORIES`.

    Deterministic: the same ``(category, seed)`` gives the same mesh; categories draw from
    independent random streams (``np.random.default_rng([category_index, seed])``). The
    parts (boxes, cylinders, spheres, solids of revolution, convex hulls) are merged by a
    boolean union (manifold3d), so the result is normally watertight; if the union fails
    the parts are concatenated, which :func:`e2vlib.voxels.voxelize` still fills correctly.
    The mesh is normalized (bounding box centred at the origin, longest side 1), z up,
    front towards -y, not randomly rotated: like ShapeNet, objects share one canonical pose.

    Cabinets, displays, speakers and telephones come in named sub-types with parts the
    others lack (open shelves, an open door, a panel on an arm, a speaker on a stand, a
    handset on a cradle...): :data:`SUB_TYPES` lists them, :func:`shape_kind` says which
    one a seed gives.

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
    rng = _check(category, seed)
    parts = _BUILDERS[category](rng)
    return normalize_mesh(union_parts(parts))


def shape_kind(category: str, seed: int) -> str:
    """The sub-type (a key of ``SUB_TYPES[category]``) of ``make_shape(category, seed)``.

    Cheap: it replays only the first random draw of the builder, not the mesh. Raises
    ValueError for a category without named sub-types (listing those that have them), an
    unknown category or a negative seed. bench/bench_categories.py draws one object of each
    sub-type with it (docs/figures/category_gallery.png).

    Examples
    --------
    >>> sorted(SUB_TYPES["cabinet"])
    ['chest', 'hutch', 'on_legs', 'open_door', 'shelves']
    >>> shape_kind("cabinet", 0) in SUB_TYPES["cabinet"]
    True
    >>> shape_kind("chair", 0)
    Traceback (most recent call last):
    ...
    ValueError: chair has no named sub-types; only cabinet, display, speaker, telephone have
    """
    rng = _check(category, seed)
    if category not in SUB_TYPES:
        raise ValueError(f"{category} has no named sub-types; only {', '.join(SUB_TYPES)} have")
    return pick_style(rng, SUB_TYPES[category])
