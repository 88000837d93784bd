"""PyVista scenes of voxels and meshes: the lessons' plotter, its camera, screenshots.

Each ``view_*`` function builds and returns a ``pyvista.Plotter`` without showing it: call
``.show()`` in a notebook (the backend comes from the environment variable
PYVISTA_JUPYTER_BACKEND: "trame" gives an interactive view in JupyterLab, "static" an
image) or :func:`screenshot` for a picture as an array or PNG file. ``off_screen=None``
lets pyvista decide (off screen inside notebooks and where PYVISTA_OFF_SCREEN is set).
Lessons compose their own scenes from the same parts: :func:`new_plotter`,
:func:`add_voxels`, :func:`aim_at_object`. pyvista loads on the first call.

Introduced in notebooks/07_evaluation.ipynb and notebooks/08_visualizing_in_3d.ipynb.
"""

from __future__ import annotations

import numpy as np

from e2vlib import paper
from e2vlib._headless import headless_opengl_window, offline_wasm_bundle
from e2vlib.viz.style import (
    MESH_COLOR,
    OBJECT_VIEW,
    PROBABILITY_CMAP,
    TRUTH_COLOR,
    UNIT_CUBE_BOUNDS,
)


def new_plotter(off_screen: bool | None = None, window_size=(500, 500), shape=(1, 1)):
    """An empty ``pyvista.Plotter`` in the lessons' style: white, evenly lit, no borders.

    ``window_size`` is ``(width, height)`` in pixels for the whole window, ``shape``
    ``(rows, cols)`` of subplots (select one with ``plotter.subplot(row, col)``).
    "Three lights" (key, fill and back light) keeps dense voxel views readable on every
    side. ``off_screen=None`` lets pyvista decide (off screen in notebooks). On a machine
    without a display the headless OpenGL window is chosen first
    (:func:`headless_opengl_window`). Every ``view_*`` function starts from this plotter.
    Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> plotter = new_plotter(off_screen=True, window_size=(64, 48))
    >>> plotter.window_size, plotter.shape, plotter.background_color.name
    ([64, 48], (1, 1), 'white')
    >>> plotter.close()
    """
    import pyvista as pv

    headless_opengl_window()
    offline_wasm_bundle()
    plotter = pv.Plotter(off_screen=off_screen, window_size=window_size, shape=shape,
                         border=False, lighting="three lights")
    plotter.set_background("white")
    return plotter


def aim_at_object(plotter, direction=OBJECT_VIEW, zoom: float = 1.0) -> None:
    """Point the active subplot's camera at the origin from ``direction``, +z up.

    ``direction`` is any vector (only its direction counts; the default looks from the
    front-right and above, the objects facing -y); the camera is then moved so the unit
    cube :data:`UNIT_CUBE_BOUNDS` fills the view, and ``zoom > 1`` moves closer.
    Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> plotter = new_plotter(off_screen=True)
    >>> aim_at_object(plotter, (0, -1, 0))  # from the front (-y)
    >>> position, focus, up = plotter.camera_position
    >>> position[0] == position[2] == 0 and position[1] < 0, focus, up
    (True, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    >>> plotter.close()
    """
    direction = np.asarray(direction, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(direction)) or not np.any(direction):
        raise ValueError(f"direction must be a finite, non-zero 3-vector, got {direction}")
    if np.linalg.norm(np.cross(direction, (0.0, 0.0, 1.0))) < 1e-9 * np.linalg.norm(direction):
        raise ValueError(f"direction {direction} points along z, the camera's up direction; "
                         "tilt it, e.g. (0, -1, 3) to look from above")
    if not zoom > 0:
        raise ValueError(f"zoom must be positive, got {zoom!r}")
    plotter.camera_position = [tuple(float(v) for v in direction), (0.0, 0.0, 0.0),
                               (0.0, 0.0, 1.0)]
    plotter.reset_camera(bounds=UNIT_CUBE_BOUNDS)
    if zoom != 1.0:
        plotter.camera.zoom(zoom)


