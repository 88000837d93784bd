"""Render the paper's spiral camera orbit around an object into a grayscale video.

E2V (Chen et al., ICVR 2023) rendered each ShapeNet object in Blender while the camera
flew a spiral around it, always looking at the object, with an 80 mm lens on a 36 mm
sensor, a white background and a sun plus lights above and below. This module rebuilds
that set-up with pyvista/VTK rendering off screen: :func:`make_plotter` sets the scene up
(window, anti-aliasing, background, lights) and :func:`render_orbit` flies the camera along
the orbit, taking a grey picture at every stop. The orbit itself, its clock and the camera
model (numpy only) live in :mod:`e2vlib.orbit`, whose conventions hold here (metres,
degrees, microseconds; the camera looks at the origin with +z up); :func:`orbit_cameras`
is also importable from here. Builds that render many objects in one process can keep
their plotters for reuse (``e2vlib.scale.render_cache``).

Introduced in notebooks/03_simulating_events.ipynb.
"""

from __future__ import annotations

import numpy as np

from e2vlib import _headless, paper
from e2vlib.orbit import (
    VIEW_ANGLE_DEG,
    camera_axes,
    check_clock,
    check_count,
    orbit_cameras,
    rendered_cameras,
    rendered_times_us,
    resolve_video_frames,
)

_CLIPPING_RANGE = (0.1, 50.0)  # near/far planes (m); objects fit in the unit cube
_BACKGROUND = (1.0, 1.0, 1.0)
_MATERIAL = {"color": (0.8, 0.8, 0.8), "ambient": 0.15, "diffuse": 0.85, "specular": 0.0}
_LUMA = np.array([0.299, 0.587, 0.114])  # ITU-R BT.601 weights, RGB -> grey

ANTI_ALIASING = ("ssaa", "msaa", "supersample", "none")
"""Values of :func:`render_orbit`'s ``anti_aliasing`` (``True`` means ``"ssaa"``, ``False``
``"msaa"``, which is what ``False`` has always rendered)."""
SUPERSAMPLE_FACTOR = 2
"""``anti_aliasing="supersample"`` renders this many times larger on each side, without
VTK's anti-aliasing, and averages each block of samples."""

MAX_OBJECT_SIZE_M, MIN_OBJECT_SIZE_M = 2.0, 0.01
"""Largest and smallest bounding-box side :func:`render_orbit` accepts (m): the orbit is
built for objects normalised to the unit cube (the paper's 1 m^3)."""


def anti_aliasing_mode(value) -> str:
    """A mode of :data:`ANTI_ALIASING`; any non-string counts by its truth, as it always did."""
    if not isinstance(value, str):
        return "ssaa" if value else "msaa"
    if value in ANTI_ALIASING:
        return value
    raise ValueError(f"anti_aliasing must be True, False or one of {ANTI_ALIASING}, "
                     f"got {value!r}")


def make_plotter(resolution: int = 256, anti_aliasing: bool | str = True):
    """An off-screen ``pyvista.Plotter`` set up for the orbit, with no object in it yet.

    A square window of ``resolution`` px (:data:`SUPERSAMPLE_FACTOR` times larger for
    ``anti_aliasing="supersample"``), the anti-aliasing of :func:`render_orbit`, a white
    background, a sun-like directional light and weaker lights straight above and below.
    Close it with ``plotter.close()`` when done. Introduced in
    notebooks/03_simulating_events.ipynb.
    """
    import pyvista as pv

    res = check_count("resolution", resolution, 1)
    aa = anti_aliasing_mode(anti_aliasing)
    _headless.headless_opengl_window()
    size = res * (SUPERSAMPLE_FACTOR if aa == "supersample" else 1)
    plotter = pv.Plotter(off_screen=True, notebook=False, window_size=(size, size),
                         lighting="none")
    try:
        if aa == "ssaa":
            plotter.enable_anti_aliasing("ssaa")
        elif aa in ("supersample", "none"):
            plotter.render_window.SetMultiSamples(0)  # one sample per pixel
        # "msaa": the window's multisampling as pyvista sets it (its theme's 8 samples)
        plotter.set_background(_BACKGROUND)
        plotter.camera_set = True  # render_orbit aims the camera: pyvista must not move it
        for position, intensity in (((2.0, -1.0, 3.0), 0.75), ((0.0, 0.0, 1.0), 0.35),
                                    ((0.0, 0.0, -1.0), 0.25)):
            light = pv.Light(position=position, focal_point=(0.0, 0.0, 0.0),
                             light_type="scene light", intensity=intensity)
            light.positional = False  # directional: parallel rays, like the sun
            plotter.add_light(light)
    except BaseException:
        plotter.close()
        raise
    return plotter


