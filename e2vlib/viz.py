"""Plotting helpers: events in space-time, event rates, frame grids, animations, voxels.

Matplotlib functions (``plot_*``, ``show_frame``, ``animate_frames``) give static figures
that work headless; each draws into an ``ax``/``fig`` it is given or makes one, and
returns it. PyVista functions (``view_*``) build 3D scenes and return the plotter unshown:
``.show()`` is interactive in JupyterLab (trame) and an image under
``PYVISTA_JUPYTER_BACKEND=static``; :func:`screenshot` renders one off screen. Lessons
compose their own scenes from the same parts: :func:`new_plotter`, :func:`add_voxels`,
:func:`aim_at_object`. :func:`interactive_figure` puts widgets on a matplotlib picture
that also shows (at its current values) where no widget can run.
:func:`export_reconstruction` writes a prediction for other tools.
Colours: ON events orange and OFF events blue (:data:`ON_COLOR`, :data:`OFF_COLOR`, the
Okabe-Ito pair, distinct for every common colour-vision deficiency and, being light against
dark, in grey print); signed ON - OFF images use :data:`POLARITY_CMAP` (blue, white, orange);
probabilities use viridis (its lightness rises monotonically, so grey print keeps the order).

This module draws what it is given; it never reads datasets or runs models (the README's
pictures, which do both, live in :mod:`e2vlib.figures`).

Introduced in notebooks/01_events.ipynb, notebooks/02_event_frames.ipynb and
notebooks/08_visualizing_in_3d.ipynb.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation
from matplotlib.colors import LinearSegmentedColormap

from e2vlib import paper
from e2vlib._headless import headless_opengl_window, offline_wasm_bundle  # re-exported
from e2vlib.events import check_sensor_size, validate
from e2vlib.frames import accumulate

ON_COLOR, OFF_COLOR = "#e69f00", "#0072b2"  # Okabe-Ito orange and blue
POLARITY_CMAP = LinearSegmentedColormap.from_list("e2v_polarity", [OFF_COLOR, "#ffffff", ON_COLOR])
"""Signed ON - OFF counts: OFF blue (dark in grey), zero white, ON orange (mid grey)."""
PROBABILITY_CMAP = "viridis"


def _subsample(events: np.ndarray, max_events: int, seed: int = 0) -> np.ndarray:
    """At most ``max_events`` events, picked uniformly at random, kept in time order."""
    if len(events) <= max_events:
        return events
    keep = np.sort(np.random.default_rng(seed).choice(len(events), max_events, replace=False))
    return events[keep]


def plot_events_3d(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    ax=None,
    max_events: int = 20_000,
    marker_size: float = 1.0,
):
    """3D space-time scatter: x across, time (ms from the first event) in depth, y up.

    ON events orange, OFF blue; at most ``max_events`` points are drawn (a random subset).
    ``y`` is flipped so the picture is upright like the camera image. Returns the axes.
    Introduced in notebooks/01_events.ipynb.
    """
    width, height = check_sensor_size(sensor_size)
    validate(events, (width, height))
    if ax is None:
        ax = plt.figure(figsize=(8, 6)).add_subplot(projection="3d")
    shown = _subsample(events, max_events)
    t_ms = (shown["t"] - (events["t"][0] if len(events) else 0)) / 1e3
    for polarity, color, label in ((1, ON_COLOR, "ON (+1)"), (-1, OFF_COLOR, "OFF (-1)")):
        sel = shown["p"] == polarity
        ax.scatter(shown["x"][sel], t_ms[sel], height - 1 - shown["y"][sel].astype(int),
                   s=marker_size, c=color, label=label, depthshade=False, linewidths=0)
    ax.set_xlabel("x [px]")
    ax.set_ylabel("t [ms]")
    ax.set_zlabel("y [px] (up)")
    ax.set_xlim(0, width)
    ax.set_zlim(0, height)
    ax.legend(loc="upper left", markerscale=6)
    return ax


def plot_event_rate(events: np.ndarray, bin_us: int = 10_000, ax=None):
    """Events per second over time, ON and OFF separately, in bins of ``bin_us``.

    Returns the axes. Introduced in notebooks/01_events.ipynb.
    """
    if ax is None:
        ax = plt.figure(figsize=(8, 3)).add_subplot()
    if len(events) == 0:
        return ax
    t0 = events["t"][0]
    n_bins = int((events["t"][-1] - t0) // bin_us) + 1
    edges_ms = np.arange(n_bins + 1) * bin_us / 1e3
    for polarity, color, label in ((1, ON_COLOR, "ON"), (-1, OFF_COLOR, "OFF")):
        k = (events["t"][events["p"] == polarity] - t0) // bin_us
        rate = np.bincount(k, minlength=n_bins) / (bin_us / 1e6)
        ax.stairs(rate, edges_ms, color=color, label=label)
    ax.set_xlabel("time since first event [ms]")
    ax.set_ylabel("events / s")
    ax.legend()
    return ax


def plot_frame_grid(
    frames: np.ndarray,
    indices=None,
    n_cols: int = 10,
    dt_us: int | None = None,
    cmap: str = "gray_r",
    panel_size: float = 1.6,
):
    """Show frames ``(n, H, W)`` (or a chosen ``indices`` subset) as a grid of images.

    With ``dt_us`` each panel is titled with its window start in ms. Returns the figure.
    Introduced in notebooks/02_event_frames.ipynb.
    """
    frames = np.asarray(frames)
    if frames.ndim != 3:
        raise ValueError(f"frames must be (n, H, W), got shape {frames.shape}")
    indices = list(range(len(frames))) if indices is None else list(indices)
    n_rows = max(1, -(-len(indices) // n_cols))
    height, width = frames.shape[1:]
    fig, axes = plt.subplots(
        n_rows, n_cols, squeeze=False,
        figsize=(n_cols * panel_size, n_rows * panel_size * height / width + 0.3 * n_rows),
    )
    vmax = max(1, float(frames.max())) if frames.size else 1
    for ax in axes.flat[len(indices):]:
        ax.axis("off")
    for ax, k in zip(axes.flat, indices, strict=False):
        ax.set_xticks([])
        ax.set_yticks([])
        ax.imshow(frames[k], cmap=cmap, vmin=0, vmax=vmax, interpolation="nearest")
        ax.set_title(f"{k * dt_us / 1e3:.0f} ms" if dt_us else f"k={k}", fontsize=8)
    fig.tight_layout()
    return fig


def show_frame(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    dt_ms: float,
    index: int,
    ax=None,
):
    """Accumulate binary frames of ``dt_ms`` and draw frame ``index``; return (frame, ax).

    The plain function behind the dt / frame-index slider of lesson 02 (the widget only
    calls it). ``index`` past the last frame shows the last frame.
    Introduced in notebooks/02_event_frames.ipynb.
    """
    dt_us = max(1, round(dt_ms * 1000))
    frames = accumulate(events, sensor_size, dt_us=dt_us, mode="binary")
    index = int(np.clip(index, 0, len(frames) - 1))
    frame = frames[index]
    if ax is None:
        ax = plt.figure(figsize=(5, 4)).add_subplot()
    ax.imshow(frame, cmap="gray_r", vmin=0, vmax=1, interpolation="nearest")
    ax.set_title(f"dt = {dt_us / 1e3:g} ms, frame {index} of {len(frames)}: "
                 f"{int(frame.sum())} pixels fired")
    ax.axis("off")
    return frame, ax


def animate_frames(frames: np.ndarray, interval_ms: int = 50, dt_us: int | None = None,
                   cmap: str = "gray_r"):
    """A matplotlib animation of frames ``(n, H, W)``; show it with :func:`animation_html`.

    No ffmpeg needed. Introduced in notebooks/02_event_frames.ipynb.
    """
    frames = np.asarray(frames)
    if frames.ndim != 3 or len(frames) == 0:
        raise ValueError(f"frames must be a non-empty (n, H, W) stack, got {frames.shape}")
    fig, ax = plt.subplots(figsize=(4, 4 * frames.shape[1] / frames.shape[2]))
    image = ax.imshow(frames[0], cmap=cmap, vmin=0, vmax=max(1, float(frames.max())),
                      interpolation="nearest")
    ax.axis("off")

    def draw(k):
        image.set_data(frames[k])
        ax.set_title(f"{k * dt_us / 1e3:.0f} ms" if dt_us else f"frame {k}")
        return (image,)

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), interval=interval_ms, blit=True)
    plt.close(fig)
    return anim


def animation_html(anim: animation.Animation, description: str) -> str:
    """``anim`` as a self-contained HTML player that reads well to everyone.

    matplotlib's ``to_jshtml()`` with ``description`` as the picture's alt text and as the
    frame slider's label, and without its link to an icon font on a CDN (JupyterLab and the
    book ship the icons), so that the page loads nothing from outside.

    Examples:
        >>> anim = animate_frames(np.zeros((2, 4, 4)))
        >>> html = animation_html(anim, "two empty frames")
        >>> 'alt="two empty frames"' in html, "bootstrapcdn" in html
        (True, False)
    """
    import html as html_text
    import re

    if not description.strip():
        raise ValueError("describe the animation for readers who cannot see it: a non-empty "
                         "description is its alt text")
    label = html_text.escape(description, quote=True)
    page = anim.to_jshtml()
    page = re.sub(r'<link rel="stylesheet"\s+href="https://[^"]*font-awesome[^"]*">', "", page)
    page = re.sub(r'<img id="(_anim_img\w+)">', rf'<img id="\1" alt="{label}">', page)
    page = re.sub(r'<input id="(_anim_slider\w+)" type="range"',
                  rf'<input id="\1" type="range" aria-label="frame of: {label}"', page)
    return page


# --- voxels (matplotlib: static, works everywhere) -----------------------------------------


def plot_voxels(grid: np.ndarray, ax=None, threshold: float = 0.5, color="#8fa8c8",
                title: str | None = None, colormap: str | None = None):
    """Draw the voxels of a ``(R, R, R)`` grid (indexed x, y, z) with ``grid >= threshold``.

    With ``colormap`` (e.g. ``"viridis"``) each voxel is coloured by its value (a
    probability); otherwise all take ``color``. Returns the 3D axes.
    Introduced in notebooks/07_evaluation.ipynb.
    """
    grid = np.asarray(grid, dtype=np.float32)
    if grid.ndim != 3:
        raise ValueError(f"grid must be (R, R, R), got shape {grid.shape}")
    if ax is None:
        ax = plt.figure(figsize=(4, 4)).add_subplot(projection="3d")
    filled = grid >= threshold
    if colormap is not None:
        colors = plt.get_cmap(colormap)(np.clip(grid, 0, 1))
        ax.voxels(filled, facecolors=colors, edgecolor=(0, 0, 0, 0.15), linewidth=0.2)
    else:
        ax.voxels(filled, facecolors=color, edgecolor=(0, 0, 0, 0.25), linewidth=0.2)
    size = grid.shape[0]
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(0, size)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=-60)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_zticks([])
    if title:
        ax.set_title(title)
    return ax


def plot_reconstruction(probabilities: np.ndarray, voxels: np.ndarray | None = None,
                        threshold: float = paper.IOU_THRESHOLD, title: str | None = None):
    """Ground truth (if given) beside the prediction ``probabilities >= threshold``.

    The prediction is coloured by probability; the title reports IoU at ``threshold``
    when the ground truth is known. Returns the figure.
    Introduced in notebooks/07_evaluation.ipynb.
    """
    from e2vlib.metrics import iou

    n = 1 if voxels is None else 2
    fig = plt.figure(figsize=(4.2 * n, 4.4))
    if voxels is not None:
        plot_voxels(voxels, fig.add_subplot(1, n, 1, projection="3d"), title="ground truth")
    label = f"prediction (p >= {threshold})"
    if voxels is not None:
        label += f", IoU {iou(probabilities, voxels, threshold):.2f}"
    plot_voxels(probabilities, fig.add_subplot(1, n, n, projection="3d"), threshold=threshold,
                colormap=PROBABILITY_CMAP, title=label)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


# --- voxels and meshes (pyvista: interactive in JupyterLab, static image headless) -------


def voxel_mesh(grid: np.ndarray, threshold: float = 0.5):
    """The voxels of ``grid`` (indexed x, y, z) with value ``>= threshold`` as cubes.

    Returns a ``pyvista.UnstructuredGrid`` placed in the unit cube ``[-0.5, 0.5]^3`` (the
    frame of the meshes), with the voxel values in ``cell_data["value"]``. Empty
    selections return an empty grid. Introduced in notebooks/04_building_the_dataset.ipynb.
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