def screenshot(plotter, path=None, scale: int | None = None) -> np.ndarray:
    """Render ``plotter`` headless and return the image ``(H, W, 3)`` uint8.

    With ``path`` the image is also written as a PNG (temporary file, then renamed).
    Works for plotters created with ``off_screen=None`` that have not been shown yet:
    they are switched to off-screen rendering first. The plotter stays open, so it can
    still be shown or saved again. Introduced in notebooks/08_visualizing_in_3d.ipynb.

    Examples
    --------
    >>> plotter = new_plotter(off_screen=True, window_size=(64, 48))
    >>> image = screenshot(plotter)  # an empty scene: all white
    >>> image.shape, image.dtype, image[0, 0].tolist()
    ((48, 64, 3), dtype('uint8'), [255, 255, 255])
    >>> plotter.close()
    """
    if getattr(plotter, "render_window", None) is None:
        raise ValueError("this plotter is closed; build the scene again before a screenshot")
    if plotter._first_time and not plotter.off_screen:  # never shown: render off screen
        plotter.off_screen = True
        plotter.ren_win.SetOffScreenRendering(1)
    image = np.asarray(plotter.screenshot(return_img=True, scale=scale))[..., :3].copy()
    if path is not None:
        from pathlib import Path

        from PIL import Image

        from e2vlib.files import atomic_path

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            Image.fromarray(image).save(tmp, format="PNG", optimize=True)
    return image


def _unit_cube_floor():
    """A light 4 x 4 grid on the floor of the unit cube (z = -0.5), 0.25 m squares."""
    import pyvista as pv

    return pv.Plane(center=(0.0, 0.0, -0.5), i_size=1.0, j_size=1.0, i_resolution=4,
                    j_resolution=4)


def _is_binary(grid: np.ndarray) -> bool:
    return bool(np.all((grid == 0) | (grid == 1)))


def voxel_mesh(grid: np.ndarray, threshold: float = 0.5):
    """The voxels of ``grid`` (indexed x, y, z) with value ``>= threshold`` as cubes.

    Returns a ``pyvista.UnstructuredGrid`` placed in the unit cube ``[-0.5, 0.5]^3`` (the
    frame of the meshes), with the voxel values in ``cell_data["value"]``. Empty
    selections return an empty grid. Introduced in notebooks/04_building_the_dataset.ipynb.

    Examples
    --------
    >>> grid = np.zeros((4, 4, 4))
    >>> grid[1:3, 1:3, 1:3] = 1.0  # a 2 x 2 x 2 block: 8 voxels
    >>> cubes = voxel_mesh(grid)
    >>> cubes.n_cells, [float(b) for b in cubes.bounds]  # 0.25 m voxels in the unit cube
    (8, [-0.25, 0.25, -0.25, 0.25, -0.25, 0.25])
    """
    import pyvista as pv

    grid = np.asarray(grid, dtype=np.float32)
    if grid.ndim != 3 or len(set(grid.shape)) != 1:
        raise ValueError(f"grid must be a cube (R, R, R), got shape {grid.shape}")
    size = grid.shape[0]
    image = pv.ImageData(dimensions=(size + 1,) * 3, spacing=(1.0 / size,) * 3,
                         origin=(-0.5, -0.5, -0.5))
    image.cell_data["value"] = grid.ravel(order="F")  # VTK runs x fastest
    return image.threshold(threshold, scalars="value")


