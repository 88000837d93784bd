"""Event representations: binary/count/polarity frames, time surfaces, voxel grids.

All functions take an event array of :data:`e2vlib.events.EVENT_DTYPE` (sorted by ``t``,
microseconds) and ``sensor_size = (width, height)``, validate them, and never modify the
caller's array. Frames are indexed ``[k, y, x]``; with fixed windows (the default) frame
``k`` covers the half-open window ``[t0 + k*dt, t0 + (k+1)*dt)``; ``windows="paper"``
groups events as the paper's Eq. 5 does (see :func:`accumulate`). :func:`accumulate` is
plain numpy, written to be read; ``e2vlib.scale.frames_numba.accumulate_fast`` gives the
same frames from a compiled kernel, for long streams.

Introduced in notebooks/02_event_frames.ipynb.
"""

from __future__ import annotations

import numpy as np

from e2vlib import paper
from e2vlib.events import INT64_MAX, INT64_MIN, EventError, check_sensor_size, validate

MODES = ("binary", "count", "polarity")
WINDOWS = ("fixed", "paper")
"""How :func:`accumulate` cuts time: fixed clock windows, or the paper's Eq. 5 groups."""

MAX_FRAMES_BYTES: int = 8 * 2**30
"""Largest frame stack :func:`accumulate` makes (8 GiB); larger requests raise EventError
before anything is allocated (``accumulate_fast`` also keeps within half the free memory)."""


