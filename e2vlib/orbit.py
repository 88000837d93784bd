"""The camera orbit's clock and geometry, numpy only: frame times, cameras, projection.

E2V (Chen et al., ICVR 2023) rendered each object while the camera flew a spiral around it:
from 2 m above to 2 m below the object, 4 m from the vertical axis at the ends and 6 m at
mid height, always looking at the object, with an 80 mm lens on a 36 mm sensor. This module
holds every number of that orbit and every function of it that needs no renderer; the
renderer (:mod:`e2vlib.render`), the dataset builder, the grey video and the geometry
baselines (:mod:`e2vlib.geometry`) all read the orbit from here.

Conventions (lengths in metres, angles in degrees, times in microseconds):

* orbit parameter ``s`` runs from 0 (first frame) to 1 (last frame);
* height ``z(s) = 2 - 4 s`` (linear, +2 m to -2 m);
* horizontal radius ``r(z) = 6 - z**2 / 2``: a parabola in ``z`` that is 4 m at ``z = +-2``
  and 6 m at ``z = 0``, smooth everywhere;
* azimuth ``phi(s) = -90 + 360 s``: one full counter-clockwise turn seen from above,
  starting on the -y side of the object (the "front" view of Blender, looking along +y, so
  +x is to the right in the first frame); the start is fixed so labels and views line up;
* the camera looks at the origin with +z as its up direction, so a +z-pointing object is
  upright in the image;
* the clock: ``n_video_frames`` video frames at ``fps`` (the paper's 120 at 240 fps, 0.5 s);
  ``oversample = k`` samples the same span ``k`` times more densely, :func:`n_rendered`
  ``= k (n_video_frames - 1) + 1`` frames, frame ``i`` at orbit parameter
  ``i / (n_rendered - 1)`` and at time ``round(i * 1e6 / (k * fps))`` us
  (:func:`rendered_times_us`), so every ``k``-th rendered frame is a video frame.

Names: the orbit (:func:`orbit_cameras`, :func:`orbit_angles`, :func:`rendered_cameras`,
:func:`orbit_camera_at`), the clock (:func:`n_rendered`, :func:`rendered_times_us`,
:func:`nearest_frames`, :func:`window_frame_indices`, :func:`window_cameras`), the camera
(:data:`VIEW_ANGLE_DEG`, :func:`camera_axes`, :func:`project_points`) and the oversampling rule
(:func:`pixel_motion_per_frame`, :func:`required_oversample`).

Introduced in notebooks/03_simulating_events.ipynb.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from e2vlib import paper

FOCAL_LENGTH_MM = paper.FOCAL_LENGTH_MM
"""Focal length of the paper's virtual camera (mm)."""
SENSOR_SIZE_MM = paper.SENSOR_WIDTH_MM
"""Sensor width (and height: our images are square) of the virtual camera (mm); our choice,
the paper gives only the focal length (see :data:`e2vlib.paper.SENSOR_WIDTH_MM`)."""
VIEW_ANGLE_DEG = math.degrees(2.0 * math.atan(0.5 * SENSOR_SIZE_MM / FOCAL_LENGTH_MM))
"""Full view angle of an 80 mm lens on a 36 mm sensor, about 25.36 degrees."""
AZIMUTH_START_DEG = -90.0
"""Azimuth of the first camera position (on the -y side, looking along +y)."""
Z_TOP_M, Z_BOTTOM_M = paper.ORBIT_Z_TOP_M, paper.ORBIT_Z_BOTTOM_M
"""Camera heights at the first and last frame (m)."""
RADIUS_END_M, RADIUS_MID_M = paper.ORBIT_SIZE_END_M, paper.ORBIT_SIZE_MID_M
"""Horizontal camera radius at the ends and at mid height (m); the paper's 4 m and 6 m read
as radii (our reading, :data:`e2vlib.paper.ORBIT_READING`)."""
CAMERA_TABLE_DENSITY = 64
""":func:`orbit_camera_at` interpolates in a table of the orbit this many times denser than
the video (off the true spiral by under a micrometre; exact at the video frames)."""
MAX_OVERSAMPLE = 64
"""The largest ``oversample`` :func:`required_oversample` searches."""


