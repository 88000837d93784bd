"""Geometry baselines without learning: shape from known camera poses.

Two classical ways to get a 32^3 occupancy grid from the orbit, to compare with E2V:

* **visual hull** (:func:`visual_hull`): from the rendered grey frames, each frame's
  silhouette (:func:`silhouettes_from_video`) is a cone from the camera; the object lies in
  the intersection of all cones. A voxel's occupancy is the share of its sample points that
  project inside every silhouette. It needs the frames, which an event camera does not give.
* **event rays** (:func:`event_ray_density`, :func:`fill_solid`): events only. The events
  are grouped into binary event frames (the model's input), each frame is seen from the
  camera at its window's mid-time (:func:`orbit_camera_at`), and every voxel counts the
  frames whose event pixels its centre projects onto (ray counting as in EMVS, done from
  the voxel's side). Raw event pixels mark only the edges that moved, too thin a set to
  enclose a solid, so by default each frame is first turned into a silhouette estimate
  (:func:`silhouettes_from_events`: neighbouring frames merged, each image row filled
  between its outermost events, because the orbit moves the image along its rows and only
  outlines across the rows fire reliably). The density is then a hull vote, the share of
  frames whose estimate holds the voxel; :func:`fill_solid` keeps voxels with a share of
  at least :data:`EVENT_VOTE_THRESHOLD`, closes one-voxel gaps and fills enclosed holes.

Measured (IoU at 0.3 against the labels; dataset settings: 128 px render with 3x
oversampling, contrast 0.2, 120 orbit frames for the hull, 100 event frames of 5 ms):
a 0.5 m box 0.76 (hull) / 0.70 (events), a sphere 0.90 / 0.73; three data_small test
objects each of car 0.74 / 0.54, chair 0.60 / 0.24, table 0.60 / 0.36, airplane 0.66 /
0.37 (events at 128 px; from the stored 64 px model input about 0.03 lower). Raw event
rays without silhouettes reach at most 0.21 on the box. The hull never carved a voxel of
the box or sphere; on the objects it loses thin-part voxels (see :func:`visual_hull`).

Frames and conventions are those of :mod:`e2vlib.orbit` (camera looking at the origin, +z
up, ``project_points``: pixel ``(column, row)`` centres at integers, row 0 at the top) and
:mod:`e2vlib.voxels` (grid ``[i, j, k] = (x, y, z)`` over ``[-0.5, 0.5]^3``, voxel ``i``
centred at ``-0.5 + (i + 0.5) / grid``), so the results compare directly with the dataset's
labels; :func:`score_occupancy` scores them as the learned model is scored.

Lifting (:func:`lifting_table`, :func:`lift_frames`) is the same back-projection written for
a learner: each voxel centre is projected once into every event frame of the known orbit
(the table of pixel indices, made once per orbit and frame size), and then lifting a stack
of frames is one look-up per voxel and frame, summarised as two channels (:data:`LIFTED_CHANNELS`):
the silhouette vote of event carving and the raw event-ray share. A hybrid model reads them
beside the frames (``E2VConfig.lift``; lesson 15).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike
from scipy import ndimage

from e2vlib import paper
from e2vlib.metrics import score_predictions
from e2vlib.orbit import orbit_camera_at, project_points  # orbit_camera_at re-exported

SILHOUETTE_TOLERANCE = 0.5 / 255
"""A pixel belongs to the silhouette when it differs from the background by more than this
(half an 8-bit level): anti-aliased edge pixels count, so silhouettes err on the large side,
which keeps the visual hull a superset of the object."""


def _check_int(name: str, value: int, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _check_masks(name: str, masks: ArrayLike, resolution: int | None) -> np.ndarray:
    """``masks`` as a bool ``(n, res, res)`` array; ``resolution`` must match if given."""
    m = np.asarray(masks)
    if m.ndim != 3 or m.shape[0] == 0 or m.shape[1] != m.shape[2] or m.shape[1] == 0:
        raise ValueError(f"{name} must be a non-empty (n_views, res, res) stack of square "
                         f"images, got shape {m.shape}")
    if resolution is not None and _check_int("resolution", resolution, 1) != m.shape[1]:
        raise ValueError(f"resolution={resolution} does not match the {m.shape[1]} px "
                         f"{name}")
    if m.dtype != bool:
        if not np.issubdtype(m.dtype, np.number) or not np.all(np.isin(m, (0, 1))):
            raise ValueError(f"{name} must be binary (bool or 0/1), got dtype {m.dtype}")
        m = m.astype(bool)
    return m


def _check_cameras(cameras: ArrayLike, n_views: int) -> np.ndarray:
    c = np.asarray(cameras, dtype=np.float64)
    if c.shape != (n_views, 3):
        raise ValueError(f"cameras must be ({n_views}, 3) positions in metres, one per view, "
                         f"got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError("cameras hold NaN/inf positions")
    return c


def sample_points(grid: int = paper.GRID_SIDE, samples: int = 1) -> np.ndarray:
    """Points ``(grid**3 * samples**3, 3)`` (m) filling the voxels of the label grid.

    Each voxel holds ``samples**3`` points at the centres of its sub-cells (``samples=1``:
    the voxel centre), listed voxel by voxel in the grid's ``[i, j, k]`` order, so
    ``values.reshape(grid, grid, grid, samples**3)`` regroups a per-point result.

    Examples
    --------
    >>> points = sample_points(2)  # the centres of a 2 x 2 x 2 grid
    >>> points.shape, points[0].tolist(), points[-1].tolist()
    ((8, 3), [-0.25, -0.25, -0.25], [0.25, 0.25, 0.25])
    >>> sample_points(2, samples=2).shape  # 8 points in each of the 8 voxels
    (64, 3)
    """
    g = _check_int("grid", grid, 1)
    s = _check_int("samples", samples, 1)
    fine = -0.5 + (np.arange(g * s) + 0.5) / (g * s)  # sub-cell centres along one axis
    pts = np.stack(np.meshgrid(fine, fine, fine, indexing="ij"), axis=-1)
    pts = pts.reshape(g, s, g, s, g, s, 3)  # fine index i * s + a -> (i, a)
    # index order (i, a, j, b, k, c) -> (i, j, k, a, b, c)
    return np.ascontiguousarray(pts.transpose(0, 2, 4, 1, 3, 5, 6)).reshape(-1, 3)


def _hits(masks: np.ndarray, cameras: np.ndarray, points: np.ndarray,
          max_misses: int | None = None) -> np.ndarray:
    """Per point, in how many views it projects onto a set pixel of ``masks``.

    A point projecting outside the image counts as a hit (no information, nothing carved).
    With ``max_misses``, points that already missed more views are no longer projected
    (their count is then only a lower bound, but they are out anyway).
    """
    n, res, _ = masks.shape
    count = np.zeros(len(points), dtype=np.int32)
    misses = np.zeros(len(points), dtype=np.int32)
    alive = np.arange(len(points))
    for view in range(n):
        if alive.size == 0:
            break
        uv = np.rint(project_points(points[alive], cameras[view], res)).astype(np.int64)
        col, row = uv[:, 0], uv[:, 1]
        inside = (col >= 0) & (col < res) & (row >= 0) & (row < res)
        hit = ~inside
        hit[inside] = masks[view, row[inside], col[inside]]
        count[alive[hit]] += 1
        misses[alive[~hit]] += 1
        if max_misses is not None:
            alive = alive[misses[alive] <= max_misses]
    return count


def silhouettes_from_video(video: ArrayLike, background: float = 1.0,
                           tolerance: float = SILHOUETTE_TOLERANCE) -> np.ndarray:
    """Binary silhouettes ``(n, H, W)`` of a rendered video: pixels unlike the background.

    ``video``: ``(n, H, W)`` float in [0, 1] or uint8 (read as ``I / 255``), as
    :func:`e2vlib.render.render_orbit` makes it; its background is white (1.0) and the lit
    grey object never reaches white, so ``|I - background| > tolerance`` is the object
    (with its anti-aliased edge).

    Examples
    --------
    >>> video = np.ones((1, 2, 3))  # one white frame
    >>> video[0, 0, 1] = 0.5  # one grey pixel
    >>> silhouettes_from_video(video).astype(int).tolist()
    [[[0, 1, 0], [0, 0, 0]]]
    """
    v = np.asarray(video)
    if v.ndim != 3:
        raise ValueError(f"video must be (n_frames, height, width), got shape {v.shape}")
    if v.dtype == np.uint8:
        v = v / 255.0
    elif not np.issubdtype(v.dtype, np.floating):
        raise ValueError(f"video must be float in [0, 1] or uint8, got dtype {v.dtype}")
    if not (math.isfinite(background) and 0.0 <= background <= 1.0):
        raise ValueError(f"background must be a grey level in [0, 1], got {background!r}")
    if not (math.isfinite(tolerance) and tolerance >= 0):
        raise ValueError(f"tolerance must be a finite number >= 0, got {tolerance!r}")
    if not np.all(np.isfinite(v)):
        raise ValueError("video holds NaN/inf values")
    return np.abs(v - background) > tolerance


def visual_hull(silhouettes: ArrayLike, cameras: ArrayLike, resolution: int | None = None,
                grid: int = paper.GRID_SIDE, samples: int = 1,
                min_fraction: float = 1.0) -> np.ndarray:
    """Occupancy ``(grid, grid, grid)`` float32 in [0, 1] carved from silhouettes.

    ``silhouettes``: ``(n_views, res, res)`` binary, seen from ``cameras`` ``(n_views, 3)``
    (m; e.g. :func:`e2vlib.orbit.orbit_cameras`); ``resolution`` (px) is checked against
    them when given. Each voxel holds ``samples**3`` points (:func:`sample_points`); a point
    survives when it projects (nearest pixel) inside the silhouette in at least
    ``min_fraction`` of the views (1: every view, the classical hull; lower values tolerate
    wrong silhouettes). The voxel's value is the share of its points that survive.

    With the default ``samples=1`` a voxel is kept when its centre survives, the rule by
    which the labels fill an object's inside: with exact (or slightly large) silhouettes
    every voxel whose centre lies inside the object is kept. The labels also keep voxels
    that a part thinner than a voxel only passes through (chair legs, a thin table top);
    their centres can fall outside the silhouettes and get carved. ``samples=2`` or more
    with ``value > 0`` keeps such voxels too (a conservative hull), at the price of about
    half a voxel of extra shell on thick parts.

    Examples
    --------
    The first camera of the orbit (on the -y side, +x to the right in its image) sees a
    silhouette filling the left half of its image: the hull keeps the voxels with x < 0.

    >>> from e2vlib.orbit import orbit_cameras
    >>> masks = np.zeros((1, 16, 16), bool)
    >>> masks[0, :, :8] = True
    >>> hull = visual_hull(masks, orbit_cameras()[:1], grid=4)
    >>> hull.shape, hull.dtype, float(hull[:2].min()), float(hull[2:].max())
    ((4, 4, 4), dtype('float32'), 1.0, 0.0)
    """
    masks = _check_masks("silhouettes", silhouettes, resolution)
    cams = _check_cameras(cameras, masks.shape[0])
    if not (isinstance(min_fraction, int | float) and 0 < min_fraction <= 1):
        raise ValueError(f"min_fraction must be in (0, 1], got {min_fraction!r}")
    g, s = _check_int("grid", grid, 1), _check_int("samples", samples, 1)
    need = math.ceil(min_fraction * len(cams) - 1e-9)
    points = sample_points(g, s)
    kept = _hits(masks, cams, points, max_misses=len(cams) - need) >= need
    return kept.reshape(g, g, g, s**3).mean(axis=3).astype(np.float32)


MERGE_FRAMES = 5
"""Event frames OR-ed together (centred on each frame) before its outline is filled: 5
frames of 5 ms, a 25 ms stretch of the orbit (about 18 degrees of azimuth)."""

EVENT_VOTE_THRESHOLD = 0.9
"""Share of event silhouettes that must hold a voxel for :func:`fill_solid` to keep it by
default. Merged, row-filled silhouettes err on the large side, so the vote must be nearly
unanimous; but round outlines (a sphere's top and bottom) make few events and leave
silhouettes short, which a unanimous vote would carve. 0.9 is our choice from the
measurements in the module docstring (0.95 scores a little higher on data_small objects and
far lower on a sphere)."""


def silhouettes_from_events(frames: ArrayLike, merge_frames: int = MERGE_FRAMES) -> np.ndarray:
    """Silhouette estimates ``(n, H, W)`` bool from binary event frames ``(n, H, W)``.

    Events of a moving object mark its edges, and an outline is rarely closed: on the
    orbit the camera turns about the vertical, so the image moves along its rows, and edges
    lying along the rows (tops, bottoms) make few events. The left and right outline moves
    across every row it meets, though. So frame ``k`` is OR-ed with its neighbours
    (``merge_frames`` frames centred on it, to bridge gaps), and each row is filled from
    its first to its last event pixel. This errs on the large side in concave places
    (between a table's legs) and on the small side where an outline made no events; the
    vote over many frames (:func:`frames_ray_density`) averages both out. A frame without
    events gives an empty silhouette.

    Examples
    --------
    >>> frames = np.zeros((1, 4, 4), bool)
    >>> frames[0, 1, [0, 2]] = True  # the left and right outline of one row
    >>> silhouettes_from_events(frames, merge_frames=1)[0].astype(int).tolist()
    [[0, 0, 0, 0], [1, 1, 1, 0], [0, 0, 0, 0], [0, 0, 0, 0]]
    """
    masks = _check_masks("frames", frames, None)
    k = _check_int("merge_frames", merge_frames, 1)
    if k > 1:
        masks = ndimage.maximum_filter1d(masks.astype(np.uint8), k, axis=0).astype(bool)
    width = masks.shape[2]
    any_event = masks.any(axis=2)
    first = np.where(any_event, np.argmax(masks, axis=2), width)
    last = np.where(any_event, width - 1 - np.argmax(masks[:, :, ::-1], axis=2), -1)
    column = np.arange(width)
    return (column >= first[..., None]) & (column <= last[..., None])


def frames_ray_density(frames: ArrayLike, cameras: ArrayLike, grid: int = paper.GRID_SIDE,
                       fill_frames: bool = True,
                       merge_frames: int = MERGE_FRAMES) -> np.ndarray:
    """Share of frames ``(grid, grid, grid)`` float32 whose set pixels a voxel's centre hits.

    ``frames``: ``(n, res, res)`` binary event frames, each seen from ``cameras[k]``
    (``(n, 3)``, m). With ``fill_frames`` (default) the frames are first turned into
    silhouettes (:func:`silhouettes_from_events`), making the share a hull vote; without,
    the raw event pixels are used (EMVS-style counting of the event rays through each
    voxel, high only near edges the events saw). Frames left empty carry no information
    and do not count.

    Examples
    --------
    >>> from e2vlib.orbit import orbit_cameras
    >>> frames = np.zeros((2, 16, 16), bool)
    >>> frames[0, :, :8] = True  # events over the left half; frame 1 has none
    >>> density = frames_ray_density(frames, orbit_cameras()[:2], grid=4, fill_frames=False)
    >>> float(density[:2].min()), float(density[2:].max())  # only frame 0 counts
    (1.0, 0.0)
    """
    masks = _check_masks("frames", frames, None)
    cams = _check_cameras(cameras, masks.shape[0])
    g = _check_int("grid", grid, 1)
    if fill_frames:
        masks = silhouettes_from_events(masks, merge_frames)
    used = masks.reshape(len(masks), -1).any(axis=1)
    if not used.any():
        raise ValueError("all event frames are empty; there is nothing to back-project")
    counts = _hits(masks[used], cams[used], sample_points(g, 1))
    return (counts / int(used.sum())).reshape(g, g, g).astype(np.float32)


def event_ray_density(
    events: np.ndarray,
    cameras_at_time: Callable[[np.ndarray], np.ndarray],
    resolution: int,
    grid: int = paper.GRID_SIDE,
    dt_us: int = paper.DT_US,
    t0_us: int = 0,
    fill_frames: bool = True,
    merge_frames: int = MERGE_FRAMES,
) -> np.ndarray:
    """Events-only occupancy evidence ``(grid, grid, grid)`` float32 in [0, 1].

    ``events`` (:data:`~e2vlib.events.EVENT_DTYPE`) from a ``resolution`` x ``resolution``
    px sensor are grouped into binary frames of ``dt_us`` from ``t0_us`` (fixed windows,
    :func:`e2vlib.frames.accumulate`); frame ``k`` is seen from
    ``cameras_at_time(t0 + (k + 0.5) dt)`` (a function of an int64 array of microseconds
    returning ``(m, 3)`` positions, e.g. :func:`orbit_camera_at`). Then as
    :func:`frames_ray_density`; turn the result into a solid with :func:`fill_solid`.

    Examples
    --------
    Events over the left half of a 16 px sensor at 2.5 ms, the first 5 ms window's
    middle, seen from the orbit camera of that time: the voxels with x < 0.

    >>> from e2vlib.events import make_events
    >>> y, x = np.mgrid[0:16, 0:8]
    >>> events = make_events(x.ravel(), y.ravel(), np.full(x.size, 2500), np.ones(x.size))
    >>> density = event_ray_density(events, orbit_camera_at, 16, grid=4)
    >>> density.shape, float(density[:2].min()), float(density[2:].max())
    ((4, 4, 4), 1.0, 0.0)
    """
    from e2vlib.frames import accumulate

    res = _check_int("resolution", resolution, 1)
    dt = _check_int("dt_us", dt_us, 1)
    if not callable(cameras_at_time):
        raise ValueError("cameras_at_time must be a function from times (us) to (m, 3) "
                         "camera positions, e.g. e2vlib.geometry.orbit_camera_at")
    if len(events) == 0:
        raise ValueError("no events; there is nothing to back-project")
    frames = accumulate(events, (res, res), dt_us=dt, t0_us=t0_us)
    mid = t0_us + (np.arange(len(frames), dtype=np.int64) * dt + dt // 2)
    cameras = np.asarray(cameras_at_time(mid), dtype=np.float64)
    return frames_ray_density(frames, cameras, grid, fill_frames, merge_frames)


# --- lifting: the event frames back-projected into the grid, for a learner ------------------

LIFTED_CHANNELS = ("silhouette_vote", "event_rays")
"""The channels of :func:`lift_frames`: per voxel, the share of event frames whose silhouette
estimate holds its centre (event carving's vote, :func:`frames_ray_density`), and the share
whose raw event pixels it hits (the EMVS-style ray count, ``fill_frames=False``)."""


def window_centre_cameras(n_frames: int = paper.N_EVENT_FRAMES, dt_us: int = paper.DT_US,
                          t0_us: int = 0) -> np.ndarray:
    """Camera ``(n_frames, 3)`` (m) at the middle of each event window ``t0 + (k + 1/2) dt``.

    Windows run on the orbit's clock (``t0_us = 0``: the first video frame), as the stored
    frames of a dataset do; the cameras are :func:`orbit_camera_at` of the window centres,
    the ones :func:`event_ray_density` uses.

    Examples
    --------
    >>> window_centre_cameras(100, 5000).shape
    (100, 3)
    """
    n = _check_int("n_frames", n_frames, 1)
    dt = _check_int("dt_us", dt_us, 1)
    return orbit_camera_at(t0_us + np.arange(n, dtype=np.int64) * dt + dt // 2)


def lifting_table(n_frames: int = paper.N_EVENT_FRAMES, dt_us: int = paper.DT_US,
                  resolution: int = paper.FRAME_SIZE_PX, grid: int = paper.GRID_SIDE,
                  t0_us: int = 0) -> np.ndarray:
    """Where each voxel centre lands in each event frame: ``(n_frames, grid**3)`` int32.

    Entry ``[k, v]`` is the flat pixel index ``row * resolution + column`` of voxel ``v``'s
    centre (:func:`sample_points` order, ``[i, j, k]`` of the grid) seen from the camera of
    frame ``k`` (:func:`window_centre_cameras`), the nearest pixel of a ``resolution`` px
    square frame; ``-1`` where the centre falls outside the frame. The orbit is the same
    for every sample, so the table is made once and serves every stack of frames.

    Examples
    --------
    >>> table = lifting_table(n_frames=2, resolution=16, grid=4)
    >>> table.shape, table.dtype, int(table.min()) >= 0  # every centre is in view
    ((2, 64), dtype('int32'), True)
    """
    n = _check_int("n_frames", n_frames, 1)
    res = _check_int("resolution", resolution, 1)
    points = sample_points(_check_int("grid", grid, 1))
    table = np.full((n, len(points)), -1, dtype=np.int32)
    for k, camera in enumerate(window_centre_cameras(n, dt_us, t0_us)):
        col, row = np.rint(project_points(points, camera, res)).astype(np.int64).T
        inside = (col >= 0) & (col < res) & (row >= 0) & (row < res)
        table[k, inside] = row[inside] * res + col[inside]
    return table


def lift_frames(frames: ArrayLike, table: np.ndarray,
                merge_frames: int = MERGE_FRAMES) -> np.ndarray:
    """Binary event frames ``(n, H, W)`` lifted into the grid: ``(2, g, g, g)`` float32.

    ``table``: :func:`lifting_table` for these frames' orbit, frame count and size. For
    each channel of :data:`LIFTED_CHANNELS` the frames become images (silhouette estimates,
    :func:`silhouettes_from_events`, then the raw event pixels), every voxel looks up its
    pixel in every image, and the channel is the share of the images with any set pixel
    that hold it. A voxel outside a frame counts as held (that frame cannot carve it), as
    in :func:`frames_ray_density`, whose result each channel equals.

    Examples
    --------
    >>> frames = np.zeros((2, 16, 16), bool)
    >>> frames[0, :, :8] = True  # events over the left half; frame 1 has none
    >>> lifted = lift_frames(frames, lifting_table(n_frames=2, resolution=16, grid=4))
    >>> lifted.shape, float(lifted[1, :2].min()), float(lifted[1, 2:].max())  # raw rays
    ((2, 4, 4, 4), 1.0, 0.0)
    """
    masks = _check_masks("frames", frames, None)
    n, height, width = masks.shape
    index = np.asarray(table)
    if index.ndim != 2 or index.shape[0] != n or round(index.shape[1] ** (1 / 3)) ** 3 != \
            index.shape[1] or height != width or index.max(initial=-1) >= height * width:
        raise ValueError(f"table {index.shape} does not fit {n} frames of {height} x {width} "
                         "px; make it with lifting_table(n_frames, dt_us, resolution)")
    grid = round(index.shape[1] ** (1 / 3))
    pixels = height * width + 1  # one extra pixel per frame, always set: outside the frame
    index = np.where(index < 0, pixels - 1, index)  # carves nothing
    index = index + pixels * np.arange(n)[:, None]  # into the frames laid end to end
    channels = []
    for images in (silhouettes_from_events(masks, merge_frames), masks):
        flat = images.reshape(n, -1)
        padded = np.concatenate([flat, np.ones((n, 1), dtype=bool)], axis=1)
        held = padded.ravel().take(index)  # (n, grid**3): the pixel of every voxel and frame
        used = flat.any(axis=1)  # frames without events say nothing
        channels.append(held[used].sum(axis=0) / max(int(used.sum()), 1))
    return np.stack(channels).reshape(2, grid, grid, grid).astype(np.float32)


def fill_solid(density: ArrayLike, threshold: float = EVENT_VOTE_THRESHOLD) -> np.ndarray:
    """Solid ``bool`` grid from occupancy evidence: ``density >= threshold``, holes filled.

    ``density``: a ``(R, R, R)`` grid (e.g. :func:`event_ray_density`). After thresholding,
    a closing with the 3 x 3 x 3 cube bridges one-voxel gaps in a shell (it never grows
    the outside of a convex part) and enclosed cavities are filled, since labels are solid.

    Examples
    --------
    >>> density = np.zeros((5, 5, 5))
    >>> density[1:4, 1:4, 1:4] = 1.0
    >>> density[2, 2, 2] = 0.0  # a hollow 3 x 3 x 3 shell
    >>> solid = fill_solid(density)
    >>> solid.dtype, int(solid.sum())  # its hole filled
    (dtype('bool'), 27)
    """
    d = np.asarray(density, dtype=np.float64)
    if d.ndim != 3 or len(set(d.shape)) != 1:
        raise ValueError(f"density must be a cubic (R, R, R) grid, got shape {d.shape}")
    if not np.all(np.isfinite(d)):
        raise ValueError("density holds NaN/inf")
    if not (isinstance(threshold, int | float | np.floating) and math.isfinite(threshold)):
        raise ValueError(f"threshold must be a finite number, got {threshold!r}")
    occupied = d >= threshold
    cube = np.ones((3, 3, 3), dtype=bool)
    closed = ndimage.binary_closing(np.pad(occupied, 1), structure=cube)[1:-1, 1:-1, 1:-1]
    return ndimage.binary_fill_holes(closed | occupied)


def score_occupancy(occupancy: ArrayLike, label: ArrayLike,
                    n_points: int = 8192) -> dict[str, float]:
    """Scores of one occupancy grid against its label, as the learned model is scored.

    ``occupancy``: ``(32, 32, 32)`` values in [0, 1] (a bool grid works too); ``label``:
    the 0/1 voxel label. Returns ``{"iou@0.2": ..., "iou@0.5": ..., "fscore@1%": ...,
    "fscore@20%": ...}``: :func:`e2vlib.metrics.score_predictions` of the one grid, with
    ``n_points`` surface samples.

    Examples
    --------
    >>> label = np.zeros((32, 32, 32))
    >>> label[8:24, 8:24, 8:24] = 1
    >>> scores = score_occupancy(label, label)  # a perfect reconstruction
    >>> list(scores), set(scores.values())
    (['iou@0.2', 'iou@0.3', 'iou@0.4', 'iou@0.5', 'fscore@1%', 'fscore@20%'], {1.0})
    """
    occ = np.asarray(occupancy, dtype=np.float64)[None]
    gt = np.asarray(label, dtype=np.float64)[None]
    return {key: float(values[0]) for key, values in
            score_predictions(occ, gt, fscore_points=n_points).items()}


__all__ = [
    "EVENT_VOTE_THRESHOLD", "LIFTED_CHANNELS", "MERGE_FRAMES", "SILHOUETTE_TOLERANCE",
    "event_ray_density", "fill_solid", "frames_ray_density", "lift_frames", "lifting_table",
    "orbit_camera_at", "sample_points", "score_occupancy", "silhouettes_from_events",
    "silhouettes_from_video", "visual_hull", "window_centre_cameras",
]
