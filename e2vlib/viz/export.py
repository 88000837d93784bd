"""A predicted grid as files other tools read: a surface mesh and seven formats.

:func:`probability_mesh` (marching cubes of the probability grid, in metres) and
:func:`export_reconstruction` (png, vti, vtu, vtp, binvox, obj, stl;
:data:`EXPORT_SUFFIXES`).

Introduced in notebooks/08_visualizing_in_3d.ipynb.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from e2vlib import paper
from e2vlib.metrics import grid_surface
from e2vlib.viz.scenes import screenshot, view_voxels, voxel_mesh


def probability_mesh(probabilities: np.ndarray, threshold: float = paper.IOU_THRESHOLD):
    """A closed triangle mesh of the surface ``probabilities == threshold`` (marching cubes).

    The grid ``(R, R, R)`` (indexed x, y, z over ``[-0.5, 0.5]^3``, value of voxel ``i``
    at its centre ``-0.5 + (i + 0.5) / R``) is padded with a layer of zeros so the surface
    closes at the border, and vertices are clipped to the cube. For a 0/1 grid at threshold
    0.5 the surface runs exactly along the voxel faces between occupied and empty voxels
    (edges and corners cut diagonally). Returns a watertight ``trimesh.Trimesh`` in metres
    with outward normals. Introduced in notebooks/08_visualizing_in_3d.ipynb.

    Examples
    --------
    >>> grid = np.zeros((4, 4, 4))
    >>> grid[1:3, 1:3, 1:3] = 1.0  # a 2 x 2 x 2 block of voxels: a 0.5 m cube
    >>> mesh = probability_mesh(grid, threshold=0.5)
    >>> mesh.is_watertight, mesh.bounds.tolist()
    (True, [[-0.25, -0.25, -0.25], [0.25, 0.25, 0.25]])
    >>> round(float(mesh.volume), 4)  # 0.125 m^3 less the bevelled edges and corners
    0.0885
    """
    import trimesh

    grid = np.asarray(probabilities, dtype=np.float32)
    if grid.ndim != 3 or len(set(grid.shape)) != 1:
        raise ValueError(f"probabilities must be a cube (R, R, R), got shape {grid.shape}")
    if not 0 < threshold < 1:
        raise ValueError(f"threshold must lie strictly between 0 and 1, got {threshold!r}")
    if not np.any(grid >= threshold):
        raise ValueError(f"no voxel reaches the threshold {threshold:g}; lower it to get a mesh")
    verts, faces = grid_surface(grid, threshold)
    mesh = trimesh.Trimesh(np.clip(verts, -0.5, 0.5), faces, process=True)
    if mesh.volume < 0:  # make the normals point outwards whatever skimage's convention
        mesh.invert()
    return mesh


EXPORT_SUFFIXES = {"png": ".png", "vti": ".vti", "vtu": ".vtu", "vtp": ".vtp",
                   "binvox": ".binvox", "obj": ".obj", "stl": ".stl"}
"""What :func:`export_reconstruction` writes, by format name."""


def export_reconstruction(probabilities: np.ndarray, out_dir,
                          threshold: float = paper.IOU_THRESHOLD,
                          name: str = "reconstruction", formats=tuple(EXPORT_SUFFIXES)):
    """Write a predicted grid ``(R, R, R)`` in formats other tools read; return the paths.

    ``formats`` (default: all) picks from :data:`EXPORT_SUFFIXES`:

    * ``png``: a picture of the voxels ``>= threshold`` (:func:`view_voxels`, off screen);
    * ``vti``: the whole probability grid as VTK image data (cell data ``"probability"``),
      for volume rendering or thresholding in ParaView;
    * ``vtu``: the voxels ``>= threshold`` as cubes (:func:`voxel_mesh`), ``vtp`` their
      outer surface as polygons;
    * ``binvox``: the thresholded grid (:func:`e2vlib.voxels.write_binvox`), the format of
      ShapeNetVox32 / Pix2Vox labels;
    * ``obj`` and ``stl``: a smooth surface from :func:`probability_mesh` for Blender,
      MeshLab or a 3D printer (metres; the object fits the 1 m cube).

    Every file goes to a temporary file in ``out_dir`` first and is then renamed, so an
    existing export is never left half-written. Returns ``{format: Path}``.
    Introduced in notebooks/08_visualizing_in_3d.ipynb.

    Examples
    --------
    >>> import tempfile
    >>> grid = np.zeros((4, 4, 4), np.float32)
    >>> grid[1:3, 1:3, 1:3] = 0.9
    >>> paths = export_reconstruction(grid, tempfile.mkdtemp(), name="block",
    ...                               formats=("vti", "binvox", "obj"))
    >>> {fmt: path.name for fmt, path in paths.items()}
    {'vti': 'block.vti', 'binvox': 'block.binvox', 'obj': 'block.obj'}
    >>> from e2vlib.voxels import read_binvox
    >>> int(read_binvox(paths["binvox"]).sum())  # the 8 voxels >= 0.3
    8
    """

    import pyvista as pv

    from e2vlib.files import atomic_path
    from e2vlib.voxels import write_binvox

    grid = np.asarray(probabilities, dtype=np.float32)
    if grid.ndim != 3 or len(set(grid.shape)) != 1:
        raise ValueError(f"probabilities must be a cube (R, R, R), got shape {grid.shape}")
    unknown = sorted(set(formats) - set(EXPORT_SUFFIXES))
    if unknown:
        raise ValueError(f"unknown formats {unknown}; choose from {sorted(EXPORT_SUFFIXES)}")
    if not name or "/" in name or name.startswith("."):
        raise ValueError(f"name must be a plain file stem such as 'chair', got {name!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {fmt: out / f"{name}{EXPORT_SUFFIXES[fmt]}" for fmt in formats}
    size = grid.shape[0]
    cubes = voxel_mesh(grid, threshold) if {"vtu", "vtp"} & set(formats) else None
    surface = probability_mesh(grid, threshold) if {"obj", "stl"} & set(formats) else None
    for fmt, path in paths.items():
        if fmt == "png":
            plotter = view_voxels(grid, threshold, off_screen=True,
                                  title=f"{name}: p >= {threshold:g}")
            try:
                screenshot(plotter, path)
            finally:
                plotter.close()
        elif fmt == "binvox":
            write_binvox(path, grid >= threshold)  # atomic itself
        else:
            with atomic_path(path) as tmp:
                if fmt == "vti":
                    image = pv.ImageData(dimensions=(size + 1,) * 3, spacing=(1.0 / size,) * 3,
                                         origin=(-0.5, -0.5, -0.5))
                    image.cell_data["probability"] = grid.ravel(order="F")
                    image.save(tmp)
                elif fmt == "vtu":
                    cubes.save(tmp)
                elif fmt == "vtp":
                    cubes.extract_surface(algorithm=None).save(tmp)
                else:
                    surface.export(tmp, file_type=fmt)
    return paths
