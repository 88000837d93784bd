"""Compiled (numba) kernels behind :func:`e2vlib.frames.accumulate`'s default fast path.

The plain-numpy code in :mod:`e2vlib.frames` is the readable reference that the lessons
show; this module does the same work in one pass over the sorted events. Each event is
checked (pixel on the sensor, polarity -1/+1, time not before the previous event) and,
if it lies inside a window, counted into a one-frame scratch buffer that stays in the CPU
cache; the buffer is added into the frame stack when the window ends. The window (or
Eq. 5 group) index is carried from one event to the next and only recomputed when an
event leaves the current window, so there is no division and no index array per event.
Long streams (:data:`THREADED_MIN_EVENTS`) are cut at window or group starts into one
part per core, counted at the same time in threads into disjoint slices of the frames.

Importing this module imports numba; :mod:`e2vlib.frames` does so only on the first fast
call and falls back to numpy where numba is missing. Compiled code is cached on disk
(``cache=True``) where the package folder or numba's user cache folder is writable, so
only the first call on a machine pays the compile time (a few seconds).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from e2vlib.events import INT64_MAX

THREADED_MIN_EVENTS = 1_000_000
"""Streams at least this long are cut into one part per core (at most :data:`MAX_PARTS`),
each part a run of whole windows or groups, and the parts are counted at the same time in
threads (the loops release the GIL); shorter ones run in one loop."""

MAX_PARTS = 4


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
    parts = min(_cores(), MAX_PARTS, n) if len(t) >= THREADED_MIN_EVENTS else 1
    if parts < 2 or t0 + n * dt > INT64_MAX:  # window starts past int64: one loop
        return kernel(x, y, t, p, out, scratch, touched, width, height, t0, dt, n)
    return _fill_in_parts(kernel, parts, x, y, t, p, out, scratch, touched, width, height,
                          t0, dt, n, paper)


def _cores() -> int:
    """CPU cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _fill_in_parts(kernel, parts, x, y, t, p, out, scratch, touched, width, height, t0, dt,
                   n, paper) -> bool:
    """:func:`fill` with the frames cut into ``parts`` runs, counted in parallel threads.

    Part ``i`` takes frames ``[m_i, m_{i+1})`` and the events from the first one of frame
    ``m_i`` (found by bisection for fixed windows, by galloping through the groups for
    Eq. 5) to the first one of ``m_{i+1}``; it is :func:`fill` on those events with its own
    ``t0`` (the window's start, or the group's first time), its own scratch buffers and
    the slice of ``out`` that holds its frames, so parts never write to the same memory.
    For sorted events every event lands where the single loop puts it: the frames are
    identical. Unsorted events give arbitrary cuts, but each part checks its own order and
    the events on either side of each cut are compared, so they are still reported.
    """
    frames_at = np.array([i * n // parts for i in range(parts + 1)], dtype=np.int64)
    starts = _part_starts(t, t0, dt, frames_at[1:-1], paper)
    cuts = [0, *starts.tolist(), len(t)]
    frame_size = len(scratch)
    jobs = []
    for i in range(parts):
        lo, hi, m = cuts[i], cuts[i + 1], int(frames_at[i])
        if hi <= lo:  # no event starts this part's frames: they stay empty
            continue
        if i == 0:
            part_t0 = t0
        else:
            part_t0 = int(t[lo]) if paper else t0 + m * dt
        jobs.append((x[lo:hi], y[lo:hi], t[lo:hi], p[lo:hi],
                     out[m * frame_size:int(frames_at[i + 1]) * frame_size],
                     scratch if i == 0 else np.zeros_like(scratch),
                     touched if i == 0 else np.empty_like(touched),
                     width, height, part_t0, dt, int(frames_at[i + 1]) - m))
    with ThreadPoolExecutor(len(jobs)) as pool:
        results = list(pool.map(lambda job: kernel(*job), jobs))
    in_order = all(t[c - 1] <= t[c] for c in cuts[1:-1] if 0 < c < len(t))
    return all(results) and in_order


@_jit
def _part_starts(t, t0, dt, frames, paper):
    """Index of the first event of each frame in ``frames`` (ascending; ``t`` sorted).

    Fixed windows: the first event at or after ``t0 + m dt``. Eq. 5 groups: the first
    event of group ``m``, counting groups from the first event at or after ``t0`` (a frame
    past the last group gets ``len(t)``). Unsorted ``t`` gives indices that mean nothing,
    possibly not ascending; the parts' ranges still cover every event, so its checks run.
    """
    starts = np.empty(len(frames), dtype=np.int64)
    if not paper:
        for j in range(len(frames)):
            starts[j] = _first_at_or_after(t, t0 + frames[j] * dt)
        return starts
    dt_u = np.uint64(dt)
    i, group = _first_at_or_after(t, t0), 0
    for j in range(len(frames)):
        while group < frames[j] and i < len(t):
            i = _group_end(t, i, dt_u)
            group += 1
        starts[j] = i
    return starts


@_jit
def _first_at_or_after(t, value) -> int:
    """First index with ``t[index] >= value`` (bisection; ``len(t)`` if none)."""
    lo, hi = 0, len(t)
    while lo < hi:
        mid = (lo + hi) // 2
        if t[mid] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@_jit
def _group_end(t, i, dt_u) -> int:
    """First index ``j > i`` with ``t[j] - t[i] > dt`` (``len(t)`` if none).

    A galloping search (steps 1, 2, 4, ... then bisection), so only about log2(group size)
    times are read per group, not the whole group.
    """
    t_j = np.uint64(t[i])
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
    return lo


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

    Each group's end is found by a galloping search (:func:`_group_end`), so only about
    log2(group size) times are read per group, not the whole stream.
    """
    dt_u = np.uint64(dt)
    i, groups = _first_at_or_after(t, t0), 0
    while i < len(t):
        i = _group_end(t, i, dt_u)
        groups += 1
    return groups
