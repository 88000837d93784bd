"""Reconstruct one object with a trained checkpoint, from a mesh or from an event stream.

:func:`reconstruct` is what ``python -m e2vlib reconstruct`` runs: a mesh goes through the
dataset pipeline (:func:`e2vlib.data.mesh_to_sample`: orbit video, events, frames, and its
own voxels to compare with), an event stream (a file or an array) becomes the model's
input by :func:`e2vlib.inputs.recording_input` (windows from its first event, a
centre crop of any sensor); either way the frames are made with the settings of the data
the model was trained on (:func:`checkpoint_build_config`). The answer is a
:class:`Reconstruction`: the probabilities ``(32, 32, 32)`` float32, the frames that went
in, and the mesh's voxels.

Introduced in notebooks/07_evaluation.ipynb.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

import e2vlib.train as train  # train.predict looked up at call time (a test replaces it)
from e2vlib.data import BuildConfig, mesh_to_sample
from e2vlib.inputs import recording_input
from e2vlib.io import load_events
from e2vlib.metrics import iou
from e2vlib.model import E2V, checkpoint_data_config, load_checkpoint, read_checkpoint
from e2vlib.paper import IOU_THRESHOLD
from e2vlib.shapes import load_mesh

MIN_FILLED_FRACTION = 0.5
"""The least fraction of the model's frames (time windows of ``dt_us`` us from the first
event) that must hold an event of a recording given to :func:`reconstruct`: with fewer, the
events are bunched in time (all in one window, a stray event long before the rest) and the
model would answer from frames empty by construction. Simulated orbits fill every frame."""

MIN_SPREAD_FRACTION = 0.25
"""The least share of the model's frame side that the pixels holding events of a recording
given to :func:`reconstruct` must span (across or down): with less, the events fill a small
corner of the declared sensor (a sensor size far larger than the camera's) and the model
would answer from frames empty but for a few pixels. Simulated orbits span most of it."""


class InputError(ValueError):
    """Events that cannot make the model's input (too few for its frames, a sensor smaller
    than its frames). ``source`` names them (the file, or ``"given"`` for an array),
    ``reason`` says what is wrong; the message is ``"events <source>: <reason>"``.

    Examples
    --------
    >>> err = InputError("few.npz", "3 event(s) cannot make the model's input")
    >>> str(err), err.source
    ("events few.npz: 3 event(s) cannot make the model's input", 'few.npz')
    """

    def __init__(self, source: str, reason: str) -> None:
        super().__init__(f"events {source}: {reason}")
        self.source, self.reason = source, reason


@dataclass(frozen=True)
class Reconstruction:
    """One reconstruction: ``probabilities`` ``(32, 32, 32)`` float32 in ``[0, 1]``
    indexed ``[x, y, z]``, the ``frames`` the model read (its input shape, uint8 or
    float32), and ``voxels`` ``(32, 32, 32)`` bool, the mesh's own occupancy (None for
    events, which carry no ground truth).

    Examples
    --------
    >>> p = np.zeros((32, 32, 32), np.float32)
    >>> p[:2] = 0.9  # two slabs of 32 x 32 voxels
    >>> truth = np.zeros((32, 32, 32), bool)
    >>> truth[:4] = True
    >>> result = Reconstruction(p, np.zeros((10, 16, 16), np.uint8), truth)
    >>> result.occupied(), result.iou()  # 2048 of the 4096 true voxels, nothing else
    (2048, 0.5)
    >>> sorted(result.arrays())
    ['frames', 'probabilities', 'voxels']
    """

    probabilities: np.ndarray
    frames: np.ndarray
    voxels: np.ndarray | None = None

    def occupied(self, threshold: float = IOU_THRESHOLD) -> int:
        """Voxels whose probability is at least ``threshold``."""
        return int((self.probabilities >= threshold).sum())

    def iou(self, threshold: float = IOU_THRESHOLD) -> float | None:
        """IoU at ``threshold`` against the mesh's own voxels (None without them)."""
        if self.voxels is None:
            return None
        return float(iou(self.probabilities, self.voxels, threshold))

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays to save: ``voxels`` (when known), ``probabilities``, ``frames``."""
        known = {} if self.voxels is None else {"voxels": self.voxels}
        return {**known, "probabilities": self.probabilities, "frames": self.frames}


def checkpoint_build_config(ckpt: Mapping[str, Any], model: E2V,
                            source: object = "checkpoint") -> BuildConfig:
    """The settings that make ``model``'s input as for the data it was trained on: the data
    config stored in ``ckpt`` (:func:`~e2vlib.model.checkpoint_data_config`), with the
    frames' number and size from the model where it stores none (renders at twice the
    frame size then) and one object of one category (only the frame settings matter).

    Raises ValueError naming ``source`` when the stored frames differ from the model's.

    Examples
    --------
    >>> from e2vlib.model import build_e2v
    >>> model = build_e2v("tiny", input_shape=(10, 16, 16))
    >>> config = checkpoint_build_config({}, model)  # a checkpoint without a data config
    >>> config.n_frames, config.frame_size, config.resolution, config.dt_us, config.windows
    (10, 16, 32, 5000, 'fixed')
    >>> checkpoint_build_config({"data_config": {"n_frames": 50}}, model, "tiny.pt")
    Traceback (most recent call last):
    ...
    ValueError: tiny.pt is inconsistent: its model takes 10 frames of 16 px but the data \