# --- 3D scenes (pyvista) -------------------------------------------------------------------
#
# Each ``view_*`` function builds and returns a ``pyvista.Plotter`` without showing it: call
# ``.show()`` in a notebook (the backend comes from the environment variable
# PYVISTA_JUPYTER_BACKEND: "trame" gives an interactive view in JupyterLab, "static" an
# image) or :func:`screenshot` for a picture as an array or PNG file. ``off_screen=None``
# lets pyvista decide (off screen inside notebooks and where PYVISTA_OFF_SCREEN is set).

OBJECT_VIEW = (1.6, -2.4, 1.4)
"""Default viewing direction on the object: front-right and above (the object faces -y)."""
TRUTH_COLOR, MESH_COLOR = "#8fa8c8", "#d2b48c"
UNIT_CUBE_BOUNDS = (-0.5, 0.5, -0.5, 0.5, -0.5, 0.5)
"""``(xmin, xmax, ymin, ymax, zmin, zmax)`` in metres of the cube the voxel grids cover."""



def new_plotter(off_screen: bool | None = None, window_size=(500, 500), shape=(1, 1)):
    """An empty ``pyvista.Plotter`` in the lessons' style: white, evenly lit, no borders.

    ``window_size`` is ``(width, height)`` in pixels for the whole window, ``shape``
    ``(rows, cols)`` of subplots (select one with ``plotter.subplot(row, col)``).
    "Three lights" (key, fill and back light) keeps dense voxel views readable on every
    side. ``off_screen=None`` lets pyvista decide (off screen in notebooks). On a machine
    without a display the headless OpenGL window is chosen first
    (:func:`headless_opengl_window`). Every ``view_*`` function starts from this plotter.
    Introduced in notebooks/07_evaluation.ipynb.
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


def _unit_cube_floor():
    """A light 4 x 4 grid on the floor of the unit cube (z = -0.5), 0.25 m squares."""
    import pyvista as pv

    return pv.Plane(center=(0.0, 0.0, -0.5), i_size=1.0, j_size=1.0, i_resolution=4,
                    j_resolution=4)


def _is_binary(grid: np.ndarray) -> bool:
    return bool(np.all((grid == 0) | (grid == 1)))


def event_cloud(events: np.ndarray, sensor_size: tuple[int, int], max_events: int = 100_000,
                t_scale: float | None = None):
    """Events as a ``pyvista.PolyData`` point cloud at ``(x, t * t_scale, y up)``.

    ``x`` and the flipped ``y`` (``height - 1 - y``, so the picture is upright) are in
    pixels; time in ms since the first event is multiplied by ``t_scale`` (pixels per ms;
    default: the whole stream spans twice the sensor width). Point data ``"polarity"``
    (-1/+1) and ``"t_ms"``; ``field_data["t_scale"]`` holds the scale used. At most
    ``max_events`` events, a random subset kept in time order.
    Introduced in notebooks/08_visualizing_in_3d.ipynb.
    """
    import pyvista as pv

    width, height = check_sensor_size(sensor_size)
    validate(events, (width, height))
    if len(events) == 0:
        raise ValueError("no events to show; pass a non-empty event array")
    shown = _subsample(events, max_events)
    t_ms = (shown["t"] - events["t"][0]) / 1e3
    span_ms = max(float(events["t"][-1] - events["t"][0]) / 1e3, 1e-3)
    scale = 2.0 * width / span_ms if t_scale is None else float(t_scale)
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"t_scale must be a positive number of px per ms, got {t_scale!r}")
    points = np.column_stack([shown["x"].astype(np.float64), t_ms * scale,
                              (height - 1 - shown["y"].astype(np.int64)).astype(np.float64)])
    cloud = pv.PolyData(points)
    cloud.point_data["polarity"] = shown["p"].astype(np.int8)
    cloud.point_data["t_ms"] = t_ms.astype(np.float32)
    cloud.field_data["t_scale"] = np.array([scale])
    return cloud


def view_events(events: np.ndarray, sensor_size: tuple[int, int], max_events: int = 100_000,
                point_size: float = 2.0, off_screen: bool | None = None,
                window_size=(900, 600)):
    """3D scene of events in space-time: x across, time in depth, y up; ON orange, OFF blue.

    The pyvista twin of :func:`plot_events_3d` (rotate it with the mouse in JupyterLab).
    The axes show pixels and milliseconds. Returns the plotter (not shown).
    Introduced in notebooks/08_visualizing_in_3d.ipynb.
    """
    width, height = check_sensor_size(sensor_size)
    cloud = event_cloud(events, (width, height), max_events=max_events)
    scale = float(cloud.field_data["t_scale"][0])
    span_ms = float(events["t"][-1] - events["t"][0]) / 1e3
    plotter = new_plotter(off_screen, window_size)
    for polarity, color, label in ((1, ON_COLOR, "ON (+1)"), (-1, OFF_COLOR, "OFF (-1)")):
        part = cloud.extract_points(cloud.point_data["polarity"] == polarity,
                                    adjacent_cells=False, include_cells=True)
        if part.n_points:
            plotter.add_mesh(part, color=color, point_size=point_size, label=label,
                             render_points_as_spheres=False, style="points")
    plotter.add_legend(bcolor="white", border=True, size=(0.16, 0.1), loc="upper left")
    bounds = (0.0, float(width), 0.0, span_ms * scale, 0.0, float(height))
    plotter.show_bounds(bounds=bounds, axes_ranges=(0, width, 0, span_ms, 0, height),
                        xtitle="x [px]", ytitle="t [ms]", ztitle="y [px]", color="gray",
                        grid=False, location="outer", ticks="outside", fmt="%.0f")
    centre = np.array([width / 2, span_ms * scale / 2, height / 2])
    plotter.camera_position = [tuple(centre + np.array([1.4, -1.0, 0.6]) * span_ms * scale),
                               tuple(centre), (0.0, 0.0, 1.0)]
    plotter.reset_camera(bounds=bounds)
    position, focus, up = plotter.camera_position  # lower the view a little: room for labels
    drop = np.array([0.0, 0.0, 0.12 * height])
    plotter.camera_position = [tuple(np.asarray(position) - drop),
                               tuple(np.asarray(focus) - drop), up]
    plotter.camera.zoom(1.15)
    return plotter


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

    The layout of the paper's Figure 3. ``truths`` and ``predictions`` are one grid
    ``(R, R, R)`` or sequences/stacks of ``n`` grids; predictions are probabilities,
    drawn where ``>= threshold`` and coloured by value (one probability bar, in the last
    panel), each panel titled with its IoU at ``threshold``. With ``link`` all ``2 n``
    views share one camera: turning one turns all. Returns the plotter with
    ``shape == (2, n)`` (not shown).
    Introduced in notebooks/08_visualizing_in_3d.ipynb.
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
    """
    from e2vlib.render import to_polydata

    if not 0 < mesh_opacity <= 1:
        raise ValueError(f"mesh_opacity must be in (0, 1], got {mesh_opacity!r}")
    poly = to_polydata(mesh)
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


