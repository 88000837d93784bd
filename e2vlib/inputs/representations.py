"""Model inputs from events: the one home of events -> what the E2V network family reads.

Every representation turns the events of one 0.5 s orbit into ``(D, S, S)`` for one
channel or ``(C, D, S, S)`` for several: ``D`` time windows of ``S x S`` pixels, max- or
sum-pooled from the sensor. The paper uses only ``"binary"`` (Eq. 4); the others answer its
future-work question about other representations (``e2vlib.paper`` holds its words).

Two clocks need two functions; pick by where the events come from:

=========================  =================================================================
:func:`orbit_input`        events of a *simulated orbit* (the dataset builder, SynthEVox3D
                           scans, the experiments, the explorer): windows counted from
                           ``t0_us`` (0: the orbit's first video frame, whenever the first
                           event fires), a square sensor whose side is a multiple of
                           ``frame_size`` (``frame_size=None``: the sensor's own pixels)
:func:`recording_input`    a *recording* with its own clock and sensor (``reconstruct
                           --events``, real cameras): windows from its first event, the
                           sensor centre-cropped to the largest square that is a multiple
                           of ``frame_size``; fewer than ``n_frames`` events are refused
=========================  =================================================================

This module imports only ``frames``, ``events`` and ``paper`` (``data`` imports it).
Introduced in notebooks/09_event_representations_and_time.ipynb.
"""

from __future__ import annotations

import numpy as np

from e2vlib import paper
from e2vlib.events import EventError
from e2vlib.frames import (
    WINDOWS,
    accumulate,
    downsample,
    sobel_edges,
    time_surface_stack,
    voxel_grid,
)

REPRESENTATIONS: dict[str, str] = {
    "binary": "the paper's binary frames (Eq. 4) over fixed 5 ms windows (our default)",
    "binary_paper": "binary frames grouped as the paper's Eq. 5 (groups start at events)",
    "count": "events per pixel and window (sum-pooled)",
    "polarity": "ON and OFF counts as 2 channels (sum-pooled)",
    "time_surface": "exponential time surface (tau = dt) at the end of each window (max-pooled)",
    "voxel_grid": "polarity-weighted voxel grid with bilinear time bins (Zhu et al.)",
    "edges": "Sobel magnitude of the binary frames (our reading of Xu et al.'s edge frames)",
}
"""Representation name -> one-line description."""


def input_channels(representation: str) -> int:
    """Channels of a representation: 2 for ``"polarity"``, else 1.

    Examples
    --------
    >>> input_channels("polarity"), input_channels("binary")
    (2, 1)
    """
    _check(representation)
    return 2 if representation == "polarity" else 1


def _check(representation: str) -> None:
    if representation not in REPRESENTATIONS:
        raise ValueError(f"unknown representation {representation!r}; choose one of "
                         f"{', '.join(REPRESENTATIONS)}")


def _windows(representation: str, windows: str | None) -> str:
    """The windows ``representation`` is made with: ``"binary_paper"`` is ``"binary"`` on
    the paper's Eq. 5 groups; ``windows`` (None: :data:`e2vlib.paper.FRAME_WINDOWS`) may be
    ``"paper"`` only for ``"binary"``; the other representations use fixed clock windows."""
    if windows is not None and windows not in WINDOWS:
        raise ValueError(f"windows must be one of {WINDOWS}, got {windows!r}")
    if representation == "binary_paper":
        if windows not in (None, "paper"):
            raise ValueError("representation 'binary_paper' groups events as the paper's Eq. 5 "
                             f"(windows='paper'), not {windows!r}; for fixed windows use "
                             "representation 'binary'")
        return "paper"
    if representation == "binary":
        return paper.FRAME_WINDOWS if windows is None else windows
    if windows not in (None, "fixed"):
        raise ValueError(f"windows={windows!r} makes binary frames only; {representation!r} "
                         "uses fixed clock windows: leave windows out, or use representation "
                         "'binary'")
    return "fixed"


def _represent(events: np.ndarray, sensor_size: tuple[int, int], representation: str,
               factor: int, crop: tuple[int, int, int] | None, n_frames: int, dt_us: int,
               t0_us: int, windows: str) -> np.ndarray:
    """``representation`` at the sensor's resolution on windows from ``t0_us``, cut to
    ``crop = (top, left, side)`` (None: the whole sensor), pooled by ``factor``."""

    def pool(array: np.ndarray, reduce: str) -> np.ndarray:
        if crop is not None:
            top, left, side = crop
            array = array[..., top:top + side, left:left + side]
        return downsample(array, factor, reduce)

    clock = {"n_frames": n_frames, "dt_us": dt_us, "t0_us": t0_us}
    if representation in ("binary", "binary_paper"):
        return pool(accumulate(events, sensor_size, **clock, windows=windows), "max")
    if representation == "count":
        counts = accumulate(events, sensor_size, **clock, mode="count", windows=windows)
        return pool(counts, "sum").astype(np.float32)
    if representation == "polarity":
        counts = accumulate(events, sensor_size, **clock, mode="polarity", windows=windows)
        return pool(counts, "sum").astype(np.float32).transpose(1, 0, 2, 3).copy()  # (2, D, ..)
    if representation == "time_surface":
        return pool(time_surface_stack(events, sensor_size, dt_us, n_frames, t0_us), "max")
    if representation == "voxel_grid":
        inside = events[(events["t"] >= t0_us) & (events["t"] < t0_us + n_frames * dt_us)]
        return pool(voxel_grid(inside, sensor_size, n_frames), "sum").astype(np.float32)
    binary = accumulate(events, sensor_size, **clock, windows=windows)  # "edges"
    return pool(sobel_edges(binary), "max")


