"""Render the paper's spiral camera orbit around an object into a grayscale video.

E2V (Chen et al., ICVR 2023) rendered each ShapeNet object in Blender while the camera
flew a spiral around it, always looking at the object, with an 80 mm lens on a 36 mm
sensor, a white background and a sun plus lights above and below. This module rebuilds
that set-up with pyvista/VTK rendering off screen (:func:`render_orbit`); it holds only the
VTK work. The orbit itself, its clock and the camera model (numpy only) live in
:mod:`e2vlib.orbit`, whose conventions hold here (metres, degrees, microseconds; the
camera looks at the origin with +z up). Re-exported from there, so lessons keep importing
them from here: :func:`orbit_cameras`, :func:`orbit_angles`, :func:`project_points`,
:func:`pixel_motion_per_frame`, :func:`required_oversample`, :data:`VIEW_ANGLE_DEG` and the
orbit's numbers (:data:`FOCAL_LENGTH_MM`, :data:`SENSOR_SIZE_MM`, :data:`Z_TOP_M`, ...).

Introduced in notebooks/03_simulating_events.ipynb.
"""

from __future__ import annotations

import atexit
import collections
import os
import threading

import numpy as np

from e2vlib import paper
from e2vlib._headless import headless_opengl_window  # re-exported
from e2vlib.orbit import (  # re-exported: the orbit's numbers and functions
    AZIMUTH_START_DEG,
    FOCAL_LENGTH_MM,
    RADIUS_END_M,
    RADIUS_MID_M,
    SENSOR_SIZE_MM,
    VIEW_ANGLE_DEG,
    Z_BOTTOM_M,
    Z_TOP_M,
    _check_clock,
    _check_count,
    _video_frames,
    n_rendered,
    orbit_angles,
    orbit_cameras,
    pixel_motion_per_frame,
    project_points,
    rendered_cameras,
    rendered_times_us,
    required_oversample,
)

_n_rendered = n_rendered  # the old private name

_CLIPPING_RANGE = (0.1, 50.0)  # near/far planes (m); objects fit in the unit cube
_BACKGROUND = (1.0, 1.0, 1.0)
_MATERIAL = {"color": (0.8, 0.8, 0.8), "ambient": 0.15, "diffuse": 0.85, "specular": 0.0}
_LUMA = np.array([0.299, 0.587, 0.114])  # ITU-R BT.601 weights, RGB -> gray