config stored with it makes 50 frames of 16 px; re-create the checkpoint (train, or \
slim_checkpoint)
    """
    n_frames, frame_size, _ = model.input_shape
    stored = dict(checkpoint_data_config(ckpt) or {})
    made = (stored.get("n_frames") or n_frames, stored.get("frame_size") or frame_size)
    if made != (n_frames, frame_size):
        raise ValueError(
            f"{source} is inconsistent: its model takes {n_frames} frames of {frame_size} px "
            f"but the data config stored with it makes {made[0]} frames of {made[1]} px; "
            "re-create the checkpoint (train, or slim_checkpoint)")
    stored.setdefault("frame_size", frame_size)
    stored.setdefault("resolution", 2 * frame_size)
    stored.setdefault("n_frames", n_frames)
    known = {k: v for k, v in stored.items() if k in BuildConfig.__dataclass_fields__}
    known["categories"] = list(known.get("categories") or []) or ["chair"]
    known["per_category"] = 1
    return BuildConfig.from_dict(known)


def check_frames_filled(frames: np.ndarray, events: np.ndarray, source: str,
                        dt_us: int) -> None:
    """Refuse frames of which fewer than :data:`MIN_FILLED_FRACTION` hold an event, naming
    ``source``, the count and what to do (an :class:`InputError`).

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> frames = np.zeros((10, 4, 4), np.uint8)
    >>> frames[0, 0, 0] = 1  # one frame of ten holds events
    >>> events = make_events([0, 1], [0, 0], [0, 900], [1, 1])
    >>> check_frames_filled(frames, events, "b.npz", 5000)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.reconstruct.InputError: events b.npz: only 1 of the model's 10 frames ...
    """
    windows = frames.shape[-3]  # (..., n_frames, H, W)
    filled = int(np.any(frames.reshape(-1, windows, *frames.shape[-2:]) != 0,
                        axis=(0, 2, 3)).sum())
    needed = math.ceil(MIN_FILLED_FRACTION * windows)
    if filled < needed:
        first, last = int(events["t"].min()), int(events["t"].max())
        raise InputError(source, (
            f"only {filled} of the model's {windows} frames ({dt_us} us each, from the first "
            f"event) hold events; at least {needed} must (MIN_FILLED_FRACTION "
            f"{MIN_FILLED_FRACTION}): its {len(events)} events span {last - first} us "
            f"from t = {first} us, the frames {windows * dt_us} us. Give a recording of "
            "the whole orbit, and drop stray events before it (the frames start at the "
            "first event: keep events from the first dense second on)"))


def check_events_spread(events: np.ndarray, sensor_size: tuple[int, int], frame_size: int,
                        source: str) -> None:
    """Refuse events that the model's frames (the centred square of the sensor pooled to
    ``frame_size``, as :func:`~e2vlib.inputs.recording_input` makes them) would see in less
    than :data:`MIN_SPREAD_FRACTION` of the frame side across and down, naming ``source``,
    where the events lie on the declared sensor and what to do (an :class:`InputError`).
    The spatial twin of :func:`check_frames_filled`, checked before any frame is made (the
    frames of a 4000 x 4000 sensor take gigabytes).

    Examples
    --------
    >>> from e2vlib.events import make_events
    >>> events = make_events([0, 127], [0, 127], [0, 900], [1, 1])
    >>> check_events_spread(events, (128, 128), 64, "small.npz")  # spans the frame
    >>> check_events_spread(events, (4000, 4000), 64, "big.npz")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.reconstruct.InputError: events big.npz: they lie within x 0-127, y 0-127 \
