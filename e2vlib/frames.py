"""Event representations: binary/count/polarity frames, time surfaces, voxel grids.

All functions take an event array of :data:`e2vlib.events.EVENT_DTYPE` (sorted by ``t``,
microseconds) and ``sensor_size = (width, height)``, validate them, and never modify the
caller's array. Frames are indexed ``[k, y, x]``; with fixed windows (the default) frame
``k`` covers the half-open window ``[t0 + k*dt, t0 + (k+1)*dt)``; ``windows="paper"``
groups events as the paper's Eq. 5 does (see :func:`accumulate`). :func:`accumulate` runs
a compiled kernel (:mod:`e2vlib.scale.frames_numba`, numba) where numba is installed; its numpy
reference, here, gives the same frames (``backend="numpy"``).

Introduced in notebooks/02_event_frames.ipynb.
"""

from __future__ import annotations

import functools
import os

import numpy as np

from e2vlib import paper
from e2vlib.events import (
    INT64_MAX,
    INT64_MIN,
    EventError,
    check_sensor_size,
    iter_checked_chunks,
    validate,
)

MODES = ("binary", "count", "polarity")


def window_count(t_first_us: int, t_last_us: int, dt_us: int, t0_us: int) -> int:
    """Number of windows of ``dt_us`` starting at ``t0_us`` needed to cover ``t_last_us``.

    The window holding the last event is included, so no event at the end is lost:
    ``floor((t_last - t0) / dt) + 1`` (0 if every event is before ``t0``).
    """
    if t_last_us < t0_us:
        return 0
    return int((t_last_us - t0_us) // dt_us) + 1


def searchsorted_left(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``np.searchsorted(t, values, side="left")`` without copying a strided ``t``.

    ``events["t"]`` is a strided view into the structured array; ``np.searchsorted`` would
    first copy all of it. A vectorized bisection touches only ~log2(N) entries per value.
    """
    values = np.asarray(values, dtype=np.int64)
    lo = np.zeros(values.shape, dtype=np.intp)
    hi = np.full(values.shape, len(t), dtype=np.intp)
    while np.any(lo < hi):
        mid = (lo + hi) // 2
        active = lo < hi
        below = np.zeros(values.shape, dtype=bool)
        below[active] = t[mid[active]] < values[active]
        lo = np.where(active & below, mid + 1, lo)
        hi = np.where(active & ~below, mid, hi)
    return lo


def _check_dt(dt_us) -> int:
    """``dt_us`` as a positive whole number of microseconds, or a clear EventError."""
    try:
        ok = bool(np.isfinite(dt_us)) and int(dt_us) == dt_us and dt_us > 0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise EventError(
            f"dt_us must be a positive whole number of microseconds, got {dt_us!r} "
            f"(the paper's 5 ms is dt_us={paper.DT_US})")
    return int(dt_us)


def _check_n_frames(n_frames) -> int:
    try:
        ok = bool(np.isfinite(n_frames)) and int(n_frames) == n_frames and n_frames >= 0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise EventError(f"n_frames must be a non-negative integer, got {n_frames!r}")
    return int(n_frames)


def _resolve_windows(
    events: np.ndarray, dt_us: int, t0_us: int | None, n_frames: int | None
) -> tuple[int, int, int]:
    """Return ``(dt, t0, n)`` of fixed windows: defaults filled in, types and ranges checked."""
    dt_us = _check_dt(dt_us)
    t = events["t"]
    if t0_us is None:
        t0_us = int(t[0]) if len(t) else 0
    if n_frames is None:
        n_frames = window_count(int(t[0]), int(t[-1]), dt_us, int(t0_us)) if len(t) else 0
    return dt_us, int(t0_us), _check_n_frames(n_frames)


def paper_group_bounds(t: np.ndarray, dt_us: int, start: int = 0,
                       n_groups: int | None = None) -> np.ndarray:
    """Event-index bounds of the paper's Eq. 5 groups, ``(G + 1,)`` int64.

    Group ``g`` holds events ``bounds[g]:bounds[g + 1]``. A group starts at its first event
    ``t_j`` and takes every following event with ``t_i - t_j <= dt_us`` (inclusive); the
    first event beyond that starts the next group. Grouping starts at index ``start`` and
    stops after ``n_groups`` groups (default: when the events run out), so no group is
    empty. ``t`` must be sorted (microseconds).

    Examples
    --------
    >>> t = np.array([0, 3, 5, 6, 20, 21])
    >>> paper_group_bounds(t, dt_us=5).tolist()   # {0, 3, 5} {6} {20, 21}
    [0, 3, 4, 6]
    >>> paper_group_bounds(t, dt_us=5, n_groups=2).tolist()
    [0, 3, 4]
    """
    bounds = [int(start)]
    limit = np.inf if n_groups is None else int(n_groups)
    while bounds[-1] < len(t) and len(bounds) - 1 < limit:
        group_start = int(t[bounds[-1]])
        # first event with t > t_j + dt, i.e. t >= t_j + dt + 1 (integer microseconds)
        bounds.append(_first_at_least(t, bounds[-1], group_start + dt_us + 1))
    return np.asarray(bounds, dtype=np.int64)


def _first_at_least(t: np.ndarray, start: int, value: int) -> int:
    """First index ``>= start`` with ``t[index] >= value`` (``t`` sorted).

    Searches blocks growing from ``start`` (a group rarely spans many events), so each call
    copies only about as many times as the group holds, not the whole strided column.
    """
    size = 1024
    while start < len(t):
        block = np.asarray(t[start:start + size])
        if block[-1] >= value:
            return start + int(np.searchsorted(block, value, side="left"))
        start += len(block)
        size *= 4
    return len(t)


def _window_offsets(t: np.ndarray, t0: int, dt: int, frame_elements: int) -> np.ndarray | int:
    """``((t - t0) // dt) * frame_elements`` for sorted ``t``, without a division per event.

    A block of sorted events spans few windows (usually one), so the window index is a
    constant, or a few runs of constants found by binary search on the window edges.
    """
    k_first, k_last = (int(t[0]) - t0) // dt, (int(t[-1]) - t0) // dt
    if k_first == k_last:
        return k_first * frame_elements
    cuts = np.searchsorted(t, t0 + dt * np.arange(k_first + 1, k_last + 1, dtype=np.int64))
    run_lengths = np.diff(cuts, prepend=0, append=len(t))
    return np.repeat(np.arange(k_first, k_last + 1) * frame_elements, run_lengths)


def _group_offsets(bounds: np.ndarray, lo: int, hi: int, frame_elements: int) -> np.ndarray | int:
    """``group(i) * frame_elements`` for event indices ``lo <= i < hi`` given group ``bounds``."""
    g_first = int(np.searchsorted(bounds, lo, side="right")) - 1
    g_last = int(np.searchsorted(bounds, hi - 1, side="right")) - 1
    if g_first == g_last:
        return g_first * frame_elements
    edges = np.clip(bounds[g_first:g_last + 2], lo, hi)
    return np.repeat(np.arange(g_first, g_last + 1) * frame_elements, np.diff(edges))


MAX_FRAMES_BYTES: int = 8 * 2**30
"""Largest frame stack :func:`accumulate` allocates (8 GiB, and at most half the memory
available, :func:`frames_memory_limit`); larger requests raise EventError."""


BINCOUNT_MAX_VALUES: int = 2**25
"""Largest count stack (values) the numpy path of :func:`accumulate` counts with
``np.bincount``, whose int64 result takes twice the int32 stack (256 MiB here); larger
stacks count each touched value once, so the path holds no more than the stack the memory
limit allowed plus memory per event."""


def available_memory() -> int | None:
    """Bytes of memory available to new allocations now (Linux ``MemAvailable``, else the
    free physical pages), or None where neither can be read."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return None


def frames_memory_limit() -> tuple[int, str]:
    """``(bytes, why)``: the largest frame stack :func:`accumulate` makes here, the smaller
    of :data:`MAX_FRAMES_BYTES` and half the memory available now. :func:`accumulate`
    asks only for stacks over 256 MiB; smaller ones are always made."""
    available = available_memory()
    if available is not None and available // 2 < MAX_FRAMES_BYTES:
        return available // 2, (f"half the {available / 2**30:.1f} GiB of memory available "
                                "now")
    return MAX_FRAMES_BYTES, "frames.MAX_FRAMES_BYTES"

WINDOWS = ("fixed", "paper")
BACKENDS = ("auto", "numba", "numpy")


@functools.cache
def _fast_kernels():
    """The compiled kernels (:mod:`e2vlib.scale.frames_numba`), or None where numba is missing.

    Imported on the first fast call, not with this module: importing numba takes a while.
    """
    try:
        from e2vlib.scale import frames_numba as frames_fast
    except ImportError:
        return None
    return frames_fast


def accumulate(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    dt_us: int = paper.DT_US,
    t0_us: int | None = None,
    n_frames: int | None = None,
    mode: str = "binary",
    windows: str = paper.FRAME_WINDOWS,
    backend: str = "auto",
) -> np.ndarray:
    """Accumulate events into a stack of frames, one per time window of ``dt_us``.

    Modes:
      * ``"binary"`` -- ``(n, H, W)`` uint8, 1 where a pixel fired at least once in the
        window, whatever the polarity (the paper's Eq. 4, E2V's input);
      * ``"count"`` -- ``(n, H, W)`` int32, number of events per pixel and window;
      * ``"polarity"`` -- ``(n, 2, H, W)`` int32 counts, channel 0 = OFF (-1), 1 = ON (+1).

    Windows:
      * ``"fixed"`` (default, our choice) -- frame ``k`` covers the clock window
        ``[t0 + k*dt, t0 + (k+1)*dt)``; a window without events gives an empty frame;
      * ``"paper"`` -- the paper's Eq. 5: a group starts at its first event ``t_j`` and
        takes events while ``t_i - t_j <= dt`` (inclusive), so groups start at events and
        none is empty (see :func:`paper_group_bounds`). With ``n_frames``, later groups are
        dropped and missing ones are empty frames at the end.

    ``t0_us`` defaults to the first event's time (events before it are left out);
    ``n_frames`` to as many windows or groups as cover the last event. Events outside the
    windows are left out. The frame stack may not exceed :func:`frames_memory_limit`.

    Backends give identical frames: ``"numpy"`` is the plain reference written out below
    (vectorized blocks and one ``np.bincount``; read it to see how frames are made);
    ``"numba"`` runs the compiled single pass of :mod:`e2vlib.scale.frames_numba`, about twice as
    fast for counts (bench/RESULTS.md; the first call on a machine compiles it, a few
    seconds, then it is cached on disk), and counts streams of a million events or more
    in one part per core, at the same time;
    ``"auto"`` (default) is numba where it is installed, numpy otherwise.
    Introduced in notebooks/02_event_frames.ipynb.

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> ev = make_events(x=[0, 1, 1, 0], y=[0, 0, 0, 0], t=[0, 4, 6, 11], p=[1, -1, 1, 1])
    >>> accumulate(ev, (2, 1), dt_us=5, mode="count")[:, 0].tolist()   # [0,5) [5,10) [10,15)
    [[1, 1], [0, 1], [1, 0]]
    >>> accumulate(ev, (2, 1), dt_us=5, mode="count", windows="paper")[:, 0].tolist()
    [[1, 1], [1, 1]]
    >>> accumulate(ev, (2, 1), dt_us=5, mode="count", backend="numpy")[:, 0].tolist()
    [[1, 1], [0, 1], [1, 0]]
    """
    width, height = check_sensor_size(sensor_size)
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if windows not in WINDOWS:
        raise ValueError(f"windows must be one of {WINDOWS}, got {windows!r}")
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if not isinstance(events, np.ndarray) or events.ndim != 1:
        validate(events, (width, height))  # raises a named EventError for wrong shapes/dtypes
    validate(events[:0], (width, height))  # the dtype, before reading any field
    kernels = None if backend == "numpy" else _fast_kernels()
    if backend == "numba" and kernels is None:
        raise ModuleNotFoundError(
            "accumulate(backend='numba') needs numba: pip install -r "
            "environment/requirements.txt, or pass backend='numpy'")
    channels = 2 if mode == "polarity" else 1
    if len(events) == 0:  # nothing to read; still check dtype and arguments
        validate(events, (width, height))
    t = events["t"]
    bounds = None
    if windows == "fixed":
        dt, t0, n = _resolve_windows(events, dt_us, t0_us, n_frames)
    else:
        dt = _check_dt(dt_us)
        t0 = int(t[0]) if t0_us is None and len(t) else int(t0_us or 0)
        n_wanted = None if n_frames is None else _check_n_frames(n_frames)
    # the kernels do int64 arithmetic: times past that range (never met in practice) take
    # the reference path, which works with Python integers
    if kernels is not None and not (INT64_MIN <= t0 <= INT64_MAX and dt <= INT64_MAX):
        kernels = None
    if windows == "paper":
        if kernels is not None:
            counted = kernels.count_groups(t, t0, dt) if len(t) else 0
            n = counted if n_wanted is None else n_wanted
        else:
            first = int(searchsorted_left(t, [t0])[0])
            bounds = paper_group_bounds(t, dt, start=first, n_groups=n_wanted)
            n = len(bounds) - 1 if n_wanted is None else n_wanted
    frame_elements = channels * height * width
    itemsize = 1 if mode == "binary" else 4
    wanted = n * frame_elements * itemsize
    limit, why = frames_memory_limit() if wanted > 2**28 else (wanted, "")  # 256 MiB: fine
    if wanted > limit:
        raise EventError(
            f"{n} frames of {frame_elements} values would take "
            f"{wanted / 2**30:.2f} GiB (limit "
            f"{limit / 2**30:.2f} GiB: {why}); check sensor_size, dt_us and "
            f"t0_us against the event times ({int(t[0]) if len(t) else 0}.."
            f"{int(t[-1]) if len(t) else 0} us) or pass n_frames")
    shape = (n, 2, height, width) if mode == "polarity" else (n, height, width)
    if kernels is not None and len(events) == 0:  # checked above; no kernel for no events
        return np.zeros(shape, dtype=np.uint8 if mode == "binary" else np.int32)
    if kernels is not None:
        binary = mode == "binary"
        out = np.zeros(n * frame_elements, dtype=np.uint8 if binary else np.int32)
        scratch = np.zeros(frame_elements, dtype=np.uint8 if binary else np.uint16)
        touched = np.empty(max(height * width // 16, 1), dtype=np.int64)
        if not kernels.fill(events["x"], events["y"], t, events["p"], out, scratch, touched,
                            width, height, t0, dt, n, windows == "paper", binary,
                            mode == "polarity"):
            validate(events, (width, height))  # raises the detailed EventError
            raise AssertionError("the numba kernel rejected events that validate() accepts")
        return out.reshape(shape)
    return _accumulate_numpy(events, (width, height), t0, dt, n, mode, bounds).reshape(shape)


def _accumulate_numpy(events: np.ndarray, sensor_size: tuple[int, int], t0: int, dt: int,
                      n: int, mode: str, bounds: np.ndarray | None) -> np.ndarray:
    """The numpy reference of :func:`accumulate`: flat frames ``(n * C * H * W,)``.

    Fixed windows of ``dt`` us from ``t0`` when ``bounds`` is None, else the Eq. 5 groups
    given by their event-index ``bounds`` (from :func:`paper_group_bounds`).
    """
    width, height = sensor_size
    plane = height * width
    frame_elements = (2 if mode == "polarity" else 1) * plane
    t = events["t"]
    # Sorted times: the events inside the windows are one contiguous slice [lo, hi).
    if bounds is None:
        end = t0 + n * dt  # may pass the int64 range: then every event is before it
        lo, hi = searchsorted_left(t, [t0, min(end, INT64_MAX)])
        hi = len(t) if end > INT64_MAX else hi
    else:
        lo, hi = int(bounds[0]), int(bounds[-1])

    # One pass over the events, block by block (see e2vlib.events.iter_checked_chunks):
    # each block is checked, then turned into flat indices k*C*H*W + c*H*W + y*W + x
    # while it is still in the CPU cache. Binary frames are set directly; counts collect
    # the indices for a single np.bincount at the end (np.add.at would be ~20x slower).
    binary = np.zeros(n * frame_elements, dtype=np.uint8) if mode == "binary" else None
    indices = None if mode == "binary" else np.empty(hi - lo, dtype=np.intp)
    for start, block in iter_checked_chunks(events, (width, height)):
        a, b = max(lo - start, 0), min(hi - start, len(block))
        if a >= b:
            continue
        block = block[a:b]
        flat = block["y"].astype(np.intp)
        flat *= width
        if bounds is None:
            flat += _window_offsets(block["t"], t0, dt, frame_elements)
        else:
            flat += _group_offsets(bounds, start + a, start + b, frame_elements)
        flat += block["x"]
        if mode == "polarity":
            flat += (block["p"] > 0) * plane
        if binary is not None:
            binary[flat] = 1
        else:
            indices[start + a - lo:start + b - lo] = flat
    if binary is not None:
        return binary
    if n * frame_elements <= BINCOUNT_MAX_VALUES:
        return np.bincount(indices, minlength=n * frame_elements).astype(np.int32)
    counts = np.zeros(n * frame_elements, dtype=np.int32)  # the stack the limit allowed
    touched, times = np.unique(indices, return_counts=True)
    counts[touched] = times
    return counts


def time_surface(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    t_us: int,
    tau_us: float,
    split_polarity: bool = True,
) -> np.ndarray:
    """Exponentially decaying time surface at time ``t_us`` (Lagorce et al., HOTS, 2017).

    Each pixel holds ``exp(-(t_us - t_last) / tau_us)``, where ``t_last`` is the time of
    its most recent event at or before ``t_us``; pixels without such an event hold 0.
    Returns float32 ``(2, H, W)`` (channel 0 = OFF, 1 = ON) or ``(H, W)`` when
    ``split_polarity`` is False. Introduced in notebooks/02_event_frames.ipynb.
    """
    width, height = check_sensor_size(sensor_size)
    validate(events, (width, height))
    if not (np.isfinite(tau_us) and tau_us > 0):
        raise ValueError(f"tau_us must be a positive number of microseconds, got {tau_us}")
    end = int(np.searchsorted(events["t"], t_us, side="right"))
    past = events[:end]
    plane = height * width
    flat = past["y"].astype(np.intp) * width + past["x"]
    n_channels = 2 if split_polarity else 1
    if split_polarity:
        flat += (past["p"] > 0).astype(np.intp) * plane
    # Events are sorted, so the last occurrence of each pixel is its most recent event.
    uniq, first_in_reversed = np.unique(flat[::-1], return_index=True)
    t_last = past["t"][::-1][first_in_reversed]
    surface = np.zeros(n_channels * plane, dtype=np.float32)
    surface[uniq] = np.exp(-(t_us - t_last) / float(tau_us))
    shape = (2, height, width) if split_polarity else (height, width)
    return surface.reshape(shape)


def time_surface_stack(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    dt_us: int = paper.DT_US,
    n_frames: int = paper.N_EVENT_FRAMES,
    t0_us: int = 0,
    tau_us: float | None = None,
) -> np.ndarray:
    """One time surface per fixed window, taken at the window's last microsecond.

    Surface ``k`` is :func:`time_surface` (both polarities together) at
    ``t = t0 + (k + 1) dt - 1``: every pixel holds ``exp(-(t - t_last) / tau)`` of its most
    recent event so far, or 0. ``tau_us`` defaults to ``dt_us``. Returns float32
    ``(n_frames, H, W)``. Introduced in notebooks/09_event_representations_and_time.ipynb.

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> ev = make_events(x=[0, 1], y=[0, 0], t=[0, 7], p=[1, -1])
    >>> s = time_surface_stack(ev, (2, 1), dt_us=5, n_frames=2, tau_us=5)
    >>> np.round(s[:, 0].astype(float), 3).tolist()  # t = 4: e^(-4/5); t = 9: e^(-9/5), e^(-2/5)
    [[0.449, 0.0], [0.165, 0.67]]
    """
    width, height = check_sensor_size(sensor_size)
    validate(events, (width, height))
    dt = _check_dt(dt_us)
    n = _check_n_frames(n_frames)
    tau = float(dt if tau_us is None else tau_us)
    if not (np.isfinite(tau) and tau > 0):
        raise ValueError(f"tau_us must be a positive number of microseconds, got {tau_us}")
    t = events["t"]
    edges = searchsorted_left(t, int(t0_us) + dt * np.arange(n + 1, dtype=np.int64))
    t_last = np.full(height * width, np.iinfo(np.int64).min // 4, dtype=np.int64)
    out = np.empty((n, height * width), dtype=np.float32)
    for k in range(n):
        window = events[edges[k]:edges[k + 1]]
        flat = window["y"].astype(np.intp) * width + window["x"]
        # sorted times: the last occurrence of a pixel is its most recent event
        uniq, first_in_reversed = np.unique(flat[::-1], return_index=True)
        t_last[uniq] = window["t"][::-1][first_in_reversed]
        t_now = int(t0_us) + (k + 1) * dt - 1
        out[k] = np.exp(-(t_now - t_last) / tau)
    return out.reshape(n, height, width)


def sobel_edges(frames: np.ndarray) -> np.ndarray:
    """Sobel gradient magnitude of every frame ``(..., H, W)``, float32.

    Binary frames give values in ``[0, 1]`` (divided by the largest magnitude a 0/1 image
    can give, ``4 sqrt(2)``). Our reading of the "edge-enhanced event frames" of later work
    on E2V (Xu et al., 2025); introduced in notebooks/09_event_representations_and_time.ipynb.

    Examples
    --------
    >>> img = np.zeros((1, 5, 5), np.uint8); img[0, :, 2:] = 1       # a vertical edge
    >>> np.round(sobel_edges(img)[0, 2].astype(float), 3).tolist()
    [0.0, 0.707, 0.707, 0.0, 0.0]
    """
    from scipy import ndimage

    x = np.asarray(frames, dtype=np.float32)
    if x.ndim < 2:
        raise ValueError(f"frames must be (..., H, W), got shape {x.shape}")
    def sobel(a: np.ndarray, across: int, along: int) -> np.ndarray:
        # derivative [-1, 0, 1] across the edge, smoothing [1, 2, 1] along it; only the two
        # image axes (ndimage.sobel would also smooth over the frame axis)
        d = ndimage.correlate1d(a, [-1.0, 0.0, 1.0], axis=across, mode="nearest")
        return ndimage.correlate1d(d, [1.0, 2.0, 1.0], axis=along, mode="nearest")

    gx, gy = sobel(x, -1, -2), sobel(x, -2, -1)
    return (np.hypot(gx, gy) / np.float32(4 * np.sqrt(2))).astype(np.float32)


def voxel_grid(events: np.ndarray, sensor_size: tuple[int, int], n_bins: int) -> np.ndarray:
    """Event voxel grid with bilinear interpolation in time (Zhu et al., CVPR 2019).

    Times are scaled to ``t* = (n_bins - 1) (t - t_first) / (t_last - t_first)``; each
    event adds its polarity ``p`` to bins ``b`` with weight ``max(0, 1 - |b - t*|)``, so an
    event's weight is split between its two nearest bins and sums to ``p``. Returns float32
    ``(n_bins, H, W)``. Introduced in notebooks/02_event_frames.ipynb.
    """
    width, height = check_sensor_size(sensor_size)
    validate(events, (width, height))
    if int(n_bins) != n_bins or n_bins < 1:
        raise ValueError(f"n_bins must be a positive integer, got {n_bins}")
    n_bins = int(n_bins)
    plane = height * width
    grid = np.zeros(n_bins * plane, dtype=np.float64)
    if len(events) == 0:
        return grid.astype(np.float32).reshape(n_bins, height, width)
    t = events["t"]
    span = float(t[-1] - t[0])
    t_star = (n_bins - 1) * (t - t[0]) / span if span > 0 else np.zeros(len(t))
    left = np.floor(t_star).astype(np.intp)
    frac = t_star - left
    pixel = events["y"].astype(np.intp) * width + events["x"]
    p = events["p"].astype(np.float64)
    grid += np.bincount(left * plane + pixel, weights=p * (1 - frac), minlength=n_bins * plane)
    inside = left + 1 < n_bins  # the right neighbour exists (always, except at t* = n_bins - 1)
    grid += np.bincount(
        (left[inside] + 1) * plane + pixel[inside],
        weights=(p * frac)[inside],
        minlength=n_bins * plane,
    )
    return grid.astype(np.float32).reshape(n_bins, height, width)


def downsample(frames: np.ndarray, factor: int, reduce: str = "auto") -> np.ndarray:
    """Shrink the last two axes (H, W) by an integer ``factor``, pooling ``factor^2`` blocks.

    ``reduce="max"`` keeps a pixel that fired in any of its block (binary frames: the
    paper scales 512 -> 256 this way); ``"sum"`` adds counts, so the number of events is
    kept. ``"auto"`` uses max for bool/uint8 frames (what ``mode="binary"`` returns) and
    sum for anything else. H and W must be divisible by ``factor``.
    Introduced in notebooks/02_event_frames.ipynb.
    """
    frames = np.asarray(frames)
    if frames.ndim < 2:
        raise ValueError(f"frames must have at least 2 dimensions (..., H, W), got {frames.shape}")
    if int(factor) != factor or factor < 1:
        raise ValueError(f"factor must be a positive integer, got {factor}")
    factor = int(factor)
    height, width = frames.shape[-2:]
    if height % factor or width % factor:
        raise ValueError(
            f"H x W = {height} x {width} is not divisible by factor {factor}; crop or pad first"
        )
    if reduce == "auto":
        reduce = "max" if frames.dtype in (np.bool_, np.uint8) else "sum"
    if reduce not in ("max", "sum"):
        raise ValueError(f"reduce must be 'auto', 'max' or 'sum', got {reduce!r}")
    blocks = frames.reshape(*frames.shape[:-2], height // factor, factor, width // factor, factor)
    if reduce == "max":
        return blocks.max(axis=(-3, -1))
    return blocks.sum(axis=(-3, -1))  # integer counts widen to int64, floats stay floats