def add_voxels(plotter, grid: np.ndarray, threshold: float = 0.5, color=TRUTH_COLOR,
               cmap: str | None = None, show_edges: bool = True, floor: bool = True,
               scalar_bar: bool = True) -> int:
    """Add the cubes of ``grid >= threshold`` to the active subplot; return their count.

    ``grid`` is ``(R, R, R)`` (indexed x, y, z over the unit cube, as :func:`voxel_mesh`).
    The cubes take one ``color``, or with ``cmap`` (e.g. ``"viridis"``) are coloured by
    value from 0 to 1, with a probability bar unless ``scalar_bar=False`` (leave it out
    in a grid of small panels). ``floor`` draws a light 4 x 4 grid (0.25 m squares) on
    the floor of the cube; an empty selection says so in the corner. The camera is left
    alone: follow with :func:`aim_at_object`.
    Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> grid = np.zeros((4, 4, 4))
    >>> grid[1:3, 1:3, 1:3] = 1.0  # a 2 x 2 x 2 block: 8 voxels
    >>> plotter = new_plotter(off_screen=True)
    >>> add_voxels(plotter, grid), add_voxels(plotter, grid, threshold=1.5)  # none >= 1.5
    (8, 0)
    >>> plotter.close()
    """
    cubes = voxel_mesh(grid, threshold)
    if floor:
        plotter.add_mesh(_unit_cube_floor(), style="wireframe", color="#c8c8c8", line_width=1,
                         lighting=False)
    if cubes.n_cells == 0:
        plotter.add_text(f"no voxel >= {threshold:g}", position="upper_right", font_size=8,
                         color="gray")
        return 0
    style = {"show_edges": show_edges, "edge_color": "#5a5a5a", "line_width": 0.5,
             "smooth_shading": False}
    if cmap is not None:
        plotter.add_mesh(cubes, scalars="value", cmap=cmap, clim=(0.0, 1.0),
                         show_scalar_bar=scalar_bar,
                         scalar_bar_args={"title": "probability", "vertical": True,
                                          "position_x": 0.86, "position_y": 0.1,
                                          "height": 0.55, "width": 0.06, "fmt": "%.1f"},
                         **style)
    else:
        plotter.add_mesh(cubes, color=color, **style)
    return int(cubes.n_cells)


def view_voxels(grid: np.ndarray, threshold: float = 0.5, color=TRUTH_COLOR,
                cmap: str | None = "auto", show_edges: bool = True, title: str | None = None,
                off_screen: bool | None = None, window_size=(500, 500)):
    """3D scene of a ``(R, R, R)`` voxel grid (indexed x, y, z over ``[-0.5, 0.5]^3``).

    Cubes with ``grid >= threshold`` are drawn with their edges, above a light grid on the
    floor of the unit cube (0.25 m squares). ``cmap="auto"`` colours a grid of
    probabilities (values other than 0/1) by value with viridis, and a 0/1 label in one
    ``color``; pass a colormap name or ``None`` to choose. Returns the plotter (not shown).
    Introduced in notebooks/08_visualizing_in_3d.ipynb.

    Examples
    --------
    >>> grid = np.zeros((4, 4, 4))
    >>> grid[1:3, 1:3, 1:3] = 1.0  # a 2 x 2 x 2 block: 8 voxels
    >>> plotter = view_voxels(grid, off_screen=True, window_size=(64, 64))
    >>> image = screenshot(plotter)
    >>> image.shape, bool((image[32, 32] < 255).any())  # the block in the middle
    ((64, 64, 3), True)
    >>> plotter.close()
    """
    grid = np.asarray(grid, dtype=np.float32)
    if cmap == "auto":
        cmap = None if _is_binary(grid) else PROBABILITY_CMAP
    plotter = new_plotter(off_screen, window_size)
    count = add_voxels(plotter, grid, threshold, color=color, cmap=cmap,
                       show_edges=show_edges)
    plotter.add_text(title if title is not None else f"{count} voxels >= {threshold:g}",
                     font_size=11, color="black")
    aim_at_object(plotter)
    return plotter


def _as_grid_list(grids, name: str) -> list[np.ndarray]:
    """One grid ``(R, R, R)`` or a sequence/stack of them -> list of float32 grids."""
    items = [grids] if np.ndim(grids) == 3 else list(grids)
    out = [np.asarray(g, dtype=np.float32) for g in items]
    for g in out:
        if g.ndim != 3 or len(set(g.shape)) != 1:
            raise ValueError(f"each of {name} must be a cube (R, R, R), got shape {g.shape}")
    return out