def camera_frustum(position, depth: float = 2.0, view_angle_deg: float | None = None):
    """The viewing pyramid of a camera at ``position`` (m) looking at the origin, +z up.

    Returns ``(lines, base)``: the apex-to-corner and rim lines (``pyvista.PolyData``) and
    the square base ``depth`` metres in front of the camera as a quad with texture
    coordinates, so a rendered frame can be pasted on it (top-left corner of the image
    at the top-left of the base). ``view_angle_deg`` defaults to the render camera's
    (:data:`e2vlib.render.VIEW_ANGLE_DEG`). Introduced in notebooks/03_simulating_events.ipynb.
    """
    import pyvista as pv

    from e2vlib.render import VIEW_ANGLE_DEG

    angle = VIEW_ANGLE_DEG if view_angle_deg is None else float(view_angle_deg)
    position = np.asarray(position, dtype=np.float64).reshape(3)
    forward = -position / np.linalg.norm(position)
    right = np.cross(forward, (0.0, 0.0, 1.0))
    if np.linalg.norm(right) < 1e-9:
        raise ValueError("the camera must not sit on the z axis (its up direction is +z)")
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = depth * np.tan(np.radians(angle / 2))
    centre = position + depth * forward
    corners = np.array([centre + sx * half * right + sy * half * up
                        for sx, sy in ((-1, 1), (1, 1), (1, -1), (-1, -1))])  # clockwise
    lines = pv.PolyData(np.vstack([position, corners]),
                        lines=[2, 0, 1, 2, 0, 2, 2, 0, 3, 2, 0, 4, 5, 1, 2, 3, 4, 1])
    base = pv.PolyData(corners, faces=[4, 0, 1, 2, 3])
    base.active_texture_coordinates = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=float)
    return lines, base


