"""PyVista scenes of how the data is recorded: events in space-time and the camera orbit.

:func:`event_cloud` and :func:`view_events` show an event stream as a point cloud (x
across, time in depth, y up); :func:`camera_frustum` and :func:`view_orbit` show the
render orbit of :mod:`e2vlib.orbit` with its cameras and, optionally, the frames they
rendered. Each ``view_*`` returns the plotter unshown, as in :mod:`e2vlib.viz.scenes`.

Introduced in notebooks/03_simulating_events.ipynb and notebooks/08_visualizing_in_3d.ipynb.
"""

from __future__ import annotations

import numpy as np

from e2vlib import paper
from e2vlib.events import check_sensor_size, validate
from e2vlib.orbit import VIEW_ANGLE_DEG, camera_axes, orbit_cameras, resolve_video_frames
from e2vlib.viz.plots import subsample_events
from e2vlib.viz.scenes import new_plotter
from e2vlib.viz.style import MESH_COLOR, OFF_COLOR, ON_COLOR


def event_cloud(events: np.ndarray, sensor_size: tuple[int, int], max_events: int = 100_000,
                t_scale: float | None = None):
    """Events as a ``pyvista.PolyData`` point cloud at ``(x, t * t_scale, y up)``.

    ``x`` and the flipped ``y`` (``height - 1 - y``, so the picture is upright) are in
    pixels; time in ms since the first event is multiplied by ``t_scale`` (pixels per ms;
    default: the whole stream spans twice the sensor width). Point data ``"polarity"``
    (-1/+1) and ``"t_ms"``; ``field_data["t_scale"]`` holds the scale used. At most
    ``max_events`` events, a random subset kept in time order.
    Introduced in notebooks/08_visualizing_in_3d.ipynb.

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> events = make_events([0, 2, 3, 1], [0, 1, 2, 1], [0, 2000, 5000, 15000], [1, -1, 1, 1])
    >>> cloud = event_cloud(events, (4, 3))  # 15 ms drawn 2 x 4 px long: 8/15 px per ms
    >>> np.round(cloud.points, 3).tolist()  # (x, t_ms * 8/15, 2 - y)
    [[0.0, 0.0, 2.0], [2.0, 1.067, 1.0], [3.0, 2.667, 0.0], [1.0, 8.0, 1.0]]
    >>> cloud.point_data["polarity"].tolist()
    [1, -1, 1, 1]
    """
    import pyvista as pv

    width, height = check_sensor_size(sensor_size)
    validate(events, (width, height))
    if len(events) == 0:
        raise ValueError("no events to show; pass a non-empty event array")
    shown = subsample_events(events, max_events)
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

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> events = make_events([0, 2, 3, 1], [0, 1, 2, 1], [0, 2000, 5000, 15000], [1, -1, 1, 1])
    >>> plotter = view_events(events, (4, 3), off_screen=True, window_size=(64, 64))
    >>> from e2vlib.viz.scenes import screenshot
    >>> screenshot(plotter).shape
    (64, 64, 3)
    >>> plotter.close()
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


def camera_frustum(position, depth: float = 2.0, view_angle_deg: float | None = None):
    """The viewing pyramid of a camera at ``position`` (m) looking at the origin, +z up.

    Returns ``(lines, base)``: the apex-to-corner and rim lines (``pyvista.PolyData``) and
    the square base ``depth`` metres in front of the camera as a quad with texture
    coordinates, so a rendered frame can be pasted on it (top-left corner of the image
    at the top-left of the base). ``view_angle_deg`` defaults to the render camera's
    (:data:`e2vlib.orbit.VIEW_ANGLE_DEG`). Introduced in notebooks/03_simulating_events.ipynb.

    Examples
    --------
    >>> lines, base = camera_frustum((0, -4, 0), depth=2)  # looking along +y
    >>> lines.n_lines, base.n_cells  # 4 edges and the rim; one square
    (5, 1)
    >>> np.round(base.points, 3).tolist()  # half side 2 * tan(view angle / 2) = 2 * 18 / 80
    [[-0.45, -2.0, 0.45], [0.45, -2.0, 0.45], [0.45, -2.0, -0.45], [-0.45, -2.0, -0.45]]
    """
    import pyvista as pv

    angle = VIEW_ANGLE_DEG if view_angle_deg is None else float(view_angle_deg)
    position = np.asarray(position, dtype=np.float64).reshape(3)
    forward, right, up = camera_axes(position)  # the render camera's axes
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

    The path of :func:`e2vlib.orbit.orbit_cameras` (``n_video_frames`` rendered video
    frames at ``fps``; the paper's 120 at 240 fps) is coloured by time (ms), a frustum
    is drawn every ``every`` video frames and at the last one, with a grey sight line to
    the object; with ``video`` (``(n_video_frames, H, W)`` gray in [0, 1], e.g. from
    ``render_orbit``) each frustum's base shows the frame that camera rendered. The
    object is drawn to scale at the origin. ``n_frames`` is the old name of
    ``n_video_frames`` (still accepted, same meaning; not the model's event frames).
    Returns the plotter (not shown). Introduced in notebooks/03_simulating_events.ipynb.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((0.5, 0.5, 0.5))
    >>> plotter = view_orbit(box, n_video_frames=5, every=2, off_screen=True,
    ...                      window_size=(64, 64))  # frusta at frames 0, 2 and 4
    >>> from e2vlib.viz.scenes import screenshot
    >>> screenshot(plotter).shape
    (64, 64, 3)
    >>> plotter.close()
    """
    import pyvista as pv

    cams = orbit_cameras(resolve_video_frames(n_video_frames, n_frames))
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
    plotter.add_mesh(pv.wrap(mesh), color=MESH_COLOR)
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