def view_reconstructions(truths, predictions, threshold: float = paper.IOU_THRESHOLD,
                         titles=None, off_screen: bool | None = None, panel_size: int = 300,
                         link: bool = True):
    """Ground truth (top row) above prediction (bottom row), one column per object.

    The layout of the paper's Figure 4. ``truths`` and ``predictions`` are one grid
    ``(R, R, R)`` or sequences/stacks of ``n`` grids; predictions are probabilities,
    drawn where ``>= threshold`` and coloured by value (one probability bar, in the last
    panel), each panel titled with its IoU at ``threshold``. With ``link`` all ``2 n``
    views share one camera: turning one turns all. Returns the plotter with
    ``shape == (2, n)`` (not shown).
    Introduced in notebooks/08_visualizing_in_3d.ipynb.

    Examples
    --------
    >>> grid = np.zeros((4, 4, 4))
    >>> grid[1:3, 1:3, 1:3] = 1.0  # a 2 x 2 x 2 block: 8 voxels
    >>> plotter = view_reconstructions([grid, grid], [0.9 * grid, 0.5 * grid],
    ...                                off_screen=True, panel_size=64)
    >>> plotter.shape  # truths above, predictions below, one column per object
    (2, 2)
    >>> plotter.close()
    """
    from e2vlib.metrics import iou

    truths = _as_grid_list(truths, "truths")
    predictions = _as_grid_list(predictions, "predictions")
    if len(truths) != len(predictions) or not truths:
        raise ValueError(f"need as many truths as predictions (and at least one), got "
                         f"{len(truths)} and {len(predictions)}")
    n = len(truths)
    titles = [None] * n if titles is None else list(titles)
    if len(titles) != n:
        raise ValueError(f"titles must have {n} entries (one per column), got {len(titles)}")
    plotter = new_plotter(off_screen, (panel_size * n, 2 * panel_size), shape=(2, n))
    for col, (gt, pred, title) in enumerate(zip(truths, predictions, titles, strict=True)):
        plotter.subplot(0, col)
        add_voxels(plotter, gt, 0.5)
        plotter.add_text(f"{title}\nground truth" if title else "ground truth", font_size=9,
                         color="black")
        plotter.subplot(1, col)
        add_voxels(plotter, pred, threshold, cmap=PROBABILITY_CMAP, scalar_bar=col == n - 1)
        plotter.add_text(f"prediction\nIoU@{threshold:g} = {float(iou(pred, gt, threshold)):.2f}",
                         font_size=9, color="black")
        aim_at_object(plotter, zoom=1.15)
    plotter.subplot(0, 0)
    aim_at_object(plotter, zoom=1.15)
    if link:
        plotter.link_views()
    return plotter


def view_mesh_voxels(mesh, voxels: np.ndarray, mesh_opacity: float = 0.55,
                     off_screen: bool | None = None, window_size=(600, 600)):
    """A mesh (semi-transparent) with the outer edges of its voxel label drawn over it.

    ``mesh`` is a normalized ``trimesh.Trimesh`` or ``pyvista.PolyData``; ``voxels`` a
    ``(R, R, R)`` grid over ``[-0.5, 0.5]^3``. Shows how the 32^3 label approximates the
    surface: thin parts become one-voxel slabs, curved parts staircases. Returns the
    plotter (not shown). Introduced in notebooks/08_visualizing_in_3d.ipynb.

    Examples
    --------
    >>> grid = np.zeros((4, 4, 4))
    >>> grid[1:3, 1:3, 1:3] = 1.0  # a 2 x 2 x 2 block: 8 voxels
    >>> import trimesh
    >>> box = trimesh.creation.box((0.5, 0.5, 0.5))  # the block's own shape
    >>> plotter = view_mesh_voxels(box, grid, off_screen=True, window_size=(64, 64))
    >>> screenshot(plotter).shape
    (64, 64, 3)
    >>> plotter.close()
    """
    import pyvista as pv

    if not 0 < mesh_opacity <= 1:
        raise ValueError(f"mesh_opacity must be in (0, 1], got {mesh_opacity!r}")
    poly = pv.wrap(mesh)
    shell = voxel_mesh(voxels, 0.5).extract_surface(algorithm=None)
    plotter = new_plotter(off_screen, window_size)
    plotter.add_mesh(_unit_cube_floor(), style="wireframe", color="#c8c8c8", line_width=1,
                     lighting=False)
    plotter.add_mesh(poly, color=MESH_COLOR, opacity=mesh_opacity, smooth_shading=False)
    if shell.n_cells:
        plotter.add_mesh(shell, style="wireframe", color="#1f3b73", line_width=1)
    plotter.add_text(f"mesh and its {int(np.count_nonzero(np.asarray(voxels) >= 0.5))} voxels",
                     font_size=11, color="black")
    aim_at_object(plotter)
    return plotter
