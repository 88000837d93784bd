"""Read and write event files, converting every foreign convention at the door.

Supported formats (chosen by the file name's ending):

=================  ======  ======  =========================================================
ending             read    write   layout
=================  ======  ======  =========================================================
``.npz``           yes     yes     e2vlib's own: arrays ``x y t p`` + ``sensor_size``
``.txt``/``.txt.gz`` yes   yes     rpg/ESIM text: ``width height`` line, then ``t x y p`` with
                                   t in seconds and p in 0/1
``.h5``/``.hdf5``  yes     yes     ``events/{x,y,t,p}`` (+ width/height attributes); also
                                   v2e's ``events`` (N, 4) table and DSEC's ``t_offset``
``.aedat4``        yes     no      iniVation DAVIS/DVXplorer files, through ``aedat``
=================  ======  ======  =========================================================

Whatever the file, :func:`load_events` returns events of ``EVENT_DTYPE``: integer
microseconds, polarity -1/+1, sorted by time, checked against the sensor size.

Introduced in notebooks/01_events.ipynb.
"""

from __future__ import annotations

import gzip
import os
import zipfile
from pathlib import Path

import numpy as np

from e2vlib.events import EventError, check_sensor_size, make_events, sort_events, validate
from e2vlib.files import atomic_path

FORMATS = (".npz", ".txt", ".txt.gz", ".h5", ".hdf5", ".aedat4")
_TIME_SCALE_TO_US = {"s": 1e6, "ms": 1e3, "us": 1.0, "ns": 1e-3}


def _format_of(path: Path) -> str:
    name = path.name.lower()
    for ending in sorted(FORMATS, key=len, reverse=True):
        if name.endswith(ending):
            return ending
    raise ValueError(
        f"{path}: unknown event file type; use one of {', '.join(FORMATS)} "
        "(convert other formats to .npz or .h5 first)"
    )