def to_polydata(mesh):
    """A pyvista.PolyData view of a trimesh.Trimesh or pyvista.PolyData (never modified).

    Examples
    --------
    >>> import trimesh
    >>> poly = to_polydata(trimesh.creation.box((0.5, 0.5, 0.5)))
    >>> type(poly).__name__, poly.n_points, poly.n_cells  # 8 corners, 12 triangles
    ('PolyData', 8, 12)

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    import pyvista as pv

    if isinstance(mesh, pv.PolyData):
        poly = mesh.copy(deep=False)
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices = np.asarray(mesh.vertices, dtype=np.float64)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise ValueError(f"mesh.faces must be (m, 3) triangles, got shape {faces.shape}")
        cells = np.hstack([np.full((len(faces), 1), 3, dtype=np.int64), faces]).ravel()
        poly = pv.PolyData(vertices, cells)
    else:
        raise ValueError(
            f"mesh must be a trimesh.Trimesh or pyvista.PolyData, got {type(mesh).__name__}"
        )
    if poly.n_points == 0 or poly.n_cells == 0:
        raise ValueError("mesh is empty (no vertices or faces); nothing to render")
    if not np.all(np.isfinite(poly.points)):
        raise ValueError("mesh has NaN/inf vertex coordinates")
    return poly


def _add_lights(plotter) -> None:
    """A sun-like directional light plus weaker lights straight above and below."""
    import pyvista as pv

    for position, intensity in (((2.0, -1.0, 3.0), 0.75), ((0.0, 0.0, 1.0), 0.35),
                                ((0.0, 0.0, -1.0), 0.25)):
        light = pv.Light(position=position, focal_point=(0.0, 0.0, 0.0),
                         light_type="scene light", intensity=intensity)
        light.positional = False  # directional: parallel rays, like the sun
        plotter.add_light(light)


def _aim(camera, position: np.ndarray) -> None:
    """Put the VTK camera at ``position`` looking at the origin, +z up, paper's lens.

    Plain VTK calls (``camera`` is a ``vtkCamera``, pyvista's included): the same camera
    state as pyvista's property setters, without their per-call Python overhead."""
    camera.SetPosition(float(position[0]), float(position[1]), float(position[2]))
    camera.SetFocalPoint(0.0, 0.0, 0.0)
    camera.SetViewUp(0.0, 0.0, 1.0)
    camera.SetViewAngle(VIEW_ANGLE_DEG)
    camera.SetClippingRange(*_CLIPPING_RANGE)


class _Scene:
    """One off-screen plotter set up for the orbit, reusable for many meshes.

    Holds what does not depend on the mesh: window size, anti-aliasing, white background,
    the three lights and the camera's lens. :meth:`render` adds the mesh, renders every
    camera position and removes the mesh again (all actors and scalar bars), so the next
    mesh finds the scene as it was made. Frames are read straight from the front buffer
    (``vtkRenderWindow.GetPixelData``, the buffer pyvista's ``screenshot`` reads) into one
    reused array; the pixels are the same as ``screenshot``'s.
    """

    def __init__(self, resolution: int, anti_aliasing: str) -> None:
        import pyvista as pv

        headless_opengl_window()
        self.pid = os.getpid()
        self.resolution = resolution
        self.factor = SUPERSAMPLE_FACTOR if anti_aliasing == "supersample" else 1
        size = resolution * self.factor
        self.plotter = pv.Plotter(off_screen=True, notebook=False, window_size=(size, size),
                                  lighting="none")
        self.fresh = True  # pyvista has not done its first render yet
        try:
            if anti_aliasing == "ssaa":
                self.plotter.enable_anti_aliasing("ssaa")
            elif anti_aliasing in ("supersample", "none"):
                self.plotter.render_window.SetMultiSamples(0)  # one sample per pixel
            # "msaa": the window's multisampling as pyvista sets it (its theme's 8 samples)
            self.plotter.set_background(_BACKGROUND)
            _add_lights(self.plotter)
        except BaseException:
            self.close()
            raise
        from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

        self.pixels = vtkUnsignedCharArray()

    @property
    def usable(self) -> bool:
        """Open, and made by this process (a forked child never touches its parent's GL)."""
        return self.pid == os.getpid() and self.plotter.render_window is not None

    def close(self) -> None:
        self.plotter.close()

    def render(self, poly, cameras: np.ndarray, video: np.ndarray) -> None:
        """Render ``poly`` from every position in ``cameras`` into ``video`` (n, res, res)."""
        from vtkmodules.util.numpy_support import vtk_to_numpy

        res, f = self.resolution, self.factor
        size = res * f
        plotter = self.plotter
        try:
            plotter.add_mesh(poly, smooth_shading=False, **_MATERIAL)
            window = plotter.render_window
            camera = plotter.renderer.GetActiveCamera()
            for i, position in enumerate(cameras):
                _aim(camera, position)
                if self.fresh:  # pyvista sets itself up on the first render, may move the camera
                    plotter.screenshot(return_img=True)
                    self.fresh = False
                    _aim(camera, position)
                window.Render()
                window.GetPixelData(0, 0, size - 1, size - 1, 1, self.pixels, 0)
                rgb = vtk_to_numpy(self.pixels).reshape(size, size, -1)[::-1, :, :3]  # top first
                if f == 1:
                    gray = np.rint(rgb.astype(np.float64) @ _LUMA)
                else:  # mean of each f x f block of samples, then 8-bit levels
                    fine = rgb.astype(np.float32) @ _LUMA.astype(np.float32)
                    gray = np.rint(fine.reshape(res, f, res, f).mean(axis=(1, 3)))
                video[i] = gray.astype(np.float32) / np.float32(255.0)
        finally:
            if plotter.render_window is not None:
                plotter.clear_actors()
                plotter.scalar_bars.clear()


ANTI_ALIASING = ("ssaa", "msaa", "supersample", "none")
"""Values of :func:`render_orbit`'s ``anti_aliasing`` (``True`` means ``"ssaa"``, ``False``
``"msaa"``, which is what ``False`` has always rendered)."""
SUPERSAMPLE_FACTOR = 2
"""``anti_aliasing="supersample"`` renders this many times larger on each side, without
VTK's anti-aliasing, and averages each block of samples."""


def _anti_aliasing(value) -> str:
    """A mode of :data:`ANTI_ALIASING`; any non-string counts by its truth, as it always did."""
    if not isinstance(value, str):
        return "ssaa" if value else "msaa"
    if value in ANTI_ALIASING:
        return value
    raise ValueError(f"anti_aliasing must be True, False or one of {ANTI_ALIASING}, "
                     f"got {value!r}")


_SCENES: collections.OrderedDict[tuple, _Scene] = collections.OrderedDict()
_SCENES_LOCK = threading.Lock()
MAX_CACHED_PLOTTERS = 4
"""Off-screen plotters :func:`render_orbit` keeps for reuse (one per resolution and
anti-aliasing setting, least recently used dropped first)."""


def release_plotters() -> int:
    """Close the off-screen plotters :func:`render_orbit` keeps for reuse; return how many.

    They are made again on demand; call this to free their OpenGL memory. Runs at exit.

    Examples
    --------
    >>> _ = release_plotters()
    >>> release_plotters()  # none left to close
    0
    """
    with _SCENES_LOCK:
        scenes = list(_SCENES.values())
        _SCENES.clear()
    for scene in scenes:
        if scene.usable:
            scene.close()
    return len(scenes)


atexit.register(release_plotters)


def _cached_scene(resolution: int, anti_aliasing: str) -> _Scene:
    """The reusable scene for these settings (call with ``_SCENES_LOCK`` held)."""
    import pyvista as pv

    # pv.Plotter is in the key so that a replaced (e.g. test-patched) class is honoured
    key = (pv.Plotter, resolution, anti_aliasing)
    scene = _SCENES.pop(key, None)
    if scene is not None and not scene.usable:
        if scene.pid == os.getpid():
            scene.close()
        scene = None
    if scene is None:
        scene = _Scene(resolution, anti_aliasing)
    _SCENES[key] = scene  # most recently used last
    while len(_SCENES) > MAX_CACHED_PLOTTERS:
        _, old = _SCENES.popitem(last=False)
        if old.usable:
            old.close()
    return scene


def _render_frames(poly, cameras: np.ndarray, resolution: int, anti_aliasing: str,
                   reuse_plotter: bool) -> np.ndarray:
    """``(len(cameras), res, res)`` float32 gray frames of ``poly``."""
    video = np.empty((len(cameras), resolution, resolution), dtype=np.float32)
    if reuse_plotter and _SCENES_LOCK.acquire(blocking=False):
        try:
            scene = _cached_scene(resolution, anti_aliasing)
            try:
                scene.render(poly, cameras, video)
            except BaseException:  # never reuse a plotter that failed half-way
                for key, value in list(_SCENES.items()):
                    if value is scene:
                        del _SCENES[key]
                scene.close()
                raise
        finally:
            _SCENES_LOCK.release()
        return video
    # another thread is rendering with the cached plotters, or reuse is off: a private one
    scene = _Scene(resolution, anti_aliasing)
    try:
        scene.render(poly, cameras, video)
    finally:
        scene.close()
    return video


MAX_OBJECT_SIZE_M, MIN_OBJECT_SIZE_M = 2.0, 0.01
"""Largest and smallest bounding-box side :func:`render_orbit` accepts (m): the orbit is
built for objects normalised to the unit cube (the paper's 1 m^3)."""


def _check_in_view(bounds) -> None:
    """Refuse meshes the orbit cannot frame: off-centre, huge or tiny (m)."""
    lo, hi = np.asarray(bounds[0::2], dtype=float), np.asarray(bounds[1::2], dtype=float)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError("the mesh has no finite vertices; nothing to render")
    size, centre = float(np.max(hi - lo)), (lo + hi) / 2
    fix = "normalize it with e2vlib.shapes.normalize_mesh (centred, longest side 1 m)"
    if size > MAX_OBJECT_SIZE_M or size < MIN_OBJECT_SIZE_M:
        raise ValueError(
            f"the mesh's longest side is {size:.3g} m, outside [{MIN_OBJECT_SIZE_M}, "
            f"{MAX_OBJECT_SIZE_M}] m that the orbit frames; {fix}")
    if float(np.max(np.abs(centre))) > 0.5:
        raise ValueError(
            f"the mesh is centred at {np.round(centre, 3).tolist()} m, more than 0.5 m from "
            f"the origin the camera looks at; {fix}")


def render_orbit(
    mesh,
    n_video_frames: int = paper.N_VIDEO_FRAMES,
    fps: float = paper.VIDEO_FPS,
    resolution: int = 256,
    oversample: int = 1,
    anti_aliasing: bool | str = True,
    *,
    n_frames: int | None = None,
    reuse_plotter: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Render ``mesh`` along the spiral orbit; return ``(video, t_us)``.

    ``mesh`` is a ``trimesh.Trimesh`` or ``pyvista.PolyData`` in metres (not re-normalized
    here). One off-screen plotter (``resolution`` x ``resolution`` px, view angle
    :data:`VIEW_ANGLE_DEG`, white background, grey diffuse material, a sun-like directional
    light plus lights above and below) renders every frame. With ``reuse_plotter`` (the
    default) that plotter is kept, per resolution and ``anti_aliasing``, for the next call
    in this process (the mesh is removed after each call, the lights and background stay;
    :func:`release_plotters` closes them): making a plotter costs about 0.02 s, the first
    one in a process (OpenGL and shader set-up) several tenths. The pixels are the same
    either way. ``reuse_plotter=False`` makes a fresh plotter and
    closes it at the end.

    ``video`` has shape ``(n, resolution, resolution)``, float32 gray in [0, 1] holding
    8-bit levels (``k / 255``), indexed ``[frame, row, column]`` with row 0 at the top;
    ``t_us[i] = round(i * 1e6 / (oversample * fps))`` (int64 microseconds).
    With ``oversample = 1``, ``n = n_video_frames`` frames at ``fps``. With ``oversample = k``,
    the same time span is sampled ``k`` times more densely: ``n = k * (n_video_frames - 1) + 1``
    frames at ``k * fps`` along the same spiral, so ``video[::k]`` equals the plain render
    and an event simulator sees the object move at most about 1 px per frame (see
    :func:`pixel_motion_per_frame`).

    ``anti_aliasing`` smooths edges so they do not flicker as the object turns:
    ``True`` or ``"ssaa"`` (the default, what the datasets are built with) is VTK's
    supersampling pass (an image sqrt(5) x larger on each side, filtered back down);
    ``False`` or ``"msaa"`` is the window's multisampling as pyvista sets it up (8 samples
    asked for; Mesa's CPU renderer llvmpipe gives 4); ``"supersample"`` renders
    :data:`SUPERSAMPLE_FACTOR` x larger on each side with one sample per pixel and
    averages each 2 x 2 block of gray values here; ``"none"`` takes one sample per pixel
    (aliased edges flicker and make extra events). On a CPU renderer ``"msaa"`` and
    ``"supersample"`` take about half the time of ``"ssaa"`` and ``"none"`` a quarter (128 px)
    to a seventh (256 px); the sharper the edges, the more an event simulator's events
    gather on fewer pixels (``BuildConfig(anti_aliasing=...)`` builds datasets either way;
    bench/RESULTS.md, "Dataset building", compares the events).

    Examples
    --------
    Two video frames of a 0.5 m box at 16 px, then at twice the rate along the same path:

    >>> import trimesh
    >>> box = trimesh.creation.box((0.5, 0.5, 0.5))
    >>> video, t_us = render_orbit(box, n_video_frames=2, resolution=16)
    >>> video.shape, video.dtype, t_us.tolist()
    ((2, 16, 16), dtype('float32'), [0, 4167])
    >>> float(video[0, 0, 0]), bool(video[0, 8, 8] < 1)  # white corner, grey box in the middle
    (1.0, True)
    >>> dense, t_dense = render_orbit(box, n_video_frames=2, resolution=16, oversample=2)
    >>> t_dense.tolist(), bool((dense[::2] == video).all())
    ([0, 2083, 4167], True)

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    n = _video_frames(n_video_frames, n_frames)
    res = _check_count("resolution", resolution, 1)
    k = _check_count("oversample", oversample, 1)
    fps, k = _check_clock(fps, k)
    aa = _anti_aliasing(anti_aliasing)
    poly = to_polydata(mesh)
    _check_in_view(poly.bounds)
    cameras = rendered_cameras(n, k)
    t_us = rendered_times_us(n, fps, k)

    video = _render_frames(poly, cameras, res, aa, reuse_plotter)
    if float(video.max() - video.min()) < 1.0 / 255.0:
        raise ValueError(
            "the rendered video is blank (every pixel the same grey): the object is not in "
            "view; normalize the mesh with e2vlib.shapes.normalize_mesh first")
    return video, t_us


__all__ = [
    "ANTI_ALIASING", "AZIMUTH_START_DEG", "FOCAL_LENGTH_MM", "MAX_CACHED_PLOTTERS",
    "MAX_OBJECT_SIZE_M", "MIN_OBJECT_SIZE_M", "RADIUS_END_M", "RADIUS_MID_M", "SENSOR_SIZE_MM",
    "SUPERSAMPLE_FACTOR", "VIEW_ANGLE_DEG", "Z_BOTTOM_M", "Z_TOP_M", "headless_opengl_window",
    "orbit_angles", "orbit_cameras", "pixel_motion_per_frame", "project_points",
    "release_plotters", "render_orbit", "required_oversample", "to_polydata",
]
