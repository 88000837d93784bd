"""Compiled (numba) kernels behind :func:`e2vlib.frames.accumulate`'s default fast path.

The plain-numpy code in :mod:`e2vlib.frames` is the readable reference that the lessons
show; this module does the same work in one pass over the sorted events. Each event is
checked (pixel on the sensor, polarity -1/+1, time not before the previous event) and,
if it lies inside a window, counted into a one-frame scratch buffer that stays in the CPU
cache; the buffer is added into the frame stack when the window ends. The window (or
Eq. 5 group) index is carried from one event to the next and only recomputed when an
event leaves the current window, so there is no division and no index array per event.

Importing this module imports numba; :mod:`e2vlib.frames` does so only on the first fast
call and falls back to numpy where numba is missing. Compiled code is cached on disk
(``cache=True``) where the package folder or numba's user cache folder is writable, so
only the first call on a machine pays the compile time (a few seconds).
"""

from __future__ import annotations

import numba
import numpy as np


def _jit(function):
    """``numba.njit`` with an on-disk cache, or without one where no folder is writable."""
    try:
        return numba.njit(cache=True, nogil=True)(function)
    except RuntimeError:  # numba found no writable cache folder
        return numba.njit(nogil=True)(function)


def fill(x, y, t, p, out, scratch, touched, width, height, t0, dt, n, paper, binary, split):
    """Count events into ``n`` frames: fixed windows of ``dt`` from ``t0``, or Eq. 5 groups.

    ``x, y, t, p``: the event fields, ``(N,)`` with any strides, ``N >= 1``. ``out``: the
    zeroed flat frame stack ``(n * C * H * W,)`` with ``C = 2 if split else 1``, uint8 (set
    to 1) when ``binary``, else int32 (counts). ``scratch``: a zeroed buffer for one frame,
    ``(C * H * W,)``, uint8 when binary, else uint16. ``touched``: int64 room for the
    scratch positions of up to ``len(touched)`` events. ``t0``, ``dt`` (> 0): int64
    microseconds. ``paper``: Eq. 5 groups (a group starts at its first event ``t_j`` and
    takes events while ``t - t_j <= dt``) instead of the fixed windows
    ``[t0 + k dt, t0 + (k + 1) dt)``; both start at ``t0``.

    The current frame is counted in ``scratch``, small enough to stay in the CPU cache,
    and added into ``out`` when its window ends (or after 65,535 events, so uint16 cannot
    overflow). Every event is checked as :func:`e2vlib.events.validate` does, without a
    branch per check; the result is True only if all pass (otherwise ``out`` means
    nothing: a broken event's position is only clamped into ``scratch``, to keep memory
    safe). ``paper``, ``binary`` and ``split`` pick one of six compiled loops
    (:func:`_make_fill`), each with its choices fixed at compile time.
    """
    key = (bool(paper), bool(binary), bool(split))
    kernel = _FILLS.get(key)
    if kernel is None:
        kernel = _FILLS[key] = _make_fill(*key)
    return kernel(x, y, t, p, out, scratch, touched, width, height, t0, dt, n)


_FILLS: dict = {}


def _make_fill(paper: bool, binary: bool, split: bool):
    """The loop of :func:`fill` for one choice of grouping and mode, compiled on first use.

    The three choices are constants of the closure, so numba drops the branches that do not
    apply (about 15 % faster than one loop that tests them per event); the on-disk cache
    keeps one compiled loop per choice.
    """

    @_jit
    def fill_events(x, y, t, p, out, scratch, touched, width, height, t0, dt, n):
        plane = height * width
        limit = len(t) if binary else 65_535  # events per flush: no scratch value overflows
        dt_u = np.uint64(dt)
        k = -1  # frame held in scratch (-1: none yet, n: past the last one)
        window_start = np.uint64(0)  # fixed windows: k * dt, relative to t0
        t_j = np.int64(0)  # Eq. 5 groups: the current group's first time
        held = 0  # events counted in scratch since it was last flushed
        last = len(scratch) - 1
        broken = False
        previous = t[0]
        for i in range(len(t)):
            ti, xi, yi, pi = t[i], x[i], y[i], p[i]
            broken |= (xi >= width) | (yi >= height) | (pi * pi != 1) | (ti < previous)
            previous = ti
            if ti < t0 or k >= n:  # before the first window or after the last: only checked
                continue
            if paper:
                new_frame = k < 0 or np.uint64(ti) - np.uint64(t_j) > dt_u
            else:
                # exact even past int64: t >= t0, so the difference fits uint64
                since_t0 = np.uint64(ti) - np.uint64(t0)
                new_frame = k < 0 or since_t0 - window_start >= dt_u
            if new_frame:
                if held:
                    _flush(out, scratch, touched, held, k)
                    held = 0
                if paper:
                    k += 1
                    t_j = ti
                else:
                    window = since_t0 // dt_u
                    window_start = window * dt_u
                    k = n if window >= np.uint64(n) else np.int64(window)
                if k >= n:
                    continue
            elif held == limit:
                _flush(out, scratch, touched, held, k)
                held = 0
            index = np.int64(yi) * width + np.int64(xi)
            if split:  # channel 1 for ON events (arithmetic, not a branch: polarity is random)
                index += plane * (pi > 0)
            index = min(index, last)  # only a broken event (x >= width or y >= height) moves
            if held < len(touched):
                touched[held] = index
            held += 1
            if binary:
                scratch[index] = 1
            else:
                scratch[index] += 1
        if held:
            _flush(out, scratch, touched, held, k)
        return not broken

    return fill_events


@_jit
def _flush(out, scratch, touched, held, k):
    """Add ``scratch`` (one frame, flat) into frame ``k`` of the flat ``out``; zero it.

    A frame that got few events (all listed in ``touched``) is flushed event by event,
    so sparse streams never sweep whole frames; a busy one, value by value.
    """
    size = len(scratch)
    base = k * size
    if held <= len(touched):
        for m in range(held):
            index = touched[m]
            out[base + index] += scratch[index]  # a position hit twice adds 0 the second time
            scratch[index] = 0
        return
    for index in range(size):
        out[base + index] += scratch[index]
    scratch[:] = 0


@_jit
def count_groups(t, t0, dt) -> int:
    """Number of Eq. 5 groups from the first event at or after ``t0`` (``t`` sorted).

    Each group's end is found by a galloping search (steps 1, 2, 4, ... then bisection),
    so only about log2(group size) times are read per group, not the whole stream.
    """
    lo, hi = 0, len(t)
    while lo < hi:  # first index with t >= t0
        mid = (lo + hi) // 2
        if t[mid] < t0:
            lo = mid + 1
        else:
            hi = mid
    dt_u = np.uint64(dt)
    i, groups = lo, 0
    while i < len(t):
        t_j = np.uint64(t[i])
        # find the first j > i with t[j] - t_j > dt: gallop, then bisect in (i + step/2, j]
        step = 1
        while i + step < len(t) and np.uint64(t[i + step]) - t_j <= dt_u:
            step *= 2
        lo, hi = i + step // 2 + 1, min(i + step, len(t))
        while lo < hi:
            mid = (lo + hi) // 2
            if np.uint64(t[mid]) - t_j <= dt_u:
                lo = mid + 1
            else:
                hi = mid
        groups += 1
        i = lo
    return groups