def aim_camera(camera, position: np.ndarray, up: np.ndarray) -> None:
    """Put ``camera`` (VTK's, pyvista's included) at ``position`` (m) looking at the origin,
    ``up`` up in the image (:func:`e2vlib.orbit.camera_axes`), with the paper's lens."""
    camera.SetPosition(*(float(v) for v in position))
    camera.SetFocalPoint(0.0, 0.0, 0.0)
    camera.SetViewUp(*(float(v) for v in up))
    camera.SetViewAngle(VIEW_ANGLE_DEG)
    camera.SetClippingRange(*_CLIPPING_RANGE)


def _screenshot(plotter) -> np.ndarray:
    """Draw the plotter's view; return its pixels ``(S, S, 3)`` uint8, row 0 at the top.

    The pixels of ``plotter.screenshot()``, read straight from the window (VTK's
    ``GetPixelData``) rather than through an image filter: about ten times faster.
    """
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

    width, height = plotter.window_size
    pixels = vtkUnsignedCharArray()
    plotter.render_window.Render()
    plotter.render_window.GetPixelData(0, 0, width - 1, height - 1, 1, pixels, 0)
    return vtk_to_numpy(pixels).reshape(height, width, -1)[::-1, :, :3]


def _to_grey(rgb: np.ndarray, factor: int) -> np.ndarray:
    """8-bit RGB ``(S, S, 3)`` -> grey ``(S / factor, S / factor)`` float32 in [0, 1] holding
    8-bit levels ``k / 255``; with ``factor > 1`` each block of samples is averaged first."""
    if factor == 1:
        grey = np.rint(rgb.astype(np.float64) @ _LUMA)
    else:
        fine = rgb.astype(np.float32) @ _LUMA.astype(np.float32)
        side = len(rgb) // factor
        grey = np.rint(fine.reshape(side, factor, side, factor).mean(axis=(1, 3)))
    return grey.astype(np.float32) / np.float32(255.0)


def _checked_polydata(mesh):
    """``mesh`` (a ``trimesh.Trimesh`` or ``pyvista.PolyData``, m) as PolyData (``pv.wrap``,
    no copy), refused when it is something else, empty, non-finite or out of view."""
    import pyvista as pv

    try:
        poly = pv.wrap(mesh)
    except (NotImplementedError, TypeError, ValueError):
        poly = None
    if not isinstance(poly, pv.PolyData):
        raise ValueError(
            f"mesh must be a trimesh.Trimesh or pyvista.PolyData, got {type(mesh).__name__}")
    if poly.n_points == 0 or poly.n_cells == 0:
        raise ValueError("mesh is empty (no vertices or faces); nothing to render")
    if not np.all(np.isfinite(poly.points)):
        raise ValueError("mesh has NaN/inf vertex coordinates")
    lo, hi = np.asarray(poly.bounds[0::2]), np.asarray(poly.bounds[1::2])
    size, centre = float(np.max(hi - lo)), (lo + hi) / 2
    fix = "normalize it with e2vlib.shapes.normalize_mesh (centred, longest side 1 m)"
    if size > MAX_OBJECT_SIZE_M or size < MIN_OBJECT_SIZE_M:
        raise ValueError(f"the mesh's longest side is {size:.3g} m, outside [{MIN_OBJECT_SIZE_M}, "
                         f"{MAX_OBJECT_SIZE_M}] m that the orbit frames; {fix}")
    if float(np.max(np.abs(centre))) > 0.5:
        raise ValueError(f"the mesh is centred at {np.round(centre, 3).tolist()} m, more than "
                         f"0.5 m from the origin the camera looks at; {fix}")
    return poly


