"""Frames from events with compiled (numba) kernels: :func:`accumulate_fast`, opt-in.

:func:`e2vlib.frames.accumulate` is the plain-numpy version that the lessons read;
:func:`accumulate_fast` takes the same arguments and gives the same frames (and the same
errors) in one pass over the sorted events. Each event is checked (pixel on the sensor,
polarity -1/+1, time not before the previous event) and, if it lies inside a window,
counted into a one-frame scratch buffer that stays in the CPU cache; the buffer is added
into the frame stack when the window ends. The window (or Eq. 5 group) index is carried
from one event to the next and only recomputed when an event leaves the current window, so
there is no division and no index array per event. Long streams
(:data:`THREADED_MIN_EVENTS`) are cut at window or group starts into one part per core,
counted at the same time in threads into disjoint slices of the frames. It also keeps each
stack within half the memory available now (:func:`frames_memory_limit`).

Importing this module imports numba (a second or so); only callers that ask for speed do.
Compiled code is cached on disk (``cache=True``) where the package folder or numba's user
cache folder is writable, so only the first call on a machine pays the compile time (a
few seconds).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np
import psutil

from e2vlib import frames, paper
from e2vlib.events import INT64_MAX, check_sensor_size, validate

THREADED_MIN_EVENTS = 1_000_000
"""Streams at least this long are cut into one part per core (at most :data:`MAX_PARTS`),
each part a run of whole windows or groups, and the parts are counted at the same time in
threads (the loops release the GIL); shorter ones run in one loop."""

MAX_PARTS = 4

ASK_MEMORY_BYTES = 2**28
"""Stacks up to this size (256 MiB) are made without asking how much memory is free."""


def available_memory() -> int:
    """Bytes of memory available to new allocations now (``psutil``)."""
    return int(psutil.virtual_memory().available)


def frames_memory_limit() -> tuple[int, str]:
    """``(bytes, why)``: the largest frame stack :func:`accumulate_fast` makes here, the
    smaller of :data:`e2vlib.frames.MAX_FRAMES_BYTES` and half the memory available now."""
    available = available_memory()
    if available // 2 < frames.MAX_FRAMES_BYTES:
        return available // 2, f"half the {available / 2**30:.1f} GiB of memory available now"
    return frames.MAX_FRAMES_BYTES, "frames.MAX_FRAMES_BYTES"


def accumulate_fast(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    dt_us: int = paper.DT_US,
    t0_us: int | None = None,
    n_frames: int | None = None,
    mode: str = "binary",
    windows: str = paper.FRAME_WINDOWS,
) -> np.ndarray:
    """:func:`e2vlib.frames.accumulate` by the compiled kernels: the same arguments, the
    same frames, the same errors, and a stack at most half the memory available now.

    About 3 to 30 times faster than the numpy version on long streams (bench/RESULTS.md,
    "Frame accumulation"); the first call on a machine compiles the kernels (a few
    seconds, then cached on disk). Windows longer than 2^63 us take the numpy version.

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> ev = make_events(x=[0, 1, 1, 0], y=[0, 0, 0, 0], t=[0, 4, 6, 11], p=[1, -1, 1, 1])
    >>> accumulate_fast(ev, (2, 1), dt_us=5, mode="count")[:, 0].tolist()
    [[1, 1], [0, 1], [1, 0]]
    """
    width, height = check_sensor_size(sensor_size)
    try:  # the settings, as accumulate checks them; the events are checked by the kernel
        validate(events[:0] if isinstance(events, np.ndarray) and events.ndim == 1 else events,
                 (width, height))  # the dtype, before any field is read
        dt, t0, n = frames.check_frame_arguments(events, dt_us, t0_us, n_frames, mode, windows)
        if dt > INT64_MAX:  # the kernels count in int64
            return frames.accumulate(events, sensor_size, dt_us, t0_us, n_frames, mode, windows)
        t = events["t"]
        if n is None and windows == "paper":
            n = count_groups(t, t0, dt) if len(t) else 0
        elif n is None:
            n = frames.window_count(int(t[0]), int(t[-1]), dt, t0) if len(t) else 0
        frame_values = (2 if mode == "polarity" else 1) * height * width
        wanted = n * frame_values * (1 if mode == "binary" else 4)
        limit, why = (frames_memory_limit() if wanted > ASK_MEMORY_BYTES
                      else (None, "frames.MAX_FRAMES_BYTES"))
        frames.check_stack_size(n, frame_values, mode, t, limit, why)
    except ValueError:  # accumulate reports broken events first: so does this
        validate(events, (width, height))
        raise
    shape = (n, 2, height, width) if mode == "polarity" else (n, height, width)
    binary = mode == "binary"
    out = np.zeros(n * frame_values, dtype=np.uint8 if binary else np.int32)
    if len(t) == 0:
        return out.reshape(shape)
    scratch = np.zeros(frame_values, dtype=np.uint8 if binary else np.uint16)
    touched = np.empty(max(height * width // 16, 1), dtype=np.int64)
    if not fill(events["x"], events["y"], t, events["p"], out, scratch, touched, width, height,
                t0, dt, n, windows == "paper", binary, mode == "polarity"):
        validate(events, (width, height))  # raises the detailed EventError
        raise AssertionError("the numba kernel rejected events that validate() accepts")
    return out.reshape(shape)


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
