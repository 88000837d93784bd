"""Reading a ShapeNetCore folder: :func:`iter_shapenet` lists the models of the 13 categories
(synset ids in :data:`e2vlib.paper.SHAPENET_SYNSETS`), :func:`shapenet_to_zup` turns a model
from ShapeNet's pose (y up, front -z) into ours (z up, front -y).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np
import trimesh

from e2vlib.paper import CATEGORIES, SHAPENET_SYNSETS


def shapenet_to_zup(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Turn a ShapeNetCore v2 mesh (y up, front -z) into our frame (z up, front -y).

    ShapeNetCore v2's ``model_normalized.obj`` files are aligned with +y up and the front
    towards -z. The proper rotation ``(x, y, z) -> (-x, z, y)`` (180 degrees about the axis
    ``(0, 1, 1)``) sends up to +z and front to -y; x flips sign, which is harmless for the
    many categories symmetric about the y-z plane and keeps the mesh un-mirrored. Returns a
    copy. (ShapeNetCore v1 used a different, partly mirrored alignment; check visually.)

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    out = mesh.copy()
    rot = np.array([[-1.0, 0, 0, 0], [0, 0, 1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
    out.apply_transform(rot)
    return out


def iter_shapenet(
    root: str | os.PathLike, categories: Iterable[str] | None = None
) -> Iterator[tuple[str, str, Path]]:
    """Yield ``(category, model_id, mesh_path)`` for the 13 categories in a ShapeNetCore folder.

    Reads ShapeNetCore v2 (``root/<synset>/<model_id>/models/model_normalized.obj``) and
    v1 (``root/<synset>/<model_id>/model.obj``) layouts; synset folders of other categories
    are skipped, models without a mesh file are skipped. ``categories`` limits the output to
    some names of :data:`CATEGORIES`. Output is sorted by category order, then model id.

    Raises FileNotFoundError if ``root`` is not a folder, ValueError for unknown categories.

    Introduced in notebooks/04_building_the_dataset.ipynb.
    """
    root_p = Path(root)
    if not root_p.is_dir():
        raise FileNotFoundError(f"ShapeNetCore folder not found: {root_p}")
    if categories is None:
        wanted = list(CATEGORIES)
    else:
        wanted = [categories] if isinstance(categories, str) else list(categories)
        bad = [c for c in wanted if c not in CATEGORIES]
        if bad:
            raise ValueError(f"unknown categories {bad}; choose from {', '.join(CATEGORIES)}")
    by_name = {name: synset for synset, name in SHAPENET_SYNSETS.items()}
    for name in CATEGORIES:
        if name not in wanted:
            continue
        folder = root_p / by_name[name]
        if not folder.is_dir():
            continue
        for model_dir in sorted(p for p in folder.iterdir() if p.is_dir()):
            for candidate in (
                model_dir / "models" / "model_normalized.obj",
                model_dir / "model.obj",
            ):
                if candidate.is_file():
                    yield name, model_dir.name, candidate
                    break
