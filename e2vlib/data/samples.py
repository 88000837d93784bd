"""One sample: a mesh through the whole pipeline (:func:`mesh_to_sample`), and its file.

A sample file ROOT/samples/<id>.npz holds the frames and the voxels bit-packed
(:func:`save_sample`); :func:`load_sample` checks the stored shapes and packed lengths
before unpacking anything. Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from e2vlib import paper
from e2vlib.data.checks import MAX_FRAMES_PER_SAMPLE, DatasetError, npz_problem
from e2vlib.data.config import BuildConfig
from e2vlib.data.grey import video_to_grey
from e2vlib.files import atomic_path
from e2vlib.inputs import orbit_input
from e2vlib.orbit import nearest_frames


@dataclass
class Sample:
    """A built sample: frames (n_frames, S, S) uint8 0/1, voxels (32, 32, 32) bool.

    With ``config.grey_video``, ``grey`` is the grey video (n_frames, S, S) uint8 and
    ``grey_index`` (n_frames,) int64 the rendered frame each grey frame comes from
    (see :func:`grey_frame_indices`); otherwise both are None.

    Examples
    --------
    >>> sample = Sample(frames=np.zeros((100, 8, 8), np.uint8), voxels=np.zeros((32,) * 3, bool),
    ...                 events=np.zeros(0), sensor_size=(16, 16))
    >>> sample.grey is None and sample.grey_index is None  # no --grey-video
    True
    """

    frames: np.ndarray
    voxels: np.ndarray
    events: np.ndarray
    sensor_size: tuple[int, int]
    grey: np.ndarray | None = None
    grey_index: np.ndarray | None = None


def mesh_to_sample(mesh, config: BuildConfig, seed: int = 0, *,
                   renderer: Callable | None = None) -> Sample:
    """Run one mesh through the whole pipeline: voxels, orbit video, events, frames.

    The mesh is normalized first (bbox centred, longest side 1). This is exactly what
    the dataset builder and ``python -m e2vlib reconstruct --mesh`` do. With
    ``config.grey_video`` the same rendered video also gives ``sample.grey``
    (:func:`grey_frame_indices`, :func:`video_to_grey`); nothing is rendered twice.
    ``renderer`` renders the orbit, called as :func:`e2vlib.render.render_orbit` (the
    default, which makes a plotter per call); builds of many samples pass
    ``e2vlib.scale.render_cache.render_orbit_cached``, which keeps one (the same video).
    Introduced in notebooks/04_building_the_dataset.ipynb.

    Examples
    --------
    A 16 px orbit (the lessons use 128 px), pooled to 8 px:

    >>> from e2vlib.shapes import make_shape
    >>> config = BuildConfig(categories=("chair",), per_category=1, resolution=16,
    ...                      frame_size=8, oversample=1)
    >>> sample = mesh_to_sample(make_shape("chair", 0), config, seed=0)
    >>> sample.frames.shape, sample.frames.dtype, sample.voxels.shape, sample.sensor_size
    ((100, 8, 8), dtype('uint8'), (32, 32, 32), (16, 16))
    >>> bool(sample.frames.max() == 1 and len(sample.events) > 0 and sample.voxels.any())
    True
    """
    from e2vlib.noise import NOISE_LEVELS, simulate_noisy_events
    from e2vlib.render import render_orbit
    from e2vlib.shapes import normalize_mesh
    from e2vlib.voxels import voxelize

    mesh = normalize_mesh(mesh)
    voxels = voxelize(mesh, paper.GRID_SIDE)
    render = render_orbit if renderer is None else renderer
    video, t_us = render(mesh, n_video_frames=paper.N_VIDEO_FRAMES, fps=paper.VIDEO_FPS,
                         resolution=config.resolution, oversample=config.oversample,
                         anti_aliasing=config.anti_aliasing)
    events = simulate_noisy_events(video, t_us, contrast_pos=config.contrast,
                                   contrast_neg=config.contrast, seed=seed,
                                   **NOISE_LEVELS[config.noise])
    sensor_size = (config.resolution, config.resolution)
    frames = orbit_input(events, sensor_size, config.frame_size, n_frames=config.n_frames,
                         dt_us=config.dt_us, windows=config.windows)
    grey = grey_index = None
    if config.grey_video:
        grey_index = nearest_frames(t_us, config.n_frames, config.dt_us)
        grey = video_to_grey(video, grey_index, config.frame_size)
    return Sample(frames=frames, voxels=voxels, events=events, sensor_size=sensor_size,
                  grey=grey, grey_index=grey_index)


def save_sample(path: Path, frames: np.ndarray, voxels: np.ndarray, n_events: int) -> None:
    """Write one sample as bit-packed, compressed arrays (temp file, then rename).

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "chair_0000.npz"
    >>> frames = np.zeros((100, 8, 8), np.uint8)
    >>> frames[3, 2, 5] = 1
    >>> save_sample(path, frames, np.ones((32, 32, 32), bool), n_events=1)
    >>> sorted(np.load(path).files)
    ['frames', 'frames_shape', 'n_events', 'voxels', 'voxels_shape']
    >>> int(np.load(path)["frames"].nbytes)  # 100 x 8 x 8 bits packed into bytes
    800
    """
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(
            f,
            frames=np.packbits(frames.astype(bool), axis=None),
            frames_shape=np.asarray(frames.shape, dtype=np.int64),
            voxels=np.packbits(voxels.astype(bool), axis=None),
            voxels_shape=np.asarray(voxels.shape, dtype=np.int64),
            n_events=np.int64(n_events),
        )


def _member(data, name: str, path: Path, max_bytes: int) -> np.ndarray:
    """Array ``name`` of an open ``.npz``, refused unread when its stored size exceeds
    ``max_bytes`` (so a small file cannot ask for gigabytes)."""
    try:
        size = data.zip.getinfo(f"{name}.npy").file_size
    except KeyError:
        raise DatasetError(f"{path} has no array {name!r}; it is not a sample file: delete "
                           f"it and rebuild it with make-data") from None
    if size > max_bytes + 4096:  # 4096: room for the .npy header
        raise DatasetError(f"{path}: array {name!r} takes {size} bytes, more than its shape "
                           f"allows ({max_bytes}); delete it and rebuild it with make-data")
    return data[name]


def _stored_shape(data, name: str, path: Path) -> tuple[int, ...]:
    shape = _member(data, f"{name}_shape", path, 64)
    if shape.dtype.kind not in "iu" or shape.shape != (3,) or (shape < 0).any():
        raise DatasetError(f"{path}: {name}_shape must be 3 whole numbers >= 0, got "
                           f"{shape.tolist()!r}; delete it and rebuild it with make-data")
    shape = tuple(int(v) for v in shape)
    if np.prod(shape, dtype=np.float64) > MAX_FRAMES_PER_SAMPLE:
        raise DatasetError(f"{path}: {name}_shape {list(shape)} holds more than "
                           f"{MAX_FRAMES_PER_SAMPLE} values; delete it and rebuild it with "
                           "make-data")
    return shape


def _unpacked(data, name: str, shape: tuple[int, ...], path: Path) -> np.ndarray:
    count = int(np.prod(shape))
    packed = _member(data, name, path, (count + 7) // 8)
    if packed.dtype != np.uint8 or packed.shape != ((count + 7) // 8,):
        raise DatasetError(f"{path}: {name} holds {packed.dtype} {packed.shape}, not the "
                           f"{(count + 7) // 8} packed bytes of shape {list(shape)} (a "
                           "truncated or edited file); delete it and rebuild it with make-data")
    return np.unpackbits(packed, count=count).reshape(shape)


def load_sample(path: str | os.PathLike, frames_shape: Sequence[int] | None = None,
                voxels_shape: Sequence[int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Read a sample file; return ``(frames uint8 (D, S, S), voxels bool (32, 32, 32))``.

    The stored shapes, dtypes and packed lengths are checked before anything is unpacked,
    and against ``frames_shape`` / ``voxels_shape`` when given (what config.json says);
    any mismatch or damage is a :class:`DatasetError` naming the file. A missing file
    raises FileNotFoundError.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "chair_0000.npz"
    >>> save_sample(path, np.eye(8, dtype=np.uint8)[None].repeat(100, 0), np.ones((32,) * 3), 99)
    >>> frames, voxels = load_sample(path, (100, 8, 8))
    >>> frames.shape, frames.dtype, int(frames.sum()), voxels.dtype, int(voxels.sum())
    ((100, 8, 8), dtype('uint8'), 800, dtype('bool'), 32768)
    >>> load_sample(path, (100, 16, 16))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.data.checks.DatasetError: ...frames of shape (100, 8, 8), but ... (100, 16, 16)...; ...
    """
    path = Path(path)
    try:
        data = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as err:
        raise DatasetError(f"{path}: corrupted or truncated sample file ({npz_problem(err)}); "
                           "delete it and rebuild it with `python -m e2vlib make-data`") from err
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise DatasetError(f"{path} is a single .npy array, not a sample file (.npz); delete "
                           "it and rebuild it with `python -m e2vlib make-data`")
    out = []
    try:
        with data:
            for name, expected in (("frames", frames_shape), ("voxels", voxels_shape)):
                shape = _stored_shape(data, name, path)
                if expected is not None and shape != tuple(expected):
                    raise DatasetError(
                        f"{path}: {name} of shape {shape}, but the dataset's config.json "
                        f"makes {tuple(expected)}; the sample comes from another build: "
                        "delete it and rebuild it with make-data")
                out.append(_unpacked(data, name, shape, path))
    except DatasetError:
        raise
    except (zipfile.BadZipFile, EOFError, OSError, KeyError, ValueError) as err:
        raise DatasetError(f"{path}: corrupted or truncated sample file ({err}); delete it "
                           "and rebuild it with `python -m e2vlib make-data`") from err
    return out[0], out[1].astype(bool)
