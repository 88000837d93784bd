"""Grey video at the event frames' times (``make-data --grey-video``): ROOT/grey/<id>.npz.

Grey frame ``k`` is the rendered frame nearest the centre of event window ``k``
(:func:`grey_frame_indices`), area-averaged to the frame size (:func:`video_to_grey`), seen
from :func:`grey_frame_cameras`. Used in notebooks/11_events_vs_frames_vs_geometry.ipynb.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from e2vlib import orbit, paper
from e2vlib.data.checks import check_id, inside, read_config
from e2vlib.data.commands import make_data_command
from e2vlib.data.config import BuildConfig, frame_settings
from e2vlib.files import atomic_path

GREY_DIR = "grey"
"""Folder of a dataset holding the grey videos (``make-data --grey-video``)."""


def grey_frame_indices(config: BuildConfig) -> np.ndarray:
    """Which rendered video frame becomes grey frame ``k``: shape ``(n_frames,)`` int64.

    Grey frame ``k`` is the rendered frame (of the ``oversample``-times dense orbit that
    fed the simulator, :func:`e2vlib.orbit.rendered_times_us`) nearest the centre
    ``(k + 1/2) dt_us``
    of event window ``k`` (ties to the earlier frame). Windows past the end of the 0.5 s
    video get its last frame. With ``windows="paper"`` the Eq. 5 groups start at events
    and so vary per sample; the grey video keeps to the clock windows of ``dt_us``.

    Examples
    --------
    >>> config = BuildConfig(categories=("chair",), per_category=1, oversample=1)
    >>> index = grey_frame_indices(config)  # window centres 2500, 7500, 12500, ... us
    >>> index.shape, index[:4].tolist(), index[-2:].tolist()  # frame 119 is at 495.8 ms
    ((100,), [1, 2, 3, 4], [118, 119])
    """
    return orbit.window_frame_indices(config.n_frames, config.dt_us, paper.N_VIDEO_FRAMES,
                                      paper.VIDEO_FPS, int(config.oversample))


def grey_frame_cameras(config: BuildConfig) -> np.ndarray:
    """Camera position (m) of every grey frame, shape ``(n_frames, 3)``.

    The orbit is fixed by the config alone (no per-sample randomness), so row ``k`` is
    ``e2vlib.orbit.orbit_cameras(n_rendered)[grey_frame_indices(config)[k]]``; the camera
    looks at the origin with +z up (see :func:`e2vlib.orbit.project_points`).

    Examples
    --------
    >>> from e2vlib.orbit import orbit_cameras
    >>> config = BuildConfig(categories=("chair",), per_category=1, oversample=1)
    >>> cameras = grey_frame_cameras(config)
    >>> cameras.shape, bool(np.allclose(cameras[0], orbit_cameras(120)[1]))
    ((100, 3), True)
    """
    return orbit.window_cameras(config.n_frames, config.dt_us, paper.N_VIDEO_FRAMES,
                                paper.VIDEO_FPS, int(config.oversample))


def video_to_grey(video: np.ndarray, indices: np.ndarray, frame_size: int) -> np.ndarray:
    """Frames ``indices`` of a rendered ``video`` (n, R, R) float in [0, 1], area-averaged
    down to ``frame_size`` (which must divide R), as uint8 grey levels
    ``(len(indices), frame_size, frame_size)``: each pixel is the mean of an
    ``R/frame_size``-square block of the 8-bit levels ``round(255 v)``, rounded half up
    (exact integer arithmetic).

    Examples
    --------
    >>> video = np.zeros((1, 4, 4))
    >>> video[0, :2, :2], video[0, 2:, 2:] = 1.0, 0.5  # white and mid-grey quarters
    >>> video_to_grey(video, [0], 2).tolist()  # 8-bit levels 255 and round(127.5) = 128
    [[[255, 0], [0, 128]]]
    """
    _, height, width = video.shape
    if height != width or width % frame_size:
        raise ValueError(f"video frames {width}x{height} must be square and a multiple of "
                         f"frame_size {frame_size}")
    f = width // frame_size
    frames = np.clip(np.asarray(video[np.asarray(indices)], dtype=np.float64), 0.0, 1.0)
    levels = np.rint(frames * 255.0).astype(np.int64)
    sums = levels.reshape(len(levels), frame_size, f, frame_size, f).sum(axis=(2, 4))
    return ((sums + (f * f) // 2) // (f * f)).astype(np.uint8)


def save_grey_video(path: Path, grey: np.ndarray, frame_index: np.ndarray,
                    t_us: np.ndarray) -> None:
    """Write ROOT/grey/<id>.npz: ``grey`` uint8 (n_frames, S, S), ``frame_index`` int64
    (n_frames,) into the rendered video, ``t_us`` int64 (n_frames,) their time stamps (us).

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / GREY_DIR / "chair_0000.npz"
    >>> save_grey_video(path, np.zeros((100, 8, 8), np.uint8), np.arange(100), np.arange(100) * 50)
    >>> sorted(np.load(path).files)
    ['frame_index', 'grey', 't_us']
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, grey=np.asarray(grey, dtype=np.uint8),
                            frame_index=np.asarray(frame_index, dtype=np.int64),
                            t_us=np.asarray(t_us, dtype=np.int64))