of the declared 4000 x 4000 sensor, ...
    """
    width, height = sensor_size
    factor = min(width, height) // frame_size
    if factor < 1 or not len(events):  # recording_input refuses these, naming why
        return
    side = factor * frame_size
    top, left = (height - side) // 2, (width - side) // 2
    x = events["x"].astype(np.int64) - left
    y = events["y"].astype(np.int64) - top
    seen = (x >= 0) & (x < side) & (y >= 0) & (y < side)
    spans = [int(v.max() - v.min() + 1) if v.size else 0
             for v in (x[seen] // factor, y[seen] // factor)]
    if max(spans) >= MIN_SPREAD_FRACTION * frame_size:
        return
    x, y = events["x"], events["y"]
    raise InputError(source, (
        f"they lie within x {int(x.min())}-{int(x.max())}, y {int(y.min())}-{int(y.max())} of "
        f"the declared {width} x {height} sensor, so the model's {frame_size} x {frame_size} "
        f"px frames see them in {spans[0]} x {spans[1]} px (at least "
        f"{MIN_SPREAD_FRACTION:.0%} of the side must hold events: MIN_SPREAD_FRACTION). Save "
        "the events with the size of the sensor that recorded them (at least "
        f"{int(x.max()) + 1} x {int(y.max()) + 1}), or crop them to the object"))


def reconstruct(checkpoint: str | os.PathLike | Mapping[str, Any], mesh=None, events=None,
                sensor_size: tuple[int, int] | None = None, device: str = "auto",
                seed: int = 0) -> Reconstruction:
    """Reconstruct one object from a mesh or from events with a trained checkpoint.

    Parameters
    ----------
    checkpoint
        A checkpoint file written by ``train`` / :func:`~e2vlib.model.save_checkpoint`, or
        one already read (:func:`~e2vlib.model.read_checkpoint`).
    mesh
        A ``trimesh.Trimesh`` or a mesh file (OBJ/PLY/STL/OFF/GLB): normalized, rendered
        on the orbit, simulated and framed (:func:`e2vlib.data.mesh_to_sample`, simulator
        seed ``seed``), its voxels kept for comparison.
    events
        An event file (.npz, .txt, .h5, .aedat4; :func:`e2vlib.io.load_events`) or an
        event array (:data:`e2vlib.events.EVENT_DTYPE`) with ``sensor_size`` ``(width,
        height)``. Give exactly one of ``mesh`` and ``events``.
    device
        Where the model runs (``"auto"``, ``"cpu"``, ``"cuda"``, ...).

    Returns
    -------
    Reconstruction
        ``probabilities`` ``(32, 32, 32)`` float32, the ``frames`` read, the mesh's
        ``voxels`` (None for events).

    Raises
    ------
    ValueError
        Naming the problem: neither or both of ``mesh`` and ``events``, an array without
        ``sensor_size``, a checkpoint whose stored data config disagrees with its model
        (:func:`checkpoint_build_config`), frames of another shape than the model takes;
        :class:`InputError` for events that cannot make the input (fewer than its frames,
        bunched in time so that most frames are empty: :func:`check_frames_filled`, or in a
        small corner of the declared sensor: :func:`check_events_spread`).
    FloatingPointError
        When the model's output holds NaN or inf (a broken checkpoint).

    Examples
    --------
    An untrained 10-frame model of 16 px, and one event per 5 ms frame on a 16 x 16 sensor:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from e2vlib.events import make_events
    >>> from e2vlib.model import build_e2v, save_checkpoint
    >>> path = Path(tempfile.mkdtemp()) / "small.pt"
    >>> _ = save_checkpoint(path, build_e2v("tiny", seed=0, input_shape=(10, 16, 16)))
    >>> k = np.arange(10)
    >>> events = make_events(k, k, 1000 + 5000 * k, np.ones(10))
    >>> result = reconstruct(path, events=events, sensor_size=(16, 16), device="cpu")
    >>> result.probabilities.shape, result.probabilities.dtype, result.voxels is None
    ((32, 32, 32), dtype('float32'), True)
    >>> result.frames.shape, int(result.frames.sum())  # one event in each frame
    ((10, 16, 16), 10)
    >>> reconstruct(path, events=events[:3], sensor_size=(16, 16))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.reconstruct.InputError: events given: 3 event(s) cannot make ...
    >>> reconstruct(path)
    Traceback (most recent call last):
    ...
    ValueError: give a mesh (mesh=) or events (events=) to reconstruct
    """
    if (mesh is None) == (events is None):
        raise ValueError("give a mesh (mesh=) or events (events=) to reconstruct"
                         if mesh is None else "give mesh= or events=, not both")
    if isinstance(checkpoint, Mapping):
        ckpt, source = checkpoint, "the checkpoint given"
    else:
        ckpt, source = read_checkpoint(checkpoint), f"checkpoint {checkpoint}"
    model = load_checkpoint(ckpt, source=source)
    config = checkpoint_build_config(ckpt, model, source)
    voxels = None
    if mesh is not None:
        if isinstance(mesh, (str, os.PathLike)):
            mesh = load_mesh(mesh)
        sample = mesh_to_sample(mesh, config, seed=seed)
        frames, voxels = sample.frames, sample.voxels
    else:
        name = "given"
        if isinstance(events, (str, os.PathLike)):
            name = str(events)
            events, sensor_size = load_events(events)
        elif sensor_size is None:
            raise ValueError("an event array needs its sensor_size (width, height)")
        if len(events) >= config.n_frames:  # (fewer: recording_input says so)
            check_events_spread(events, sensor_size, config.frame_size, name)
        try:
            frames = recording_input(events, sensor_size, config.frame_size,
                                           n_frames=config.n_frames, dt_us=config.dt_us,
                                           windows=config.windows)
        except ValueError as err:
            raise InputError(name, str(err)) from None
        check_frames_filled(frames, events, name, config.dt_us)
    if tuple(frames.shape) != tuple(model.input_shape):
        raise ValueError(f"the model expects frames of shape {tuple(model.input_shape)}, "
                         f"the input gives {tuple(frames.shape)}")
    probabilities = train.predict(model, torch.from_numpy(frames)[None], device)[0].numpy()
    if not np.all(np.isfinite(probabilities)):
        raise FloatingPointError(f"the model's output holds NaN/inf for this input; check "
                                 f"{source} (retrain, or use best.pt)")
    return Reconstruction(probabilities.astype(np.float32), frames, voxels)


__all__ = ["MIN_FILLED_FRACTION", "MIN_SPREAD_FRACTION", "InputError", "Reconstruction",
           "check_frames_filled", "check_events_spread", "checkpoint_build_config",
           "reconstruct"]
