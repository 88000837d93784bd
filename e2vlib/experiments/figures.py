"""The README's pictures, rendered from a dataset and a trained checkpoint.

The top layer of the library: it reads a dataset (:mod:`e2vlib.data`), runs a model
(:mod:`e2vlib.model`, :mod:`e2vlib.train`) and draws with :mod:`e2vlib.viz`, which itself
knows nothing of datasets or models. ``python -m e2vlib figures`` calls
:func:`render_readme_figures`.

Introduced in notebooks/08_visualizing_in_3d.ipynb.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from e2vlib import paper

README_CATEGORIES = ("airplane", "car", "chair", "lamp", "table")
"""Columns of the README's ground-truth-beside-reconstruction picture."""


def render_readme_figures(out_dir, data_root, checkpoint, categories=README_CATEGORIES,
                          events_category: str = "chair") -> dict[str, Path]:
    """Render the README's pictures into ``out_dir``; return ``{name: Path}``.

    * ``events_space_time.png``: the raw events of the ``events_category`` test sample
      whose events ``data_root/events/`` keeps, in space-time (:func:`e2vlib.viz.view_events`);
    * ``event_frames.png``: eight of its binary frames as the dataset makes them (100 of
      5 ms for the paper's settings), at full sensor size: the model's input before
      max-pooling;
    * ``reconstruction.png``: ground truth above the ``checkpoint``'s prediction for one
      test sample per category, the one with the median IoU at
      :data:`e2vlib.paper.IOU_THRESHOLD` of its category (a typical result, not the best),
      in the layout of the paper's Figure 4.

    Every file is written to a temporary name and renamed. Raises ``FileNotFoundError``
    for a missing checkpoint and ``ValueError`` for categories without test samples or
    raw events, before anything is written.
    Introduced in notebooks/08_visualizing_in_3d.ipynb (``python -m e2vlib figures``).
    """
    import matplotlib.pyplot as plt
    import torch

    from e2vlib.data import E2VDataset
    from e2vlib.files import atomic_path
    from e2vlib.inputs import orbit_input
    from e2vlib.io import load_events
    from e2vlib.metrics import iou
    from e2vlib.model import load_checkpoint
    from e2vlib.train import predict
    from e2vlib.viz import plot_frame_grid, screenshot, view_events, view_reconstructions

    out = Path(out_dir)
    checkpoint = Path(checkpoint)
    if not checkpoint.is_file():
        raise FileNotFoundError(
            f"checkpoint {checkpoint} not found: the reconstruction picture needs a trained "
            f"model; train one (python -m e2vlib train --data {data_root} --out DIR) and pass "
            "--checkpoint DIR/best.pt")
    model = load_checkpoint(checkpoint)  # refused (naming it) before any picture is made
    test = E2VDataset(data_root, "test")
    groups = test.category_indices()
    missing = [c for c in (*categories, events_category) if c not in groups]
    if missing:
        raise ValueError(f"{data_root} has no test samples of {missing}; choose from "
                         f"{', '.join(groups)}")
    with_events = [i for i in groups[events_category] if test.raw_events_path(i) is not None]
    if not with_events:
        raise ValueError(f"{data_root}/events/ holds no raw events of a {events_category} test "
                         "sample; pick another events_category")
    out.mkdir(parents=True, exist_ok=True)
    paths: dict[str, Path] = {}

    events, sensor_size = load_events(test.raw_events_path(with_events[0]))
    plotter = view_events(events, sensor_size, max_events=40_000, point_size=1.5,
                          off_screen=True, window_size=(900, 520))
    try:
        paths["events_space_time"] = out / "events_space_time.png"
        screenshot(plotter, paths["events_space_time"])
    finally:
        plotter.close()

    config = test.config
    frames = orbit_input(events, sensor_size, sensor_size[0], n_frames=config["n_frames"],
                              dt_us=config["dt_us"], windows=config["windows"])
    shown = np.linspace(0, len(frames) - 1, 8).round().astype(int)
    side = sensor_size[0]
    crop = slice(side // 8, side - side // 8)  # the object sits in the middle of the image
    fig = plot_frame_grid(frames[:, crop, crop], indices=shown, n_cols=8,
                          dt_us=config["dt_us"], panel_size=1.5)
    paths["event_frames"] = out / "event_frames.png"
    try:
        with atomic_path(paths["event_frames"]) as tmp:
            fig.savefig(tmp, dpi=90, format="png")
    finally:
        plt.close(fig)

    truths, preds = [], []
    for category in categories:
        stack = [test.arrays(i) for i in groups[category]]
        frames_in = torch.from_numpy(np.stack([f for f, _ in stack]))
        probs = predict(model, frames_in, "cpu").numpy()
        scores = [float(iou(p, v, paper.IOU_THRESHOLD)) for p, (_, v) in zip(probs, stack,
                                                                             strict=True)]
        pick = int(np.argsort(scores)[len(scores) // 2])  # the median sample
        truths.append(stack[pick][1])
        preds.append(probs[pick])
    plotter = view_reconstructions(truths, preds, threshold=paper.IOU_THRESHOLD,
                                   titles=list(categories), off_screen=True, panel_size=260)
    try:
        paths["reconstruction"] = out / "reconstruction.png"
        screenshot(plotter, paths["reconstruction"])
    finally:
        plotter.close()
    return paths