def render_orbit(
    mesh,
    n_video_frames: int = paper.N_VIDEO_FRAMES,
    fps: float = paper.VIDEO_FPS,
    resolution: int = 256,
    oversample: int = 1,
    anti_aliasing: bool | str = True,
    *,
    n_frames: int | None = None,
    plotter=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Render ``mesh`` along the spiral orbit; return ``(video, t_us)``.

    ``mesh`` is a ``trimesh.Trimesh`` or ``pyvista.PolyData`` in metres (not re-normalized
    here). An off-screen plotter (:func:`make_plotter`: ``resolution`` x ``resolution`` px,
    white background, grey diffuse material, a sun-like light plus lights above and below)
    gets the mesh; then, for every camera position of the orbit, the camera is aimed at the
    object (:func:`aim_camera`, view angle :data:`e2vlib.orbit.VIEW_ANGLE_DEG`) and a
    screenshot becomes one grey frame. ``plotter`` (keyword) lends a plotter made by
    ``make_plotter(resolution, anti_aliasing)``, left open with the mesh removed again (how
    ``e2vlib.scale.render_cache`` reuses plotters); by default one is made and closed.

    ``video`` has shape ``(n, resolution, resolution)``, float32 grey in [0, 1] holding
    8-bit levels (``k / 255``), indexed ``[frame, row, column]`` with row 0 at the top;
    ``t_us[i] = round(i * 1e6 / (oversample * fps))`` (int64 microseconds).
    With ``oversample = 1``, ``n = n_video_frames`` frames at ``fps``. With ``oversample = k``,
    the same time span is sampled ``k`` times more densely: ``n = k * (n_video_frames - 1) + 1``
    frames at ``k * fps`` along the same spiral, so ``video[::k]`` equals the plain render
    and an event simulator sees the object move at most about 1 px per frame (see
    :func:`e2vlib.orbit.pixel_motion_per_frame`). ``n_frames`` is the old name of
    ``n_video_frames``.

    ``anti_aliasing`` smooths edges so they do not flicker as the object turns:
    ``True`` or ``"ssaa"`` (the default, what the datasets are built with) is VTK's
    supersampling pass (an image sqrt(5) x larger on each side, filtered back down);
    ``False`` or ``"msaa"`` is the window's multisampling as pyvista sets it up (8 samples
    asked for; Mesa's CPU renderer llvmpipe gives 4); ``"supersample"`` renders
    :data:`SUPERSAMPLE_FACTOR` x larger on each side with one sample per pixel and
    averages each 2 x 2 block of grey values here; ``"none"`` takes one sample per pixel
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
    n = resolve_video_frames(n_video_frames, n_frames)
    res = check_count("resolution", resolution, 1)
    fps, k = check_clock(fps, oversample)
    aa = anti_aliasing_mode(anti_aliasing)
    poly = _checked_polydata(mesh)
    cameras, t_us = rendered_cameras(n, k), rendered_times_us(n, fps, k)
    factor = SUPERSAMPLE_FACTOR if aa == "supersample" else 1
    if plotter is not None and tuple(plotter.window_size) != (res * factor,) * 2:
        raise ValueError(f"the plotter's window is {tuple(plotter.window_size)} px, not "
                         f"{(res * factor,) * 2}: make it with make_plotter({res}, {aa!r})")

    own_plotter = plotter is None
    if own_plotter:
        plotter = make_plotter(res, aa)
    video = np.empty((len(cameras), res, res), dtype=np.float32)
    ups = camera_axes(cameras)[2]  # +z tilted to face each camera
    try:
        actor = plotter.add_mesh(poly, smooth_shading=False, **_MATERIAL)
        for i, (position, up) in enumerate(zip(cameras, ups, strict=True)):
            aim_camera(plotter.camera, position, up)
            video[i] = _to_grey(_screenshot(plotter), factor)
        plotter.remove_actor(actor, render=False)
    finally:
        if own_plotter:
            plotter.close()
    if float(video.max() - video.min()) < 1.0 / 255.0:
        raise ValueError(
            "the rendered video is blank (every pixel the same grey): the object is not in "
            "view; normalize the mesh with e2vlib.shapes.normalize_mesh first")
    return video, t_us


__all__ = [
    "ANTI_ALIASING", "MAX_OBJECT_SIZE_M", "MIN_OBJECT_SIZE_M", "SUPERSAMPLE_FACTOR",
    "aim_camera", "make_plotter", "orbit_cameras", "render_orbit",
]
