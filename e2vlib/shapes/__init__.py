"""Objects to reconstruct: procedural stand-ins for the paper's 13 ShapeNet categories,
mesh normalization, mesh files, and a ShapeNetCore folder reader.

ShapeNet cannot be downloaded here, so :func:`make_shape` builds a recognisable object of each
of the 13 :data:`CATEGORIES` from mesh primitives with randomized proportions and parts. Every
mesh is in the project's frame: bounding box centred at the origin, longest side 1 (metres),
z up, the object's front towards -y, x left-right. That is ShapeNetCore v2's canonical pose
(y up, front -z) turned by :func:`shapenet_to_zup`, so procedural and real objects line up.

Module map, in the order an object is made::

    primitives   boxes, rods, hulls, beams, spheres, solids of revolution, panels, bricks;
                 rotating parts (turned); Rng, Parts
    parts        random proportions and styles of parts (uniform, pick_style); joining parts
                 (union_parts)
    vehicles     builders: airplane, car, watercraft
    furniture    builders: bench, chair, sofa, table
    lamps        builder: lamp, in 4 styles (table, floor, desk, pendant)
    cabinets     builder: cabinet, in 5 sub-types (chest, shelves, open_door, on_legs, hutch)
    displays     builder: display, in 5 sub-types (monitor, arm, tv, crt, all_in_one)
    speakers     builder: speaker, in 6 sub-types (box, stand, round, wedge, system, bar)
    telephones   builder: telephone, in 5 sub-types (mobile, feature, flip, desk, cordless)
    devices      builder: rifle
    builders     category -> builder table; make_shape(category, seed); SUB_TYPES, shape_kind
    meshes       normalize_mesh, load_mesh, MESH_SUFFIXES
    shapenet     iter_shapenet (ShapeNetCore folders), shapenet_to_zup

``CATEGORIES`` is :mod:`e2vlib.paper`'s list, also importable from here because every
builder is one of them; ``SHAPENET_SYNSETS`` stays in ``paper``.

Introduced in notebooks/04_building_the_dataset.ipynb.
"""

import lazy_loader

from e2vlib.paper import CATEGORIES as CATEGORIES  # the categories a builder makes

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "builders": ["SUB_TYPES", "make_shape", "shape_kind"],
        "meshes": ["MESH_SUFFIXES", "load_mesh", "normalize_mesh"],
        "primitives": [],
        "shapenet": ["iter_shapenet", "shapenet_to_zup"],
    },
)
__all__ = sorted([*__all__, "CATEGORIES"])