def load_grey_video(root: str | os.PathLike, sample_id: str) -> np.ndarray:
    """Grey video of sample ``sample_id``: uint8 ``(n_frames, frame_size, frame_size)``.

    Frame ``k`` shows the object at the centre of event window ``k``
    (:func:`grey_frame_indices`), seen from ``grey_frame_cameras(config)[k]``. Raises a
    ValueError naming the make-data command to run when ``root`` was built without
    ``--grey-video`` or the file is missing or damaged.

    Examples
    --------
    >>> import json, tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> config = BuildConfig(categories=("chair",), per_category=1, resolution=16,
    ...                      frame_size=8, oversample=1, grey_video=True)
    >>> _ = (root / "config.json").write_text(json.dumps(config.to_dict()))
    >>> index = grey_frame_indices(config)
    >>> save_grey_video(root / GREY_DIR / "chair_0000.npz", np.full((100, 8, 8), 7, np.uint8),
    ...                 index, orbit.rendered_times_us(oversample=config.oversample)[index])
    >>> grey = load_grey_video(root, "chair_0000")
    >>> grey.shape, grey.dtype, int(grey[0, 0, 0])
    ((100, 8, 8), dtype('uint8'), 7)
    """
    root = Path(root)
    config_path = root / "config.json"
    if not config_path.is_file():
        raise FileNotFoundError(f"{config_path} not found: {root} is not a dataset made by "
                                f"`python -m e2vlib make-data --out {root} --grey-video`")
    sample_id = check_id(sample_id, f"load_grey_video({str(root)!r}, ...)")
    stored = read_config(root)
    if not stored.get("grey_video", False):
        try:
            command = make_data_command(
                BuildConfig.from_dict({**stored, "grey_video": True}), f"{root}_grey")
        except (TypeError, ValueError):
            command = "python -m e2vlib make-data --grey-video --out NEW_FOLDER ..."
        raise ValueError(f"{root} was built without --grey-video, so it stores no grey "
                         f"frames; build the same samples with them: `{command}`")
    path = inside(root, root / GREY_DIR / f"{sample_id}.npz")
    sample = inside(root, root / "samples" / f"{sample_id}.npz")
    if not path.is_file():
        if not sample.is_file():
            raise ValueError(f"{root} has no sample {sample_id!r}; ids are listed in "
                             f"{root / 'manifest.csv'}")
        raise ValueError(f"{path} is missing; delete {sample} and finish the build with "
                         f"make-data --out {root} (resumable)")
    try:
        with np.load(path, allow_pickle=False) as data:
            grey = np.asarray(data["grey"])
    except (zipfile.BadZipFile, EOFError, OSError, KeyError, ValueError) as err:
        raise ValueError(f"{path}: corrupted or truncated grey video ({err}); delete it and "
                         f"its sample file and rerun make-data --out {root}") from err
    settings = frame_settings(stored)
    expected = (settings["n_frames"], settings["frame_size"], settings["frame_size"])
    if grey.dtype != np.uint8 or grey.shape != expected:
        raise ValueError(f"{path}: expected uint8 grey frames of shape {expected}, got "
                         f"{grey.dtype} {grey.shape}; rebuild it with make-data --out {root}")
    return grey