def orbit_input(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    frame_size: int | None = paper.FRAME_SIZE_PX,
    *,
    representation: str = "binary",
    n_frames: int = paper.N_EVENT_FRAMES,
    dt_us: int = paper.DT_US,
    t0_us: int = 0,
    windows: str | None = None,
) -> np.ndarray:
    """The model input of a simulated orbit: ``n_frames`` windows of ``dt_us`` (us) from
    ``t0_us`` on the orbit's clock, pooled from a square sensor to ``frame_size``.

    Use it for events whose clock starts with the orbit's video (everything e2vlib
    simulates: t = 0 is the first rendered frame, and the first event comes later), so the
    windows are the same for every sample whatever its first event; a recording with its
    own clock goes to :func:`recording_input`. ``sensor_size`` is ``(width, height)`` in
    px; it must be square with a side a multiple of ``frame_size``, and is pooled by
    ``side / frame_size`` (max for binary frames, time surfaces and edges, sum for counts
    and the voxel grid). ``frame_size=None`` keeps the sensor's own pixels (any width x
    height, no pooling). ``windows`` ``"fixed"`` (clock windows, the default) or
    ``"paper"`` (Eq. 5 groups, for ``"binary"`` only; ``"binary_paper"`` is that).

    Returns uint8 ``(D, S, S)`` 0/1 for the binary representations, float32 ``(D, S, S)``
    for the other single-channel ones and float32 ``(2, D, S, S)`` (OFF, ON) for
    ``"polarity"``; ``D = n_frames``, ``S = frame_size`` (``(D, H, W)`` with
    ``frame_size=None``). What the dataset builder (:func:`e2vlib.data.mesh_to_sample`)
    stores, with ``t0_us=0``.

    Examples
    --------
    Three events on a 4 x 4 sensor, two windows of 5 us, pooled to 2 x 2:

    >>> from e2vlib.events import make_events
    >>> ev = make_events(x=[0, 3, 3], y=[0, 3, 3], t=[0, 6, 7], p=[1, -1, 1])
    >>> orbit_input(ev, (4, 4), 2, n_frames=2, dt_us=5).tolist()
    [[[1, 0], [0, 0]], [[0, 0], [0, 1]]]
    >>> orbit_input(ev, (4, 4), 2, representation="count", n_frames=2, dt_us=5)[1].tolist()
    [[0.0, 0.0], [0.0, 2.0]]
    >>> orbit_input(ev, (4, 4), 2, n_frames=2, dt_us=5, t0_us=5)[0].tolist()  # [5, 10) us
    [[0, 0], [0, 1]]
    >>> orbit_input(ev, (6, 4), None, n_frames=2, dt_us=5).shape  # (D, H, W), not pooled
    (2, 4, 6)
    """
    _check(representation)
    windows = _windows(representation, windows)
    width, height = sensor_size
    if frame_size is None:
        factor = 1
    elif width != height or width % frame_size:
        raise ValueError(f"sensor {width}x{height} must be square and a multiple of "
                         f"frame_size {frame_size}")
    else:
        factor = width // frame_size
    return _represent(events, sensor_size, representation, factor, None, n_frames, dt_us,
                      t0_us, windows)