def load_events(path: str | os.PathLike) -> tuple[np.ndarray, tuple[int, int]]:
    """Load an event file; return ``(events, sensor_size)`` with ``sensor_size=(W, H)``.

    Times come back as int64 microseconds, polarity as -1/+1, sorted by time (stable).
    Missing files raise FileNotFoundError; truncated or corrupted files raise ValueError
    naming the file. Introduced in notebooks/01_events.ipynb.

    Examples
    --------
    >>> import tempfile
    >>> from e2vlib.events import make_events
    >>> path = Path(tempfile.mkdtemp()) / "ev.txt"
    >>> _ = save_events(path, make_events([1, 2], [0, 3], [500, 1500], [1, -1]), (4, 4))
    >>> print(path.read_text())      # rpg/ESIM text: seconds, polarity 0/1
    4 4
    0.000500 1 0 1
    0.001500 2 3 0
    <BLANKLINE>
    >>> events, sensor_size = load_events(path)
    >>> events["t"].tolist(), events["p"].tolist(), sensor_size
    ([500, 1500], [1, -1], (4, 4))
    """
    path = Path(path)
    fmt = _format_of(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such event file")
    reader = {
        ".npz": _read_npz,
        ".txt": _read_text,
        ".txt.gz": _read_text,
        ".h5": _read_hdf5,
        ".hdf5": _read_hdf5,
        ".aedat4": _read_aedat4,
    }[fmt]
    try:
        events, sensor_size = reader(path)
    except EventError as err:
        raise EventError(f"{path}: {err}") from err
    if len(events) > 1 and np.any(np.diff(events["t"]) < 0):
        events = sort_events(events)
    try:
        validate(events, sensor_size)
    except EventError as err:
        raise EventError(f"{path}: {err}") from err
    return events, check_sensor_size(sensor_size)


def save_events(
    path: str | os.PathLike, events: np.ndarray, sensor_size: tuple[int, int]
) -> Path:
    """Write events to ``path`` (``.npz``, ``.txt``, ``.txt.gz``, ``.h5``); return the path.

    The events are validated first. The file is written under a temporary name in the
    same folder and renamed at the end, so a crash never leaves a half-written file or
    destroys an existing one. Introduced in notebooks/01_events.ipynb.
    """
    path = Path(path)
    fmt = _format_of(path)
    sensor_size = check_sensor_size(sensor_size)
    validate(events, sensor_size)
    writer = {
        ".npz": _write_npz,
        ".txt": _write_text,
        ".txt.gz": _write_text,
        ".h5": _write_hdf5,
        ".hdf5": _write_hdf5,
    }.get(fmt)
    if writer is None:
        raise ValueError(f"{path}: writing {fmt} is not supported; save as .npz or .h5 instead")
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        writer(tmp, events, sensor_size)
    return path


# --- .npz (native) -----------------------------------------------------------------------


def _write_npz(path: Path, events: np.ndarray, sensor_size: tuple[int, int]) -> None:
    with open(path, "wb") as f:
        np.savez_compressed(
            f, x=events["x"], y=events["y"], t=events["t"], p=events["p"],
            sensor_size=np.asarray(sensor_size, dtype=np.int64),
        )


def _read_npz(path: Path) -> tuple[np.ndarray, tuple[int, int]]:
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = {"x", "y", "t", "p", "sensor_size"} - set(data.files)
            if missing:
                raise ValueError(
                    f"{path}: not an e2vlib event file, missing arrays {sorted(missing)} "
                    "(expected x, y, t, p, sensor_size)"
                )
            columns = [data[k] for k in ("x", "y", "t", "p")]
            sensor_size = tuple(int(v) for v in data["sensor_size"])
    except (zipfile.BadZipFile, EOFError, OSError) as err:
        raise ValueError(f"{path}: corrupted or truncated .npz file ({err})") from err
    return make_events(*columns), sensor_size


# --- rpg / ESIM text ---------------------------------------------------------------------


def _write_text(path: Path, events: np.ndarray, sensor_size: tuple[int, int]) -> None:
    opener = gzip.open if path.name.endswith(".gz") else open
    table = np.column_stack([
        events["t"] / 1e6, events["x"], events["y"], (events["p"] > 0).astype(np.int8)
    ])
    with opener(path, "wt") as f:
        f.write(f"{sensor_size[0]} {sensor_size[1]}\n")
        np.savetxt(f, table, fmt=["%.6f", "%d", "%d", "%d"])


def _read_text(path: Path) -> tuple[np.ndarray, tuple[int, int]]:
    opener = gzip.open if path.name.lower().endswith(".gz") else open
    try:
        with opener(path, "rt") as f:
            first = f.readline().split()
            has_header = len(first) == 2
            if not has_header and len(first) != 4:
                raise ValueError(
                    f"{path}: first line should be 'width height' or 't x y p', got {first}"
                )
            if has_header:
                table = np.loadtxt(f, ndmin=2, dtype=np.float64)
            else:
                f.seek(0)
                table = np.loadtxt(f, ndmin=2, dtype=np.float64)
    except (EOFError, OSError, gzip.BadGzipFile) as err:
        raise ValueError(f"{path}: corrupted or truncated text file ({err})") from err
    except ValueError as err:
        raise ValueError(f"{path}: cannot parse as 't x y p' lines ({err})") from err
    if table.size == 0:
        table = np.zeros((0, 4))
    if table.shape[1] != 4:
        raise ValueError(f"{path}: expected 4 columns 't x y p', found {table.shape[1]}")
    t_s, x, y, p = table.T
    events = make_events(x, y, np.round(t_s * 1e6), p)
    if has_header:
        sensor_size = (int(first[0]), int(first[1]))
    else:  # headerless ESIM output: the smallest sensor holding every event
        sensor_size = (int(x.max()) + 1, int(y.max()) + 1) if len(x) else (1, 1)
    return events, sensor_size


# --- HDF5 --------------------------------------------------------------------------------


def _write_hdf5(path: Path, events: np.ndarray, sensor_size: tuple[int, int]) -> None:
    import h5py

    with h5py.File(path, "w") as f:
        group = f.create_group("events")
        for name in ("x", "y", "t", "p"):
            group.create_dataset(name, data=events[name], compression="gzip", compression_opts=4)
        group.attrs["width"], group.attrs["height"] = sensor_size
        group.attrs["t_unit"] = "us"


def _time_scale(attrs, t: np.ndarray) -> float:
    """Microseconds per stored time unit: the ``t_unit`` attribute, else floats are seconds."""
    unit = attrs.get("t_unit")
    if isinstance(unit, bytes):
        unit = unit.decode()
    if unit is not None:
        if unit not in _TIME_SCALE_TO_US:
            raise ValueError(f"unknown t_unit {unit!r}; expected one of {list(_TIME_SCALE_TO_US)}")
        return _TIME_SCALE_TO_US[unit]
    return 1e6 if np.issubdtype(t.dtype, np.floating) else 1.0


def _read_hdf5(path: Path) -> tuple[np.ndarray, tuple[int, int]]:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            node = f.get("events")
            if isinstance(node, h5py.Group):  # e2vlib and DSEC: events/{x,y,t,p}
                missing = {"x", "y", "t", "p"} - set(node.keys())
                if missing:
                    raise ValueError(f"{path}: group 'events' lacks datasets {sorted(missing)}")
                x, y, t, p = (node[k][()] for k in ("x", "y", "t", "p"))
                attrs = {**dict(f.attrs), **dict(node.attrs)}
                scale = _time_scale(attrs, t)
                if "t_offset" in f:  # DSEC stores times relative to t_offset (us)
                    t = t.astype(np.int64) + int(f["t_offset"][()])
            elif isinstance(node, h5py.Dataset) and node.ndim == 2 and node.shape[1] == 4:
                table = node[()]  # v2e: rows of (t, x, y, p)
                t, x, y, p = table.T
                attrs = {**dict(f.attrs), **dict(node.attrs)}
                scale = _time_scale(attrs, t)
            else:
                raise ValueError(
                    f"{path}: no events found; expected a group 'events' with x, y, t, p "
                    "datasets or an (N, 4) dataset 'events' of t, x, y, p"
                )
    except OSError as err:
        raise ValueError(f"{path}: corrupted or truncated HDF5 file ({err})") from err
    t_us = np.round(t * scale) if scale != 1.0 else t
    events = make_events(x, y, t_us, p)
    width = attrs.get("width", attrs.get("sensor_width"))
    height = attrs.get("height", attrs.get("sensor_height"))
    if width is None or height is None:
        width = int(events["x"].max()) + 1 if len(events) else 1
        height = int(events["y"].max()) + 1 if len(events) else 1
    return events, (int(width), int(height))


# --- AEDAT4 ------------------------------------------------------------------------------


def _read_aedat4(path: Path) -> tuple[np.ndarray, tuple[int, int]]:
    import aedat

    try:
        decoder = aedat.Decoder(str(path))
        streams = decoder.id_to_stream()
        event_streams = {i: s for i, s in streams.items() if s.get("type") == "events"}
        if not event_streams:
            raise ValueError(f"{path}: the AEDAT4 file holds no event stream")
        stream_id = min(event_streams)
        sensor_size = (int(event_streams[stream_id]["width"]),
                       int(event_streams[stream_id]["height"]))
        chunks = [packet["events"] for packet in decoder
                  if packet.get("stream_id") == stream_id and "events" in packet]
    except (RuntimeError, OSError) as err:
        raise ValueError(f"{path}: corrupted or truncated AEDAT4 file ({err})") from err
    if not chunks:
        return make_events([], [], [], []), sensor_size
    raw = np.concatenate(chunks)
    return make_events(raw["x"], raw["y"], raw["t"].astype(np.int64), raw["on"]), sensor_size