def check_count(name: str, value: int, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def resolve_video_frames(n_video_frames: int, n_frames: int | None) -> int:
    """Resolve the old keyword ``n_frames`` (video frames) to ``n_video_frames``."""
    if n_frames is not None:
        if n_video_frames != paper.N_VIDEO_FRAMES and n_video_frames != n_frames:
            raise TypeError("give n_video_frames or its old name n_frames, not both")
        n_video_frames = n_frames
    return check_count("n_video_frames (formerly n_frames)", n_video_frames, 2)


def _check_fps(fps: float) -> float:
    if not (isinstance(fps, (int, float, np.integer, np.floating)) and math.isfinite(fps)
            and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    return float(fps)


def check_clock(fps: float, oversample: int) -> tuple[float, int]:
    """``(fps, oversample)`` checked: whole-microsecond stamps must stay distinct."""
    fps = _check_fps(fps)
    k = check_count("oversample", oversample, 1)
    if k * fps > 1e6:
        raise ValueError(
            f"fps x oversample = {k * fps:g} frames/s puts several frames in one "
            f"microsecond, so their whole-microsecond time stamps would coincide; use "
            f"fps <= {1e6 / k:g}")
    return fps, k


def _spiral(s: np.ndarray) -> np.ndarray:
    """Camera positions (m, shape (len(s), 3)) at orbit parameters ``s`` in [0, 1]."""
    z = Z_TOP_M + (Z_BOTTOM_M - Z_TOP_M) * s
    half = 0.5 * (Z_TOP_M - Z_BOTTOM_M)
    r = RADIUS_MID_M - (RADIUS_MID_M - RADIUS_END_M) * (z / half) ** 2
    phi = np.radians(AZIMUTH_START_DEG + 360.0 * s)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _orbit_s(n: int) -> np.ndarray:
    """Orbit parameters ``i / (n - 1)``; exact division, so a k-times denser sampling
    hits the same ``s`` values bit for bit at every k-th frame."""
    return np.arange(n, dtype=np.float64) / (n - 1)


# --- the clock ------------------------------------------------------------------------------


def n_rendered(n_video_frames: int = paper.N_VIDEO_FRAMES, oversample: int = 1) -> int:
    """Frames rendered for ``oversample``: the same time span, ``oversample`` x denser.

    ``oversample * (n_video_frames - 1) + 1``: the first and last video frames are kept,
    and ``oversample - 1`` frames fall between each pair.

    Examples
    --------
    >>> n_rendered(120), n_rendered(120, 3)
    (120, 358)
    """
    n = check_count("n_video_frames", n_video_frames, 2)
    k = check_count("oversample", oversample, 1)
    return k * (n - 1) + 1


def rendered_times_us(n_video_frames: int = paper.N_VIDEO_FRAMES,
                      fps: float = paper.VIDEO_FPS, oversample: int = 1) -> np.ndarray:
    """Time stamps (int64 us, shape ``(n_rendered,)``) of the rendered frames.

    Frame ``i`` is at ``round(i * 1e6 / (oversample * fps))``, as
    :func:`e2vlib.render.render_orbit` stamps its video; :func:`n_rendered` frames in all.
    ``fps * oversample`` above 1e6 is refused (two frames would share a microsecond).

    Examples
    --------
    >>> t = rendered_times_us(120, 240)  # the paper's clock: 120 frames at 240 fps
    >>> len(t), t[:4].tolist(), int(t[-1])
    (120, [0, 4167, 8333, 12500], 495833)
    >>> t3 = rendered_times_us(120, 240, oversample=3)
    >>> len(t3), bool((t3[::3] == t).all())
    (358, True)
    """
    n = check_count("n_video_frames", n_video_frames, 2)
    fps, k = check_clock(fps, oversample)
    return np.round(np.arange(k * (n - 1) + 1) * 1e6 / (k * fps)).astype(np.int64)


def nearest_frames(t_us: ArrayLike, n_windows: int, dt_us: int) -> np.ndarray:
    """Index into ``t_us`` (sorted int64 us) of the frame nearest the centre
    ``(k + 1/2) dt_us`` of each window ``k < n_windows``; ties go to the earlier frame.

    Exact integer arithmetic (twice the times against twice the centres). Windows past the
    last frame get the last frame.

    Examples
    --------
    >>> t = np.array([0, 10, 20, 30])  # four frames, 10 us apart
    >>> nearest_frames(t, 5, 10).tolist()  # centres 5 (a tie: the earlier), 15, 25, 35, 45
    [0, 1, 2, 3, 3]
    """
    twice = 2 * np.asarray(t_us, dtype=np.int64)
    centre2 = (2 * np.arange(n_windows, dtype=np.int64) + 1) * int(dt_us)  # 2 x centre
    right = np.clip(np.searchsorted(twice, centre2), 1, len(twice) - 1)
    left = right - 1
    return np.where(centre2 - twice[left] <= twice[right] - centre2, left, right)


def window_frame_indices(n_windows: int, dt_us: int,
                         n_video_frames: int = paper.N_VIDEO_FRAMES,
                         fps: float = paper.VIDEO_FPS, oversample: int = 1) -> np.ndarray:
    """Which rendered frame is nearest the centre of each event window: ``(n_windows,)``.

    Windows ``k`` of ``dt_us`` from t = 0 (the orbit's first frame), centres at
    ``(k + 1/2) dt_us``; frames on the clock of :func:`rendered_times_us` (ties to the
    earlier frame, windows past the end get the last frame). The grey video of the dataset
    picks its frames this way.

    Examples
    --------
    >>> index = window_frame_indices(100, 5_000)  # centres 2500, 7500, 12500, ... us
    >>> index.shape, index[:4].tolist(), index[-2:].tolist()  # frame 119 is at 495.8 ms
    ((100,), [1, 2, 3, 4], [118, 119])
    """
    n = check_count("n_windows", n_windows, 1)
    dt = check_count("dt_us", dt_us, 1)
    return nearest_frames(rendered_times_us(n_video_frames, fps, oversample), n, dt)


# --- the orbit ------------------------------------------------------------------------------


def orbit_cameras(n_video_frames: int = paper.N_VIDEO_FRAMES, *,
                  n_frames: int | None = None) -> np.ndarray:
    """Camera positions of the paper's spiral orbit, shape ``(n_video_frames, 3)``, in metres.

    Frame ``i`` sits at orbit parameter ``s = i / (n_video_frames - 1)``: height ``2 - 4 s``,
    horizontal radius ``6 - z**2 / 2`` (4 m at the ends, 6 m at ``z = 0``) and azimuth
    ``-90 + 360 s`` degrees (one counter-clockwise turn starting on the -y side). Every
    camera looks at the origin with +z up. ``n_frames`` is the old name of
    ``n_video_frames``.

    Examples
    --------
    >>> cams = orbit_cameras(3)  # start, middle, end
    >>> (np.round(cams, 6) + 0.0).tolist()  # + 0.0 turns -0.0 into 0.0
    [[0.0, -4.0, 2.0], [0.0, 6.0, 0.0], [0.0, -4.0, -2.0]]
    >>> orbit_cameras().shape
    (120, 3)

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    n = resolve_video_frames(n_video_frames, n_frames)
    return _spiral(_orbit_s(n))


def orbit_angles(n_video_frames: int = paper.N_VIDEO_FRAMES, *, n_frames: int | None = None,
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-frame ``(azimuth_deg, elevation_deg, distance_m)`` of :func:`orbit_cameras`.

    Azimuth is measured counter-clockwise from +x (it runs from -90 to 270 degrees),
    elevation is the camera's angle above the horizontal plane through the object
    (positive while the camera is above it), distance is from the camera to the origin.
    Each array has shape ``(n_video_frames,)``.

    Examples
    --------
    >>> azimuth, elevation, distance = orbit_angles(3)
    >>> azimuth.tolist(), np.round(elevation, 2).tolist(), np.round(distance, 3).tolist()
    ([-90.0, 90.0, 270.0], [26.57, 0.0, -26.57], [4.472, 6.0, 4.472])

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    n = resolve_video_frames(n_video_frames, n_frames)
    s = _orbit_s(n)
    pos = _spiral(s)
    horizontal = np.hypot(pos[:, 0], pos[:, 1])
    azimuth = AZIMUTH_START_DEG + 360.0 * s
    elevation = np.degrees(np.arctan2(pos[:, 2], horizontal))
    return azimuth, elevation, np.linalg.norm(pos, axis=1)


def rendered_cameras(n_video_frames: int = paper.N_VIDEO_FRAMES,
                     oversample: int = 1) -> np.ndarray:
    """Camera positions ``(n_rendered, 3)`` (m) of every frame rendered with ``oversample``.

    ``orbit_cameras(n_rendered(n_video_frames, oversample))``: row ``i`` is the camera of
    the frame stamped ``rendered_times_us(...)[i]``; every ``oversample``-th row is a video
    frame's camera, bit for bit.

    Examples
    --------
    >>> dense = rendered_cameras(120, oversample=3)
    >>> dense.shape, bool((dense[::3] == orbit_cameras(120)).all())
    ((358, 3), True)
    """
    return _spiral(_orbit_s(n_rendered(n_video_frames, oversample)))


def window_cameras(n_windows: int, dt_us: int, n_video_frames: int = paper.N_VIDEO_FRAMES,
                   fps: float = paper.VIDEO_FPS, oversample: int = 1) -> np.ndarray:
    """Camera ``(n_windows, 3)`` (m) of the rendered frame nearest each window's centre.

    ``rendered_cameras(n_video_frames, oversample)[window_frame_indices(...)]``: the
    cameras of the grey video's frames. :func:`orbit_camera_at` gives the camera at the
    centre itself (between frames).

    Examples
    --------
    >>> cams = window_cameras(100, 5_000)
    >>> cams.shape, bool((cams[0] == orbit_cameras(120)[1]).all())
    ((100, 3), True)
    """
    index = window_frame_indices(n_windows, dt_us, n_video_frames, fps, oversample)
    return rendered_cameras(n_video_frames, oversample)[index]


def orbit_camera_at(t_us: ArrayLike, n_video_frames: int = paper.N_VIDEO_FRAMES,
                    fps: float = paper.VIDEO_FPS) -> np.ndarray:
    """Camera positions ``(m, 3)`` (m) of the render orbit at times ``t_us`` (microseconds).

    :func:`e2vlib.render.render_orbit` puts video frame ``i`` at ``i * 1e6 / fps`` us and
    orbit parameter ``i / (n_video_frames - 1)`` (with any ``oversample``), so time ``t``
    sits at ``s = t * fps / (1e6 * (n_video_frames - 1))``, clipped to [0, 1]. Positions are
    interpolated linearly in a table of the orbit :data:`CAMERA_TABLE_DENSITY` times denser
    than the video (off the true spiral by under a micrometre; exact at the video frames).

    Examples
    --------
    >>> cams = orbit_camera_at([0, 1e6 * 119 / 240])  # the first and the last video frame
    >>> bool(np.allclose(cams, orbit_cameras(120)[[0, -1]]))
    True
    >>> (orbit_camera_at([-5, 10**7]).round(6) + 0.0).tolist()  # before and after: clipped
    [[0.0, -4.0, 2.0], [0.0, -4.0, -2.0]]
    """
    n = check_count("n_video_frames", n_video_frames, 2)
    fps = _check_fps(fps)
    t = np.asarray(t_us, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(t)):
        raise ValueError("t_us holds NaN/inf times")
    s = np.clip(t * fps / (1e6 * (n - 1)), 0.0, 1.0)
    dense = CAMERA_TABLE_DENSITY * (n - 1)
    table = _spiral(_orbit_s(dense + 1))
    grid_s = np.arange(dense + 1) / dense
    return np.stack([np.interp(s, grid_s, table[:, axis]) for axis in range(3)], axis=1)


# --- the camera and the oversampling rule --------------------------------------------------


def camera_axes(camera_position: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit axes ``(forward, right, up)`` of the render camera at ``camera_position`` (m).

    The camera looks at the origin (``forward``) and keeps +z up in the image: ``right`` is
    ``forward x z`` and ``up`` is ``right x forward``. ``camera_position`` is ``(3,)`` or a
    stack ``(..., 3)``; each axis has its shape. The renderer aims its camera with these
    axes, :func:`project_points` projects with them and ``e2vlib.viz.camera_frustum`` draws
    them.

    Examples
    --------
    >>> forward, right, up = camera_axes([0.0, -4.0, 0.0])  # on the -y side, level
    >>> (forward + 0.0).tolist(), (right + 0.0).tolist(), (up + 0.0).tolist()
    ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    """
    position = np.asarray(camera_position, dtype=np.float64)
    if position.shape[-1:] != (3,):
        raise ValueError(f"camera_position must be (3,) or (..., 3), got shape {position.shape}")
    forward = -position / np.linalg.norm(position, axis=-1, keepdims=True)
    right = np.cross(forward, (0.0, 0.0, 1.0))
    norm = np.linalg.norm(right, axis=-1, keepdims=True)
    if not np.all(norm >= 1e-9):  # also NaN
        raise ValueError("camera_position must not lie on the z axis (up direction is +z)")
    right = right / norm
    return forward, right, np.cross(right, forward)


def project_points(points: ArrayLike, camera_position: ArrayLike, resolution: int) -> np.ndarray:
    """Pixel coordinates ``(m, 2)`` as ``(column, row)`` of 3-D ``points`` (m, shape (m, 3)).

    Pinhole model of the render camera: at ``camera_position`` looking at the origin with +z
    up, view angle :data:`VIEW_ANGLE_DEG`, square image of ``resolution`` pixels. Row 0 is
    the top of the image and pixel ``(c, r)`` has its centre at ``(c, r)``, so the image
    centre is at ``((res - 1) / 2, (res - 1) / 2)``. Points must be in front of the camera.

    Examples
    --------
    >>> cam = orbit_cameras()[0]  # (0, -4, 2): the first camera, above the -y side
    >>> project_points([[0, 0, 0]], cam, 256).tolist()  # the origin: the image centre
    [[127.5, 127.5]]
    >>> col, row = project_points([[0.1, 0, 0]], cam, 256)[0]  # +x: to the right
    >>> bool(col > 127.5), round(float(row), 6)
    (True, 127.5)

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    res = check_count("resolution", resolution, 1)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    cam = np.asarray(camera_position, dtype=np.float64).reshape(3)
    forward, right, up = camera_axes(cam)
    rel = pts - cam
    depth = rel @ forward
    if np.any(depth <= 0):
        raise ValueError("some points lie behind the camera; they have no projection")
    focal_px = 0.5 * res / math.tan(math.radians(0.5 * VIEW_ANGLE_DEG))
    centre = 0.5 * (res - 1)
    col = centre + focal_px * (rel @ right) / depth
    row = centre - focal_px * (rel @ up) / depth
    return np.stack([col, row], axis=1)


def pixel_motion_per_frame(
    n_video_frames: int = paper.N_VIDEO_FRAMES,
    resolution: int = 256,
    oversample: int = 1,
    points: ArrayLike | None = None,
    *,
    n_frames: int | None = None,
) -> np.ndarray:
    """Largest image motion (pixels) of the object between consecutive rendered frames.

    Projects ``points`` (default: a 9 x 9 x 9 grid filling the unit cube
    ``[-0.5, 0.5]^3``, where normalized objects live) with every camera of the orbit as
    :func:`e2vlib.render.render_orbit` samples it (:func:`rendered_cameras`) and returns
    the maximum displacement over the points for each consecutive pair, shape
    ``(n_rendered - 1,)``. The frame rate does not enter: motion per frame depends only on
    how densely the path is sampled. The paper's 120 frames at 256 px move points of the
    unit cube by 4 to 5 px per frame; an event simulator that interpolates linearly between
    frames wants at most about 1 px, hence ``oversample``.

    Examples
    --------
    >>> motion = pixel_motion_per_frame(120, 256)
    >>> motion.shape, round(float(motion.max()), 1)
    ((119,), 5.2)
    >>> round(float(pixel_motion_per_frame(120, 256, oversample=6).max()), 2)
    0.87

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    n = resolve_video_frames(n_video_frames, n_frames)
    k = check_count("oversample", oversample, 1)
    res = check_count("resolution", resolution, 1)
    if points is None:
        g = np.linspace(-0.5, 0.5, 9)
        points = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    cams = rendered_cameras(n, k)
    uv = np.stack([project_points(pts, c, res) for c in cams])  # (frames, points, 2)
    return np.linalg.norm(np.diff(uv, axis=0), axis=2).max(axis=1)


def required_oversample(
    n_video_frames: int = paper.N_VIDEO_FRAMES, resolution: int = 256,
    max_motion_px: float = 1.0, *, n_frames: int | None = None,
) -> int:
    """Smallest ``oversample`` for which :func:`pixel_motion_per_frame` stays within
    ``max_motion_px`` pixels on every frame pair (searched up to :data:`MAX_OVERSAMPLE`).

    Examples
    --------
    >>> required_oversample(120, 128), required_oversample(120, 256)
    (3, 6)

    Introduced in notebooks/03_simulating_events.ipynb.
    """
    if not (math.isfinite(max_motion_px) and max_motion_px > 0):
        raise ValueError(f"max_motion_px must be a positive number, got {max_motion_px!r}")
    n_frames = resolve_video_frames(n_video_frames, n_frames)
    worst = float(pixel_motion_per_frame(n_frames, resolution, 1).max())
    k = max(1, math.ceil(worst / max_motion_px))  # motion shrinks about as 1/k
    while k <= MAX_OVERSAMPLE:
        if pixel_motion_per_frame(n_frames, resolution, k).max() <= max_motion_px:
            return k
        k += 1
    raise ValueError(f"no oversample up to {MAX_OVERSAMPLE} keeps motion within "
                     f"{max_motion_px} px")