def recording_input(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    frame_size: int = paper.FRAME_SIZE_PX,
    *,
    representation: str = "binary",
    n_frames: int = paper.N_EVENT_FRAMES,
    dt_us: int = paper.DT_US,
    windows: str | None = None,
) -> np.ndarray:
    """The model input of a recording: ``n_frames`` windows of ``dt_us`` (us) from its
    first event, centre-cropped to a square and pooled to ``frame_size``.

    Use it for events with a clock and a sensor of their own (a file given to
    ``python -m e2vlib reconstruct --events``, a real camera): the windows start at the
    first event, whatever its time stamp, and ``sensor_size`` ``(width, height)`` may be
    any size of at least ``frame_size``: the frames are cut to the centred square of side
    ``k * frame_size`` (``k = min(width, height) // frame_size``) and pooled by ``k``.
    Simulated orbits, whose clock starts at the first video frame, go to
    :func:`orbit_input`; for a square sensor a multiple of ``frame_size`` this equals
    ``orbit_input(..., t0_us=events["t"][0])``. Fewer than ``n_frames`` events raise
    EventError: some frames would be empty by construction, and the model would give a
    confident-looking grid from next to no evidence.

    Returns what :func:`orbit_input` returns for ``representation`` and ``windows``:
    uint8 ``(n_frames, frame_size, frame_size)`` for ``"binary"``.

    Examples
    --------
    A 6 x 4 sensor whose clock starts at 1000 us: the centred 4 x 4 square (columns 1-4)
    pooled to 2 x 2, windows [1000, 1005) and [1005, 1010) us:

    >>> from e2vlib.events import make_events
    >>> ev = make_events(x=[1, 4, 4], y=[0, 3, 3], t=[1000, 1006, 1007], p=[1, -1, 1])
    >>> recording_input(ev, (6, 4), 2, n_frames=2, dt_us=5).tolist()
    [[[1, 0], [0, 0]], [[0, 0], [0, 1]]]
    >>> recording_input(ev, (6, 4), 2, n_frames=4, dt_us=5)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.events.EventError: 3 event(s) cannot make the model's input: its 4 frames ...
    """
    _check(representation)
    windows = _windows(representation, windows)
    if len(events) < n_frames:
        raise EventError(f"{len(events)} event(s) cannot make the model's input: its "
                         f"{n_frames} frames of {dt_us} us need at least {n_frames} events "
                         "(one per frame; with fewer, frames are empty by construction and "
                         "the model would answer from next to no evidence); give a recording "
                         "of the whole orbit")
    width, height = sensor_size
    factor = min(width, height) // frame_size
    if factor < 1:
        raise ValueError(f"a {width}x{height} sensor is smaller than frame_size {frame_size}")
    t0 = int(events["t"][0]) if len(events) else 0
    side = factor * frame_size
    crop = ((height - side) // 2, (width - side) // 2, side)
    return _represent(events, sensor_size, representation, factor, crop, n_frames, dt_us, t0,
                      windows)


def events_to_input(events: np.ndarray, sensor_size: tuple[int, int],
                    representation: str = "binary", frame_size: int = paper.FRAME_SIZE_PX,
                    n_frames: int = paper.N_EVENT_FRAMES, dt_us: int = paper.DT_US,
                    t0_us: int = 0) -> np.ndarray:
    """:func:`orbit_input` with the argument order of the collection's published contract
    (``representation`` third), which code outside this repository calls; the lessons and
    the library call :func:`orbit_input`.

    >>> from e2vlib.events import make_events
    >>> ev = make_events(x=[0, 3, 3], y=[0, 3, 3], t=[0, 6, 7], p=[1, -1, 1])
    >>> events_to_input(ev, (4, 4), "count", frame_size=2, n_frames=2, dt_us=5)[1].tolist()
    [[0.0, 0.0], [0.0, 2.0]]
    """
    return orbit_input(events, sensor_size, frame_size, representation=representation,
                       n_frames=n_frames, dt_us=dt_us, t0_us=t0_us)


GREY_INPUTS: dict[str, str] = {
    "grey_video": "the rendered grey frames of the same orbit at the event frames' times",
    "grey_single": "one grey view (the orbit's first frame), for a 2D encoder",
}
"""Inputs of the input study that are not events (read from the cache's grey videos)."""


def grey_input(grey: np.ndarray, representation: str, frame_size: int) -> np.ndarray:
    """The model input made from a stored grey video ``(n_frames, S, S)`` uint8: grey levels
    in [0, 1] as float16, block-averaged to ``frame_size``; ``"grey_single"`` keeps only the
    first frame, ``(1, frame_size, frame_size)``.

    Examples
    --------
    >>> grey = np.arange(2 * 4 * 4, dtype=np.uint8).reshape(2, 4, 4) * 5
    >>> x = grey_input(grey, "grey_single", 2)   # block (0, 0): (0 + 5 + 20 + 25) / 4 / 255
    >>> x.shape, x.dtype, round(float(x[0, 0, 0]), 3)
    ((1, 2, 2), dtype('float16'), 0.049)
    """
    if representation not in GREY_INPUTS:
        raise ValueError(f"unknown grey input {representation!r}; choose one of "
                         f"{', '.join(GREY_INPUTS)}")
    frames = np.asarray(grey)[:1] if representation == "grey_single" else np.asarray(grey)
    factor = frames.shape[-1] // frame_size
    if factor * frame_size != frames.shape[-1]:
        raise ValueError(f"frame_size {frame_size} must divide the grey video's "
                         f"{frames.shape[-1]} px")
    means = downsample(frames.astype(np.float32), factor, "sum") / (factor * factor * 255.0)
    return means.astype(np.float16)