def view_orbit(mesh, n_video_frames: int = paper.N_VIDEO_FRAMES, fps: float = paper.VIDEO_FPS,
               every: int = 20, video=None, frustum_depth: float = 2.0,
               off_screen: bool | None = None, window_size=(1000, 750), *,
               n_frames: int | None = None):
    """The data set-up in one scene: spiral camera path, camera frusta, and the object.

    The path of :func:`e2vlib.render.orbit_cameras` (``n_video_frames`` rendered video
    frames at ``fps``; the paper's 120 at 240 fps) is coloured by time (ms), a frustum
    is drawn every ``every`` video frames and at the last one, with a grey sight line to
    the object; with ``video`` (``(n_video_frames, H, W)`` gray in [0, 1], e.g. from
    ``render_orbit``) each frustum's base shows the frame that camera rendered. The
    object is drawn to scale at the origin. ``n_frames`` is the old name of
    ``n_video_frames`` (still accepted, same meaning; not the model's event frames).
    Returns the plotter (not shown). Introduced in notebooks/03_simulating_events.ipynb.
    """
    import pyvista as pv

    from e2vlib.render import orbit_cameras, to_polydata

    if n_frames is not None:
        if n_video_frames not in (paper.N_VIDEO_FRAMES, n_frames):
            raise TypeError("give n_video_frames or its old name n_frames, not both")
        n_video_frames = n_frames
    cams = orbit_cameras(n_video_frames)
    n = len(cams)
    if not isinstance(every, (int, np.integer)) or isinstance(every, bool) or every < 1:
        raise ValueError(f"every must be a positive integer, got {every!r}")
    if video is not None:
        video = np.asarray(video)
        if video.ndim != 3 or len(video) != n:
            raise ValueError(f"video must be ({n}, H, W) like render_orbit's output, "
                             f"got shape {video.shape}")
    t_ms = np.arange(n) * 1e3 / float(fps)
    path = pv.lines_from_points(cams)
    path["time [ms]"] = t_ms
    plotter = new_plotter(off_screen, window_size)
    plotter.add_mesh(path, scalars="time [ms]", cmap="viridis", line_width=5,
                     scalar_bar_args={"position_x": 0.3, "position_y": 0.86, "width": 0.4,
                                      "color": "black", "fmt": "%.0f", "n_labels": 6})
    plotter.add_mesh(to_polydata(mesh), color=MESH_COLOR)
    shown = sorted({*range(0, n, every), n - 1})
    for i in shown:
        lines, base = camera_frustum(cams[i], depth=frustum_depth)
        plotter.add_mesh(lines, color="black", line_width=1.5)
        if video is not None:
            frame = np.clip(np.asarray(video[i], dtype=np.float64), 0, 1)
            image = np.repeat((frame[..., None] * 255).astype(np.uint8), 3, axis=2)
            plotter.add_mesh(base, texture=pv.numpy_to_texture(image), lighting=False)
        else:
            plotter.add_mesh(base, color="lightgray", opacity=0.5, lighting=False)
        plotter.add_mesh(pv.Line(cams[i], (0.0, 0.0, 0.0)), color="gray", opacity=0.5)
    mid = n // 2
    radius = float(np.hypot(*cams[mid, :2]))
    plotter.add_point_labels(cams[[0, mid, -1]], ["start, 0 ms", f"r = {radius:.1f} m",
                                                   f"end, {t_ms[-1]:.0f} ms"],
                             font_size=14, point_size=8, shape_opacity=0.6)
    reach = float(np.ceil(np.abs(cams[:, :2]).max()))
    plotter.show_grid(bounds=(-reach, reach, -reach, reach, -2.0, 2.0), n_xlabels=5,
                      n_ylabels=5, n_zlabels=5, fmt="%.0f", xtitle="x [m]", ytitle="y [m]",
                      ztitle="z [m]", color="gray")
    plotter.camera_position = [(15, -15, 10), (0, 0, -0.3), (0, 0, 1)]
    plotter.reset_camera(bounds=(-reach, reach, -reach, reach, -2.0, 2.0))
    plotter.camera.zoom(1.05)
    return plotter


