"""Static matplotlib figures: events in space-time, event rates, frame grids, voxels.

Each function draws into an ``ax`` (or makes a figure) and returns it; everything works
headless (the Agg backend). The pyvista twins of these pictures are in
:mod:`e2vlib.viz.scenes` and :mod:`e2vlib.viz.recording`.

Introduced in notebooks/01_events.ipynb, notebooks/02_event_frames.ipynb and
notebooks/07_evaluation.ipynb.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from e2vlib import paper
from e2vlib.events import check_sensor_size, validate
from e2vlib.frames import accumulate
from e2vlib.viz.style import OFF_COLOR, ON_COLOR, PROBABILITY_CMAP


def subsample_events(events: np.ndarray, max_events: int, seed: int = 0) -> np.ndarray:
    """At most ``max_events`` events, picked uniformly at random, kept in time order."""
    if len(events) <= max_events:
        return events
    keep = np.sort(np.random.default_rng(seed).choice(len(events), max_events, replace=False))
    return events[keep]


def plot_events_3d(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    ax=None,
    max_events: int = 20_000,
    marker_size: float = 1.0,
):
    """3D space-time scatter: x across, time (ms from the first event) in depth, y up.

    ON events orange, OFF blue; at most ``max_events`` points are drawn (a random subset).
    ``y`` is flipped so the picture is upright like the camera image. Returns the axes.
    Introduced in notebooks/01_events.ipynb.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")  # off screen
    >>> from e2vlib.events import make_events
    >>> events = make_events([0, 2, 3, 1], [0, 1, 2, 1], [0, 2000, 5000, 15000], [1, -1, 1, 1])
    >>> ax = plot_events_3d(events, (4, 3))
    >>> ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()
    ('x [px]', 't [ms]', 'y [px] (up)')
    >>> [text.get_text() for text in ax.get_legend().get_texts()]
    ['ON (+1)', 'OFF (-1)']
    """
    width, height = check_sensor_size(sensor_size)
    validate(events, (width, height))
    if ax is None:
        ax = plt.figure(figsize=(8, 6)).add_subplot(projection="3d")
    shown = subsample_events(events, max_events)
    t_ms = (shown["t"] - (events["t"][0] if len(events) else 0)) / 1e3
    for polarity, color, label in ((1, ON_COLOR, "ON (+1)"), (-1, OFF_COLOR, "OFF (-1)")):
        sel = shown["p"] == polarity
        ax.scatter(shown["x"][sel], t_ms[sel], height - 1 - shown["y"][sel].astype(int),
                   s=marker_size, c=color, label=label, depthshade=False, linewidths=0)
    ax.set_xlabel("x [px]")
    ax.set_ylabel("t [ms]")
    ax.set_zlabel("y [px] (up)")
    ax.set_xlim(0, width)
    ax.set_zlim(0, height)
    ax.legend(loc="upper left", markerscale=6)
    return ax


def plot_event_rate(events: np.ndarray, bin_us: int = 10_000, ax=None):
    """Events per second over time, ON and OFF separately, in bins of ``bin_us``.

    Returns the axes. Introduced in notebooks/01_events.ipynb.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")  # off screen
    >>> from e2vlib.events import make_events
    >>> events = make_events([0, 2, 3, 1], [0, 1, 2, 1], [0, 2000, 5000, 15000], [1, -1, 1, 1])
    >>> ax = plot_event_rate(events, bin_us=10_000)  # two bins of 10 ms
    >>> [stairs.get_data().values.tolist() for stairs in ax.patches]  # ON, then OFF (events/s)
    [[200.0, 100.0], [100.0, 0.0]]
    """
    if ax is None:
        ax = plt.figure(figsize=(8, 3)).add_subplot()
    if len(events) == 0:
        return ax
    t0 = events["t"][0]
    n_bins = int((events["t"][-1] - t0) // bin_us) + 1
    edges_ms = np.arange(n_bins + 1) * bin_us / 1e3
    for polarity, color, label in ((1, ON_COLOR, "ON"), (-1, OFF_COLOR, "OFF")):
        k = (events["t"][events["p"] == polarity] - t0) // bin_us
        rate = np.bincount(k, minlength=n_bins) / (bin_us / 1e6)
        ax.stairs(rate, edges_ms, color=color, label=label)
    ax.set_xlabel("time since first event [ms]")
    ax.set_ylabel("events / s")
    ax.legend()
    return ax


def plot_frame_grid(
    frames: np.ndarray,
    indices=None,
    n_cols: int = 10,
    dt_us: int | None = None,
    cmap: str = "gray_r",
    panel_size: float = 1.6,
):
    """Show frames ``(n, H, W)`` (or a chosen ``indices`` subset) as a grid of images.

    With ``dt_us`` each panel is titled with its window start in ms. Returns the figure.
    Introduced in notebooks/02_event_frames.ipynb.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")  # off screen
    >>> fig = plot_frame_grid(np.zeros((3, 4, 4)), n_cols=2, dt_us=5000)
    >>> [ax.get_title() for ax in fig.axes]  # a 2 x 2 grid, the last panel blank
    ['0 ms', '5 ms', '10 ms', '']
    """
    frames = np.asarray(frames)
    if frames.ndim != 3:
        raise ValueError(f"frames must be (n, H, W), got shape {frames.shape}")
    indices = list(range(len(frames))) if indices is None else list(indices)
    n_rows = max(1, -(-len(indices) // n_cols))
    height, width = frames.shape[1:]
    fig, axes = plt.subplots(
        n_rows, n_cols, squeeze=False,
        figsize=(n_cols * panel_size, n_rows * panel_size * height / width + 0.3 * n_rows),
    )
    vmax = max(1, float(frames.max())) if frames.size else 1
    for ax in axes.flat[len(indices):]:
        ax.axis("off")
    for ax, k in zip(axes.flat, indices, strict=False):
        ax.set_xticks([])
        ax.set_yticks([])
        ax.imshow(frames[k], cmap=cmap, vmin=0, vmax=vmax, interpolation="nearest")
        ax.set_title(f"{k * dt_us / 1e3:.0f} ms" if dt_us else f"k={k}", fontsize=8)
    fig.tight_layout()
    return fig


def show_frame(
    events: np.ndarray,
    sensor_size: tuple[int, int],
    dt_ms: float,
    index: int,
    ax=None,
):
    """Accumulate binary frames of ``dt_ms`` and draw frame ``index``; return (frame, ax).

    The plain function behind the dt / frame-index slider of lesson 02 (the widget only
    calls it). ``index`` past the last frame shows the last frame.
    Introduced in notebooks/02_event_frames.ipynb.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")  # off screen
    >>> from e2vlib.events import make_events
    >>> events = make_events([0, 2, 3, 1], [0, 1, 2, 1], [0, 2000, 5000, 15000], [1, -1, 1, 1])
    >>> frame, ax = show_frame(events, (4, 3), dt_ms=10, index=0)
    >>> frame.shape, int(frame.sum()), ax.get_title()  # 3 of the 4 events in the first 10 ms
    ((3, 4), 3, 'dt = 10 ms, frame 0 of 2: 3 pixels fired')
    """
    dt_us = max(1, round(dt_ms * 1000))
    frames = accumulate(events, sensor_size, dt_us=dt_us, mode="binary")
    index = int(np.clip(index, 0, len(frames) - 1))
    frame = frames[index]
    if ax is None:
        ax = plt.figure(figsize=(5, 4)).add_subplot()
    ax.imshow(frame, cmap="gray_r", vmin=0, vmax=1, interpolation="nearest")
    ax.set_title(f"dt = {dt_us / 1e3:g} ms, frame {index} of {len(frames)}: "
                 f"{int(frame.sum())} pixels fired")
    ax.axis("off")
    return frame, ax


# --- voxels ------------------------------------------------------------------------------


def plot_voxels(grid: np.ndarray, ax=None, threshold: float = 0.5, color="#8fa8c8",
                title: str | None = None, colormap: str | None = None):
    """Draw the voxels of a ``(R, R, R)`` grid (indexed x, y, z) with ``grid >= threshold``.

    With ``colormap`` (e.g. ``"viridis"``) each voxel is coloured by its value (a
    probability); otherwise all take ``color``. Returns the 3D axes.
    Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")  # off screen
    >>> grid = np.zeros((4, 4, 4))
    >>> grid[1:3, 1:3, 1:3] = 1
    >>> ax = plot_voxels(grid, title="a 2 x 2 x 2 block")
    >>> ax.name, ax.get_xlim(), ax.get_title()
    ('3d', (np.float64(0.0), np.float64(4.0)), 'a 2 x 2 x 2 block')
    """
    grid = np.asarray(grid, dtype=np.float32)
    if grid.ndim != 3:
        raise ValueError(f"grid must be (R, R, R), got shape {grid.shape}")
    if ax is None:
        ax = plt.figure(figsize=(4, 4)).add_subplot(projection="3d")
    filled = grid >= threshold
    if colormap is not None:
        colors = plt.get_cmap(colormap)(np.clip(grid, 0, 1))
        ax.voxels(filled, facecolors=colors, edgecolor=(0, 0, 0, 0.15), linewidth=0.2)
    else:
        ax.voxels(filled, facecolors=color, edgecolor=(0, 0, 0, 0.25), linewidth=0.2)
    size = grid.shape[0]
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(0, size)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=-60)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_zticks([])
    if title:
        ax.set_title(title)
    return ax


def plot_reconstruction(probabilities: np.ndarray, voxels: np.ndarray | None = None,
                        threshold: float = paper.IOU_THRESHOLD, title: str | None = None):
    """Ground truth (if given) beside the prediction ``probabilities >= threshold``.

    The prediction is coloured by probability; the title reports IoU at ``threshold``
    when the ground truth is known. Returns the figure.
    Introduced in notebooks/07_evaluation.ipynb.

    Examples
    --------
    >>> import matplotlib; matplotlib.use("Agg")  # off screen
    >>> truth = np.zeros((4, 4, 4))
    >>> truth[1:3, 1:3, 1:3] = 1
    >>> fig = plot_reconstruction(0.9 * truth, truth)  # probabilities 0.9 where the truth is
    >>> [ax.get_title() for ax in fig.axes]
    ['ground truth', 'prediction (p >= 0.3), IoU 1.00']
    """
    from e2vlib.metrics import iou

    n = 1 if voxels is None else 2
    fig = plt.figure(figsize=(4.2 * n, 4.4))
    if voxels is not None:
        plot_voxels(voxels, fig.add_subplot(1, n, 1, projection="3d"), title="ground truth")
    label = f"prediction (p >= {threshold})"
    if voxels is not None:
        label += f", IoU {iou(probabilities, voxels, threshold):.2f}"
    plot_voxels(probabilities, fig.add_subplot(1, n, n, projection="3d"), threshold=threshold,
                colormap=PROBABILITY_CMAP, title=label)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