def window_count(t_first_us: int, t_last_us: int, dt_us: int, t0_us: int) -> int:
    """Number of windows of ``dt_us`` starting at ``t0_us`` needed to cover ``t_last_us``.

    The window holding the last event is included, so no event at the end is lost:
    ``floor((t_last - t0) / dt) + 1`` (0 if every event is before ``t0``).
    """
    if t_last_us < t0_us:
        return 0
    return int((t_last_us - t0_us) // dt_us) + 1


def _whole(value, low: int, high: int) -> bool:
    """Whether ``value`` is a whole number in ``[low, high]`` (False for NaN, text, ...)."""
    try:
        return bool(np.isfinite(value)) and int(value) == value and low <= int(value) <= high
    except (TypeError, ValueError, OverflowError):
        return False


def _check_dt(dt_us) -> int:
    """``dt_us`` as a positive whole number of microseconds, or a clear EventError."""
    if not _whole(dt_us, 1, 2**64 - 1):
        raise EventError(
            f"dt_us must be a positive whole number of microseconds below 2^64, got {dt_us!r} "
            f"(the paper's 5 ms is dt_us={paper.DT_US})")
    return int(dt_us)


def _check_n_frames(n_frames) -> int:
    if not _whole(n_frames, 0, INT64_MAX):
        raise EventError(f"n_frames must be a non-negative integer, got {n_frames!r}")
    return int(n_frames)


def check_frame_arguments(events: np.ndarray, dt_us, t0_us, n_frames, mode: str,
                          windows: str) -> tuple[int, int, int | None]:
    """The settings of :func:`accumulate` checked: ``(dt, t0, n_frames)`` as ints.

    ``t0`` defaults to the first event's time (0 without events); ``n_frames`` stays None
    when not given. Raises ValueError for an unknown ``mode`` or ``windows`` and EventError
    for a bad number, naming it. ``events`` must have the event dtype (they are not read
    beyond their first time). Shared with ``e2vlib.scale.frames_numba.accumulate_fast``.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if windows not in WINDOWS:
        raise ValueError(f"windows must be one of {WINDOWS}, got {windows!r}")
    dt = _check_dt(dt_us)
    if t0_us is None:
        t0_us = int(events["t"][0]) if len(events) else 0
    if not _whole(t0_us, INT64_MIN, INT64_MAX):
        raise EventError(f"t0_us must be a whole number of microseconds in the int64 range "
                         f"(like the event times), got {t0_us!r}")
    return dt, int(t0_us), None if n_frames is None else _check_n_frames(n_frames)


def check_stack_size(n_frames: int, frame_values: int, mode: str, t: np.ndarray,
                     limit: int | None = None, why: str = "frames.MAX_FRAMES_BYTES") -> None:
    """Refuse a stack of ``n_frames`` x ``frame_values`` over ``limit`` bytes (default
    :data:`MAX_FRAMES_BYTES`) with an EventError that gives the sizes and event times ``t``."""
    limit = MAX_FRAMES_BYTES if limit is None else limit
    wanted = n_frames * frame_values * (1 if mode == "binary" else 4)
    if wanted > limit:
        first, last = (int(t[0]), int(t[-1])) if len(t) else (0, 0)
        raise EventError(
            f"{n_frames} frames of {frame_values} values would take {wanted / 2**30:.2f} GiB "
            f"(limit {limit / 2**30:.2f} GiB: {why}); check sensor_size, dt_us and t0_us "
            f"against the event times ({first}..{last} us) or pass n_frames")


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
    t = np.ascontiguousarray(t)  # events["t"] is a strided view: copy it once, not per search
    bounds = [int(start)]
    limit = np.inf if n_groups is None else int(n_groups)
    while bounds[-1] < len(t) and len(bounds) - 1 < limit:
        group_end = min(int(t[bounds[-1]]) + int(dt_us), INT64_MAX)  # the last time it takes
        bounds.append(int(np.searchsorted(t, group_end, side="right")))
    return np.asarray(bounds, dtype=np.int64)


def accumulate(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    dt_us: int = paper.DT_US,
    t0_us: int | None = None,
    n_frames: int | None = None,
    mode: str = "binary",
    windows: str = paper.FRAME_WINDOWS,
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
    windows are left out. Stacks over :data:`MAX_FRAMES_BYTES` are refused. For long
    streams, ``e2vlib.scale.frames_numba.accumulate_fast`` gives the same frames faster.
    Introduced in notebooks/02_event_frames.ipynb.

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> ev = make_events(x=[0, 1, 1, 0], y=[0, 0, 0, 0], t=[0, 4, 6, 11], p=[1, -1, 1, 1])
    >>> accumulate(ev, (2, 1), dt_us=5, mode="count")[:, 0].tolist()   # [0,5) [5,10) [10,15)
    [[1, 1], [0, 1], [1, 0]]
    >>> accumulate(ev, (2, 1), dt_us=5, mode="count", windows="paper")[:, 0].tolist()
    [[1, 1], [1, 1]]
    """
    width, height = check_sensor_size(sensor_size)
    validate(events, (width, height))
    dt, t0, n_frames = check_frame_arguments(events, dt_us, t0_us, n_frames, mode, windows)
    t = events["t"]
    first = int(np.searchsorted(t, t0))  # t is sorted: events before t0 are left out

    # 1. The frame each event from t0 on falls in.
    if windows == "fixed":
        # frame k holds t0 + k dt <= t < t0 + (k + 1) dt. t - t0 >= 0 is read as uint64,
        # which keeps it exact even for times more than 2^63 us (292,000 years) apart.
        frame = (t[first:] - t0).view(np.uint64) // np.uint64(dt)
        n = int(frame[-1]) + 1 if len(frame) else 0  # up to the window of the last event
    else:
        # Eq. 5: a group starts at its first event t_j and takes events while t - t_j <= dt
        bounds = paper_group_bounds(t, dt, start=first, n_groups=n_frames)
        frame = np.repeat(np.arange(len(bounds) - 1), np.diff(bounds))
        n = len(bounds) - 1
    if n_frames is not None:
        n = n_frames  # later frames are dropped, missing ones stay empty
    kept = int(np.searchsorted(frame, n))  # frames rise with time: those before n lead
    inside, frame = events[first:first + kept], frame[:kept].astype(np.intp, copy=False)

    # 2. One index per event into the flat stack (n, channels, H, W).
    channels = 2 if mode == "polarity" else 1
    check_stack_size(n, channels * height * width, mode, t)
    channel = (inside["p"] > 0) if mode == "polarity" else 0  # 0 = OFF, 1 = ON
    flat = ((frame * channels + channel) * height + inside["y"]) * width + inside["x"]

    # 3. A 1 where a pixel fired (Eq. 4), or how many events it got.
    stack = np.zeros(n * channels * height * width,
                     dtype=np.uint8 if mode == "binary" else np.int32)
    if mode == "binary":
        stack[flat] = 1
    else:
        index, count = np.unique(flat, return_counts=True)
        stack[index] = count
    shape = (n, 2, height, width) if mode == "polarity" else (n, height, width)
    return stack.reshape(shape)


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
    edges = np.searchsorted(t, int(t0_us) + dt * np.arange(n + 1, dtype=np.int64))
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
    kept (integer counts widen to int64, floats stay floats). ``"auto"`` uses max for
    bool/uint8 frames (what ``mode="binary"`` returns) and sum for anything else. H and W
    must be divisible by ``factor``. scikit-image's ``block_reduce`` does the pooling.
    Introduced in notebooks/02_event_frames.ipynb.

    Examples
    --------
    >>> downsample(np.eye(4, dtype=np.uint8)[None], 2)[0].tolist()
    [[1, 0], [0, 1]]
    >>> downsample(np.eye(4, dtype=np.int32)[None], 2)[0].tolist()
    [[2, 0], [0, 2]]
    """
    from skimage.measure import block_reduce

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
    block = (1,) * (frames.ndim - 2) + (factor, factor)
    return block_reduce(frames, block, np.max if reduce == "max" else np.sum)
