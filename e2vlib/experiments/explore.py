"""A dataset explorer: pick a sample, see its events, frames, label and the model's guess.

The work is done by plain functions (:func:`explorer_view` returns numbers and a figure,
so tests can call it with many values); :func:`dataset_explorer` only wires them to
ipywidgets controls with :func:`e2vlib.viz.interactive_figure`, which also shows the
default view as a picture where no widget can run (nbmake, a notebook viewer).

``dataset`` is an :class:`e2vlib.data.E2VDataset` (its ``ids``, ``category_indices()``,
``raw_events_path(i)`` and ``arrays(i)``); this module does not import ``e2vlib.data``
(nor torch) itself.

Introduced in notebooks/08_visualizing_in_3d.ipynb.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from e2vlib.paper import DT_US, IOU_THRESHOLD, RECORDING_US


class PredictionCache(Mapping):
    """Model probabilities ``(32, 32, 32)`` per dataset index, computed on first use.

    ``cache[i]`` runs ``model`` on item ``i``'s frames once and keeps the float32 result,
    so moving a threshold slider does not re-run the network. Introduced in
    notebooks/08_visualizing_in_3d.ipynb.
    """

    def __init__(self, model, dataset, device: str = "cpu"):
        self.model, self.dataset, self.device = model, dataset, device
        self._store: dict[int, np.ndarray] = {}

    def __getitem__(self, index: int) -> np.ndarray:
        index = int(index)
        if not 0 <= index < len(self.dataset):
            raise KeyError(index)
        if index not in self._store:
            import torch

            from e2vlib.train import predict

            frames, _ = self.dataset.arrays(index)
            probs = predict(self.model, torch.from_numpy(frames)[None], self.device)[0]
            self._store[index] = probs.numpy().astype(np.float32)
        return self._store[index]

    def __iter__(self):
        return iter(range(len(self.dataset)))

    def __len__(self) -> int:
        return len(self.dataset)


def _frames_at(events: np.ndarray, sensor_size: tuple[int, int], dt_ms: float) -> np.ndarray:
    """Binary frames ``(n, H, W)`` uint8 of ``dt_ms`` covering the recording (0.5 s) from
    t = 0 at the sensor's own pixels, as the dataset: :func:`e2vlib.inputs.orbit_input`
    with ``frame_size=None``."""
    from e2vlib.inputs import orbit_input

    dt_us = max(1, round(dt_ms * 1000))
    n = math.ceil(RECORDING_US / dt_us)
    return orbit_input(events, sensor_size, None, n_frames=n, dt_us=dt_us, t0_us=0)


def explorer_view(
    dataset,
    predictions: Mapping[int, np.ndarray] | None,
    category: str,
    index: int,
    threshold: float = IOU_THRESHOLD,
    dt_ms: float = DT_US / 1000,
    n_shown: int = 8,
    max_events: int = 15_000,
    figure: bool = True,
) -> dict:
    """Everything the explorer shows for sample ``index`` of ``category``; a plain dict.

    ``predictions`` maps dataset indices to probabilities ``(32, 32, 32)`` (a
    :class:`PredictionCache`, a dict, or None for no model). Frames are re-accumulated
    at ``dt_ms`` from the raw events when the sample kept them, else the dataset's stored
    frames are shown (5 ms each with the paper's settings; ``dt_ms`` is then ignored).
    Returns ``{"id", "category", "dataset_index", "has_events", "n_events", "dt_ms",
    "frames" (k, H, W) (the panels shown), "n_frames" (all frames at dt), "n_true",
    "n_pred", "iou", "message", "figure"}``; ``iou`` (at ``threshold``) and ``n_pred``
    are None without predictions, ``figure`` is a matplotlib figure (None with
    ``figure=False``).
    Introduced in notebooks/08_visualizing_in_3d.ipynb.
    """
    from e2vlib.io import load_events
    from e2vlib.metrics import iou

    groups = dataset.category_indices()
    if category not in groups:
        raise ValueError(f"category {category!r} is not in this split; choose from "
                         f"{', '.join(groups)}")
    members = groups[category]
    if not 0 <= int(index) < len(members):
        raise ValueError(f"{category} has {len(members)} samples in this split; index must be "
                         f"0..{len(members) - 1}, got {index}")
    if not 0 < threshold < 1:
        raise ValueError(f"threshold must lie strictly between 0 and 1, got {threshold!r}")
    if not dt_ms > 0:
        raise ValueError(f"dt_ms must be positive, got {dt_ms!r}")
    ds_index = members[int(index)]
    sample_id = dataset.ids[ds_index]
    stored_frames, voxels = dataset.arrays(ds_index)

    events_path = dataset.raw_events_path(ds_index)
    events = sensor_size = None
    if events_path is not None:
        events, sensor_size = load_events(events_path)
        all_frames = _frames_at(events, sensor_size, dt_ms)
        message = (f"{sample_id}: {len(events):,} raw events; frames of {dt_ms:g} ms "
                   f"at {sensor_size[0]} x {sensor_size[1]} px")
    else:
        dt_ms = dataset.config.get("dt_us", DT_US) / 1000  # the dataset's own frames
        all_frames = stored_frames
        message = (f"{sample_id}: no raw events stored for this sample (the dataset keeps "
                   f"them for a few samples per category); showing the stored {dt_ms:g} ms "
                   "frames")
    picks = np.linspace(0, len(all_frames) - 1, min(n_shown, len(all_frames))).round()
    picks = picks.astype(int)
    shown = all_frames[picks]

    probs = None if predictions is None else np.asarray(predictions[ds_index])
    score = None if probs is None else float(iou(probs, voxels, threshold))
    result = {
        "id": sample_id, "category": category, "dataset_index": ds_index,
        "has_events": events is not None, "n_events": None if events is None else len(events),
        "dt_ms": float(dt_ms), "frames": shown, "n_frames": len(all_frames),
        "n_true": int(voxels.sum()),
        "n_pred": None if probs is None else int((probs >= threshold).sum()),
        "iou": score, "message": message, "figure": None,
    }
    if figure:
        result["figure"] = _draw(result, events, sensor_size, voxels, probs, threshold, picks,
                                 max_events)
    return result


def _voxel_picture(grid: np.ndarray, threshold: float) -> np.ndarray:
    """An off-screen pyvista picture of the voxels ``>= threshold`` (much faster than
    matplotlib's ``ax.voxels`` for a 32^3 grid)."""
    from e2vlib.viz import screenshot, view_voxels

    plotter = view_voxels(grid, threshold, cmap="viridis" if grid.dtype != bool else None,
                          title="", off_screen=True, window_size=(420, 420))
    try:
        return screenshot(plotter)
    finally:
        plotter.close()


def _draw(view: dict, events, sensor_size, voxels, probs, threshold, picks, max_events):
    import matplotlib.pyplot as plt

    from e2vlib.viz import plot_events_3d

    fig = plt.figure(figsize=(13, 5.8))
    top, bottom = fig.subfigures(2, 1, height_ratios=[3.0, 1.25])
    top.subplots_adjust(left=0.02, right=0.98, bottom=0.02, top=0.86, wspace=0.05)
    ax_ev = top.add_subplot(1, 3, 1, projection="3d")
    if events is not None:
        plot_events_3d(events, sensor_size, ax=ax_ev, max_events=max_events, marker_size=0.6)
        ax_ev.set_title(f"{view['n_events']:,} events in space-time", fontsize=10)
        ax_ev.get_legend().remove()
    else:
        ax_ev.set_axis_off()
        ax_ev.text2D(0.5, 0.5, "no raw events stored\nfor this sample\n(frames only)",
                     ha="center", va="center", transform=ax_ev.transAxes, fontsize=11,
                     color="gray")
    ax_true, ax_pred = top.add_subplot(1, 3, 2), top.add_subplot(1, 3, 3)
    ax_true.imshow(_voxel_picture(voxels, 0.5))
    ax_true.set_title(f"label: {view['n_true']} voxels", fontsize=10)
    if probs is None:
        ax_pred.text(0.5, 0.5, "no model given", ha="center", va="center",
                     transform=ax_pred.transAxes, fontsize=11, color="gray")
    else:
        ax_pred.imshow(_voxel_picture(probs, threshold))
        ax_pred.set_title(f"prediction p >= {threshold:g}: {view['n_pred']} voxels, "
                          f"IoU {view['iou']:.2f}", fontsize=10)
    for ax in (ax_true, ax_pred):
        ax.set_axis_off()
    axes = bottom.subplots(1, len(picks), squeeze=False)[0]
    for ax, k, frame in zip(axes, picks, view["frames"], strict=True):
        ax.imshow(frame, cmap="gray_r", vmin=0, vmax=1, interpolation="nearest")
        ax.set_title(f"{k * view['dt_ms']:.0f} ms", fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])
    # Pixel axes on the first frame (all frames share them).
    height, width = np.shape(view["frames"][0])[:2]
    axes[0].set_xticks([0, width - 1])
    axes[0].set_yticks([0, height - 1])
    axes[0].tick_params(labelsize=6, length=2, pad=1)
    axes[0].set_xlabel("x [px]", fontsize=7, labelpad=0)
    axes[0].set_ylabel("y [px]", fontsize=7, labelpad=0)
    bottom.subplots_adjust(left=0.035, right=0.98, bottom=0.13, top=0.82, wspace=0.08)
    fig.suptitle(f"{view['id']}: events, label and prediction; below, {len(picks)} of "
                 f"{view['n_frames']} binary frames of {view['dt_ms']:g} ms", fontsize=11)
    return fig


def dataset_explorer(dataset, model=None, predictions: Mapping[int, np.ndarray] | None = None,
                     threshold: float = IOU_THRESHOLD, dt_ms: float = DT_US / 1000,
                     device: str = "cpu"):
    """Controls for category, sample, threshold and dt around :func:`explorer_view`.

    Give a ``model`` (its predictions are cached per sample) or ready ``predictions``.
    Returns the widget of :func:`e2vlib.viz.interactive_figure`; the last expression of a
    cell displays it: the controls, then the message and the picture of the current
    choice, which stay visible (at the defaults) in a notebook run without a widget
    frontend. Introduced in notebooks/08_visualizing_in_3d.ipynb.
    """
    import ipywidgets as widgets

    from e2vlib.viz import interactive_figure

    if predictions is None and model is not None:
        predictions = PredictionCache(model, dataset, device)
    groups = dataset.category_indices()
    first = next(iter(groups))
    category = widgets.Dropdown(options=list(groups), value=first, description="category")
    index = widgets.IntSlider(value=0, min=0, max=len(groups[first]) - 1, description="sample")
    thresh = widgets.FloatSlider(value=threshold, min=0.05, max=0.95, step=0.05,
                                 description="threshold")
    dt = widgets.FloatLogSlider(value=dt_ms, base=10, min=0, max=2, step=0.1,
                                description="dt [ms]")

    def on_category(change):
        index.value = 0
        index.max = len(groups[change["new"]]) - 1

    category.observe(on_category, names="value")  # before the redraw: index first

    def show(category, index, threshold, dt_ms):
        view = explorer_view(dataset, predictions, category, index, threshold, dt_ms)
        score = "no model" if view["iou"] is None else f"IoU@{threshold:g} = {view['iou']:.3f}"
        print(f"{view['message']}\nlabel {view['n_true']} voxels; {score}")
        return view["figure"]

    return interactive_figure(show, rows=[["category", "index"], ["threshold", "dt_ms"]],
                              category=category, index=index, threshold=thresh, dt_ms=dt)
