"""The authors' released SynthEVox3D layout: ``root/<synset>/<scan>/events.npz`` and
``model_normalized.npz`` (the 32^3 label), read into the paper's frames.

:class:`~e2vlib.data.dataset.E2VDataset` reads such a folder when it has no manifest.csv.
"""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path

import numpy as np

from e2vlib import paper
from e2vlib.data.checks import DatasetError, npz_problem
from e2vlib.events import EventError
from e2vlib.inputs import orbit_input

SYNTHEVOX3D_SENSOR = 512  # the paper rendered 512 x 512 and scaled to 256 x 256


def synthevox3d_items(root: Path) -> list[tuple[str, str, Path, str]]:
    """``(id, category, scan folder, split)`` for every scan of a SynthEVox3D folder.

    Scans sit in ``root/<synset>/<scan>/`` (synset ids as in ShapeNet). The release has no
    split file that we rely on, so scans are split 8:1:1 by a hash of their id (stable
    under adding or removing other scans).

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> scan = root / "03001627" / "scan00"  # ShapeNet's synset of chairs
    >>> scan.mkdir(parents=True)
    >>> np.savez(scan / "events.npz", np.array([[0.0123, 100, 200, 1], [0.3, 5, 6, 0]]))
    >>> [(i, c, s.name, split) for i, c, s, split in synthevox3d_items(root)]
    [('03001627/scan00', 'chair', 'scan00', 'train')]
    """
    from e2vlib.paper import SHAPENET_SYNSETS

    items = []
    for synset_dir in sorted(p for p in root.iterdir() if p.is_dir()):
        category = SHAPENET_SYNSETS.get(synset_dir.name, synset_dir.name)
        for scan in sorted(p for p in synset_dir.iterdir() if (p / "events.npz").exists()):
            sample_id = f"{synset_dir.name}/{scan.name}"
            bucket = int.from_bytes(hashlib.sha256(sample_id.encode()).digest()[:2], "little")
            fraction = bucket / 65536
            split = "train" if fraction < 0.8 else "val" if fraction < 0.9 else "test"
            items.append((sample_id, category, scan, split))
    if not items:
        raise ValueError(
            f"{root}: neither an e2vlib dataset (manifest.csv) nor a SynthEVox3D folder "
            "(<synset>/<scan>/events.npz)"
        )
    return items


def synthevox3d_time_scale(t: np.ndarray) -> float:
    """Microseconds per unit of a SynthEVox3D time column, settled by its value range.

    An orbit lasts 0.5 s, so the last time stamp tells the unit: below 10 -> seconds,
    below 1e4 -> milliseconds, below 1e7 -> microseconds, else nanoseconds.

    Examples
    --------
    >>> [synthevox3d_time_scale(np.array([0.0, last])) for last in (0.49, 490.0, 4.9e5, 4.9e8)]
    [1000000.0, 1000.0, 1.0, 0.001]
    """
    span = float(np.max(t)) if len(t) else 0.0
    if span < 10:
        return 1e6
    if span < 1e4:
        return 1e3
    if span < 1e7:
        return 1.0
    return 1e-3


def load_synthevox3d_scan(scan: Path, frame_size: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Frames ``(100, S, S)`` uint8 and voxels ``(32, 32, 32)`` bool of one released scan.

    ``events.npz``'s ``arr_0`` is an ``(N, 4)`` float array of t, x, y, p; the voxel file's
    ``arr_0`` is the 32^3 grid.

    Examples
    --------
    >>> import tempfile
    >>> scan = Path(tempfile.mkdtemp())
    >>> np.savez(scan / "events.npz", np.array([[0.0123, 100, 200, 1], [0.3, 5, 6, 0]]))
    >>> np.savez(scan / "model_normalized.npz", np.ones((32, 32, 32), bool))
    >>> frames, voxels = load_synthevox3d_scan(scan, frame_size=64)  # 512 px pooled by 8
    >>> frames.shape, int(frames.sum()), int(frames[2, 200 // 8, 100 // 8])  # t = 12.3 ms: frame 2
    ((100, 64, 64), 2, 1)
    """
    from e2vlib.events import make_events, sort_events

    try:
        with np.load(scan / "events.npz", allow_pickle=False) as data:
            table = data["arr_0"]
        with np.load(scan / "model_normalized.npz", allow_pickle=False) as data:
            voxels = np.asarray(data["arr_0"]).astype(bool)
    except (zipfile.BadZipFile, EOFError, OSError, KeyError, ValueError) as err:
        raise DatasetError(f"{scan}: unreadable SynthEVox3D scan ({npz_problem(err)})") from err
    if table.ndim != 2 or table.shape[1] != 4:
        raise ValueError(f"{scan}/events.npz: expected an (N, 4) array t, x, y, p, "
                         f"got {table.shape}")
    if voxels.shape != (paper.GRID_SIDE,) * 3:
        raise ValueError(f"{scan}/model_normalized.npz: expected 32^3 voxels, got {voxels.shape}")
    t, x, y, p = table.T
    scale = synthevox3d_time_scale(t)
    try:
        events = sort_events(make_events(x, y, np.round(t * scale), p))
    except EventError as err:
        raise ValueError(f"{scan}/events.npz: {err}") from err
    size = SYNTHEVOX3D_SENSOR
    return orbit_input(events, (size, size), frame_size, t0_us=0), voxels