def screenshot(plotter, path=None, scale: int | None = None) -> np.ndarray:
    """Render ``plotter`` headless and return the image ``(H, W, 3)`` uint8.

    With ``path`` the image is also written as a PNG (temporary file, then renamed).
    Works for plotters created with ``off_screen=None`` that have not been shown yet:
    they are switched to off-screen rendering first. The plotter stays open, so it can
    still be shown or saved again. Introduced in notebooks/08_visualizing_in_3d.ipynb.
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


# --- widgets that still show a picture without a widget frontend ----------------------------
#
# An ipywidgets ``interact``/``interactive_output`` draws into an Output widget, whose
# content only a live widget frontend shows: an executed notebook read without the kernel
# (nbmake, a notebook viewer) shows "interactive(children=...)" instead of the picture.
# :func:`interactive_figure` shows the picture as an ordinary PNG output below the widgets
# and replaces that output (a display id) whenever a control moves, which JupyterLab and
# the classic notebook both apply.


def _png_of(figure) -> bytes:
    import io

    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", bbox_inches="tight")
    return buffer.getvalue()


def _stack_pngs(pngs: list[bytes]) -> bytes:
    """One PNG of several, stacked top to bottom on white (left-aligned)."""
    import io

    from PIL import Image

    images = [Image.open(io.BytesIO(png)).convert("RGB") for png in pngs]
    out = Image.new("RGB", (max(i.width for i in images), sum(i.height for i in images)),
                    "white")
    y = 0
    for image in images:
        out.paste(image, (0, y))
        y += image.height
    buffer = io.BytesIO()
    out.save(buffer, format="PNG")
    return buffer.getvalue()


def _render_call(function, values: dict) -> tuple[str, bytes | None]:
    """Run ``function(**values)`` and return ``(printed text, PNG bytes or None)``.

    Whatever the call prints becomes the text; the picture is what it draws with
    matplotlib: the figures it shows with ``plt.show()`` in a notebook, or else those it
    leaves open and a ``Figure`` it returns (several are stacked top to bottom). The
    figures it made are closed. Exceptions propagate.
    """
    import base64

    from IPython.utils.capture import capture_output
    from matplotlib.figure import Figure

    before = set(plt.get_fignums())
    try:
        with capture_output(stdout=True, stderr=False, display=True) as captured:
            result = function(**values)
        pngs = []
        for output in captured.outputs:  # figures shown inline by plt.show()
            data = output.data.get("image/png")
            if data is not None:
                pngs.append(base64.b64decode(data) if isinstance(data, str) else bytes(data))
        if not pngs:  # nothing shown inline: take what it drew and left open or returned
            figures = [plt.figure(n) for n in plt.get_fignums() if n not in before]
            if isinstance(result, Figure) and result not in figures:
                figures.append(result)
            pngs = [_png_of(figure) for figure in figures]
    finally:
        for n in set(plt.get_fignums()) - before:
            plt.close(n)
    png = None if not pngs else pngs[0] if len(pngs) == 1 else _stack_pngs(pngs)
    return captured.stdout.rstrip("\n"), png


_INTERACTIVE_FIGURE = None


def _interactive_figure_class():
    """The widget class, made on first use so importing viz does not import ipywidgets."""
    global _INTERACTIVE_FIGURE
    if _INTERACTIVE_FIGURE is not None:
        return _INTERACTIVE_FIGURE
    import base64
    import traceback
    import uuid

    import ipywidgets as widgets

    class InteractiveFigure(widgets.VBox):
        """Rows of controls, then an Output widget for errors; the text and picture of
        the current values are separate outputs below it (see :func:`interactive_figure`)."""

        def __init__(self, function, controls: dict, rows: list[list[str]]):
            self.function, self.controls = function, controls
            self.errors = widgets.Output()
            boxes = [widgets.HBox([controls[name] for name in row]) for row in rows]
            super().__init__([*boxes, self.errors])
            self._display_ids = {"text": uuid.uuid4().hex, "image": uuid.uuid4().hex}
            self._shown: set[str] = set()  # the outputs displayed so far
            self._drawn = self.values
            self.text, self.png = _render_call(function, self._drawn)  # the default state
            for control in controls.values():
                control.observe(self._redraw, names="value")

        @property
        def values(self) -> dict:
            """``{name: value}`` of the controls now."""
            return {name: control.value for name, control in self.controls.items()}

        def _redraw(self, _change=None) -> None:
            values = self.values
            if values == self._drawn:  # e.g. a control reset by another one's callback
                return
            self._drawn = values
            try:
                self.text, self.png = _render_call(self.function, values)
                self.errors.clear_output()
            except Exception as err:  # say what went wrong and keep the last picture
                self.text = f"{type(err).__name__}: {err}"
                with self.errors:
                    traceback.print_exc()
            if self._shown:
                from IPython.display import update_display

                for part in self._shown:
                    update_display(self._bundle(part), display_id=self._display_ids[part],
                                   raw=True)

        def _bundle(self, part: str) -> dict:
            if part == "text":
                return {"text/plain": self.text}
            if self.png is None:
                return {"text/plain": "(nothing drawn)"}
            return {"image/png": base64.b64encode(self.png).decode("ascii"),
                    "text/plain": f"<picture at {self._drawn}>"}

        def _ipython_display_(self, **kwargs) -> None:
            from IPython.display import display

            bundle = self._repr_mimebundle_(**kwargs)
            bundle["text/plain"] = (f"[controls {', '.join(self.controls)}: move them in "
                                    "JupyterLab; the picture below follows them]")
            display(bundle, raw=True)
            # text only for a function that prints (no empty output for one that only draws)
            for part in ("text", "image") if self.text else ("image",):
                display(self._bundle(part), raw=True, display_id=self._display_ids[part])
                self._shown.add(part)

    _INTERACTIVE_FIGURE = InteractiveFigure
    return InteractiveFigure


def interactive_figure(function, /, *, rows=None, **controls):
    """Widgets around a matplotlib picture that also shows where widgets cannot run.

    ``controls`` maps each keyword of ``function`` to an ipywidgets control (a slider, a
    dropdown); ``function(**values)`` prints text and draws one matplotlib figure (shown
    with ``plt.show()``, left open or returned). The default values are drawn at once
    (errors raise here). Displayed (the last expression of a cell), it shows the controls
    and, below them, the printed text and the picture as ordinary outputs: an executed
    notebook read without its kernel (nbmake, a notebook viewer) still shows the default
    state, and in JupyterLab each move of a control redraws and replaces them. ``rows``
    lists the control names per row (default: one per row). Returns an
    ``ipywidgets.VBox`` with one ``HBox`` per row and last an ``Output`` that shows the
    traceback of a redraw that failed; ``.values``, ``.text`` and ``.png`` (bytes) hold the
    state drawn last. Introduced in notebooks/02_event_frames.ipynb.
    """
    if not controls:
        raise ValueError("give at least one control, e.g. dt_ms=ipywidgets.FloatSlider()")
    rows = [[name] for name in controls] if rows is None else [list(row) for row in rows]
    placed = [name for row in rows for name in row]
    if sorted(placed) != sorted(controls):
        raise ValueError(f"rows must place every control exactly once: rows name {placed}, "
                         f"controls are {list(controls)}")
    return _interactive_figure_class()(function, dict(controls), rows)


# --- exporting a reconstruction for other tools ---------------------------------------------


def probability_mesh(probabilities: np.ndarray, threshold: float = paper.IOU_THRESHOLD):
    """A closed triangle mesh of the surface ``probabilities == threshold`` (marching cubes).

    The grid ``(R, R, R)`` (indexed x, y, z over ``[-0.5, 0.5]^3``, value of voxel ``i``
    at its centre ``-0.5 + (i + 0.5) / R``) is padded with a layer of zeros so the surface
    closes at the border, and vertices are clipped to the cube. For a 0/1 grid at threshold
    0.5 the surface runs exactly along the voxel faces between occupied and empty voxels
    (edges and corners cut diagonally). Returns a watertight ``trimesh.Trimesh`` in metres
    with outward normals. Introduced in notebooks/08_visualizing_in_3d.ipynb.
    """
    import trimesh
    from skimage.measure import marching_cubes

    grid = np.asarray(probabilities, dtype=np.float32)
    if grid.ndim != 3 or len(set(grid.shape)) != 1:
        raise ValueError(f"probabilities must be a cube (R, R, R), got shape {grid.shape}")
    if not 0 < threshold < 1:
        raise ValueError(f"threshold must lie strictly between 0 and 1, got {threshold!r}")
    if not np.any(grid >= threshold):
        raise ValueError(f"no voxel reaches the threshold {threshold:g}; lower it to get a mesh")
    size = grid.shape[0]
    padded = np.pad(grid, 1, constant_values=0.0)
    verts, faces, _, _ = marching_cubes(padded, level=float(threshold))
    verts = np.clip((verts - 0.5) / size - 0.5, -0.5, 0.5)  # padded index j -> metres
    mesh = trimesh.Trimesh(verts, faces, process=True)
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

