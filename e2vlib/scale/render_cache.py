"""Off-screen plotters kept for reuse between :func:`e2vlib.render.render_orbit` calls.

Opt-in speed for builds that render many objects in one process: making a plotter costs
about 0.05 s (the first one in a process, OpenGL and shader set-up, several tenths), a few
per cent of a 128 px orbit. :func:`render_orbit_cached` takes :func:`render_orbit`'s
arguments and gives the same video, rendered with a plotter kept per resolution and
anti-aliasing setting (at most :data:`MAX_CACHED_PLOTTERS`, the least recently used closed
first). The mesh is removed after each call; background and lights stay. A thread that
finds the kept plotters busy (another thread is rendering) renders with a plotter of its
own; a plotter made by another process (a forked parent's) is never touched; a plotter
whose render failed is closed, not reused. :func:`release_plotters` closes them all (it
also runs at exit).
"""

from __future__ import annotations

import atexit
import collections
import os
import threading

import numpy as np

from e2vlib import paper
from e2vlib.orbit import check_count
from e2vlib.render import anti_aliasing_mode, make_plotter, render_orbit

MAX_CACHED_PLOTTERS = 4
"""Off-screen plotters :func:`render_orbit_cached` keeps (one per resolution and
anti-aliasing setting, least recently used closed first)."""

_PLOTTERS: collections.OrderedDict[tuple, tuple[int, object]] = collections.OrderedDict()
"""(plotter class, resolution, anti-aliasing) -> (pid of the process that made it, plotter),
most recently used last."""
_LOCK = threading.Lock()


def _usable(pid: int, plotter) -> bool:
    """Open, and made by this process (a forked child never touches its parent's GL)."""
    return pid == os.getpid() and plotter.render_window is not None


def release_plotters() -> int:
    """Close the plotters :func:`render_orbit_cached` keeps; return how many there were.

    They are made again on demand; call this to free their OpenGL memory. Runs at exit.

    Examples
    --------
    >>> _ = release_plotters()
    >>> release_plotters()  # none left to close
    0
    """
    with _LOCK:
        entries = list(_PLOTTERS.values())
        _PLOTTERS.clear()
    for pid, plotter in entries:
        if _usable(pid, plotter):
            plotter.close()
    return len(entries)


atexit.register(release_plotters)


def _kept_plotter(resolution: int, anti_aliasing: str):
    """The kept plotter for these settings, made if needed (call with ``_LOCK`` held)."""
    import pyvista as pv

    # pv.Plotter is in the key so that a replaced (e.g. test-patched) class is honoured
    key = (pv.Plotter, resolution, anti_aliasing)
    entry = _PLOTTERS.pop(key, None)
    if entry is not None and not _usable(*entry):
        if entry[0] == os.getpid():
            entry[1].close()
        entry = None
    if entry is None:
        entry = (os.getpid(), make_plotter(resolution, anti_aliasing))
    _PLOTTERS[key] = entry
    while len(_PLOTTERS) > MAX_CACHED_PLOTTERS:
        _, (pid, old) = _PLOTTERS.popitem(last=False)
        if _usable(pid, old):
            old.close()
    return entry[1]


def render_orbit_cached(
    mesh,
    n_video_frames: int = paper.N_VIDEO_FRAMES,
    fps: float = paper.VIDEO_FPS,
    resolution: int = 256,
    oversample: int = 1,
    anti_aliasing: bool | str = True,
    *,
    n_frames: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`e2vlib.render.render_orbit` with a kept plotter: the same arguments, the same
    ``(video, t_us)``.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((0.5, 0.5, 0.5))
    >>> video, _ = render_orbit_cached(box, n_video_frames=2, resolution=16)
    >>> bool((video == render_orbit(box, n_video_frames=2, resolution=16)[0]).all())
    True
    """
    args = (mesh, n_video_frames, fps, resolution, oversample, anti_aliasing)
    res = check_count("resolution", resolution, 1)
    aa = anti_aliasing_mode(anti_aliasing)
    if not _LOCK.acquire(blocking=False):  # another thread renders with the kept plotters
        return render_orbit(*args, n_frames=n_frames)
    try:
        plotter = _kept_plotter(res, aa)
        try:
            return render_orbit(*args, n_frames=n_frames, plotter=plotter)
        except BaseException:  # never reuse a plotter that failed half-way
            for key, (_, kept) in list(_PLOTTERS.items()):
                if kept is plotter:
                    del _PLOTTERS[key]
            plotter.close()
            raise
    finally:
        _LOCK.release()
