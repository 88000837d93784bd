"""Model inputs from events: the event representations the experiments compare.

Every representation turns the events of one 0.5 s orbit into an array the E2V network
family reads: ``(D, S, S)`` for one channel, ``(C, D, S, S)`` for several, ``D`` time
steps of ``S x S`` pixels (max- or sum-pooled from the sensor). The paper uses only
``"binary"`` (Eq. 4); the others answer its future-work question about other
representations (see ``../shared/PAPER.md``).

Introduced in notebooks/09_event_representations_and_time.ipynb.
"""

from __future__ import annotations

import numpy as np

from e2vlib import paper
from e2vlib.frames import accumulate, downsample, sobel_edges, time_surface_stack, voxel_grid

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


def events_to_input(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    representation: str = "binary",
    frame_size: int = paper.FRAME_SIZE_PX,
    n_frames: int = paper.N_EVENT_FRAMES,
    dt_us: int = paper.DT_US,
    t0_us: int = 0,
) -> np.ndarray:
    """The model input of one recording in ``representation``.

    Windows are ``n_frames`` x ``dt_us`` from ``t0_us`` (0: the orbit's first video frame).
    The square sensor is pooled by ``sensor / frame_size``: max for binary frames, time
    surfaces and edges, sum for counts and the voxel grid. Returns uint8 ``(D, S, S)`` for
    the binary representations, float32 ``(D, S, S)`` for the other single-channel ones and
    float32 ``(2, D, S, S)`` (OFF, ON) for ``"polarity"``.

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> ev = make_events(x=[0, 3, 3], y=[0, 3, 3], t=[0, 6, 7], p=[1, -1, 1])
    >>> events_to_input(ev, (4, 4), "count", frame_size=2, n_frames=2, dt_us=5)[1].tolist()
    [[0.0, 0.0], [0.0, 2.0]]
    >>> events_to_input(ev, (4, 4), "polarity", frame_size=2, n_frames=2, dt_us=5).shape
    (2, 2, 2, 2)
    """
    _check(representation)
    width, height = sensor_size
    if width != height or width % frame_size:
        raise ValueError(f"sensor {width}x{height} must be square and a multiple of "
                         f"frame_size {frame_size}")
    factor = width // frame_size
    windows = {"n_frames": n_frames, "dt_us": dt_us, "t0_us": t0_us}
    if representation in ("binary", "binary_paper"):
        frames = accumulate(events, sensor_size, **windows,
                            windows="paper" if representation == "binary_paper" else "fixed")
        return downsample(frames, factor, "max")
    if representation == "count":
        counts = accumulate(events, sensor_size, **windows, mode="count")
        return downsample(counts, factor, "sum").astype(np.float32)
    if representation == "polarity":
        counts = accumulate(events, sensor_size, **windows, mode="polarity")  # (D, 2, H, W)
        return downsample(counts, factor, "sum").astype(np.float32).transpose(1, 0, 2, 3).copy()
    if representation == "time_surface":
        surfaces = time_surface_stack(events, sensor_size, dt_us, n_frames, t0_us)
        return downsample(surfaces, factor, "max")
    if representation == "voxel_grid":
        inside = events[(events["t"] >= t0_us) & (events["t"] < t0_us + n_frames * dt_us)]
        grid = voxel_grid(inside, sensor_size, n_frames)
        return downsample(grid, factor, "sum").astype(np.float32)
    binary = accumulate(events, sensor_size, **windows)  # "edges"
    return downsample(sobel_edges(binary), factor, "max")
