"""Read and write event files, converting every foreign convention at the door.

Supported formats (chosen by the file name's ending):

=================  ======  ======  =========================================================
ending             read    write   layout
=================  ======  ======  =========================================================
``.npz``           yes     yes     e2vlib's own: arrays ``x y t p`` + ``sensor_size``
``.txt``/``.txt.gz`` yes   yes     rpg/ESIM text: ``width height`` line, then ``t x y p`` with
                                   t in seconds (exact to the microsecond) and p in 0/1
``.h5``/``.hdf5``  yes     yes     ``events/{x,y,t,p}`` (+ width/height attributes); also
                                   v2e's ``events`` (N, 4) table and DSEC's ``t_offset``
                                   (added after ``t`` is scaled to microseconds)
``.aedat4``        yes     no      iniVation DAVIS/DVXplorer files, through ``aedat``
=================  ======  ======  =========================================================

Whatever the file, :func:`load_events` returns events of ``EVENT_DTYPE``: integer
microseconds, polarity -1/+1, sorted by time, checked against the sensor size. Times are
converted exactly where the file allows it (integers, and text seconds digit by digit).
HDF5 times are in the ``t_unit`` attribute's unit (``s``, ``ms``, ``us``, ``ns``), else
seconds for floats and microseconds for integers; the same rule, applied to its own dtype
and attribute, gives the unit of DSEC's ``t_offset``. A time outside int64 microseconds
raises :class:`~e2vlib.events.EventError` instead of wrapping around. A file whose content
is another format than its name says (an HDF5 file named ``.npz``) is reported as such.

Introduced in notebooks/01_events.ipynb.
"""

from __future__ import annotations

import gzip
import os
import warnings
import zipfile
from decimal import ROUND_HALF_EVEN, Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from e2vlib.events import (
    INT64_MAX,
    INT64_MIN,
    MAX_SENSOR_SIDE,
    TIME_RANGE,
    TIME_UNITS,
    EventError,
    add_time_offset,
    check_sensor_size,
    make_events,
    sort_events,
    times_to_us,
    validate,
)
from e2vlib.files import atomic_path, input_file

FORMATS = (".npz", ".txt", ".txt.gz", ".h5", ".hdf5", ".aedat4")

# First bytes of each format: (magic, kind). "text" and "empty" are decided separately.
_MAGIC = (
    (b"\x89HDF\r\n\x1a\n", "hdf5"),
    (b"PK\x03\x04", "npz"),
    (b"PK\x05\x06", "npz"),  # an empty zip archive
    (b"\x93NUMPY", "npy"),
    (b"\x1f\x8b", "gzip"),
    (b"#!AER-DAT4", "aedat4"),
)
_KIND_OF_FORMAT = {".npz": "npz", ".txt": "text", ".txt.gz": "gzip", ".h5": "hdf5",
                   ".hdf5": "hdf5", ".aedat4": "aedat4"}
_WHAT_KIND_IS = {
    "hdf5": "this is an HDF5 file; rename it .h5",
    "npz": "this is a zip (.npz) archive; rename it .npz",
    "npy": "this is a single .npy array, not an event file; build events with "
           "e2vlib.events.make_events and write them with save_events",
    "gzip": "this is a gzip file; if it holds 't x y p' text lines rename it .txt.gz",
    "aedat4": "this is an AEDAT4 recording; rename it .aedat4",
    "text": "this is a text file; if it holds 't x y p' lines rename it .txt",
}

EXACT_TEXT_SECONDS = 2.0**50 / 1e6
"""Text times below this many seconds (about 35 years) are exact through float64; larger
ones are re-read digit by digit (:func:`_decimal_seconds_to_us`)."""


MAX_EVENT_BYTES: int = 4 * 2**30
"""Most bytes (4 GiB) the event columns of one file (x, y, t, p, or v2e's table) may
declare: about 300 million events as e2vlib writes them (13 bytes each), three times the
100 million that load in about 3 GiB. The declared shapes and dtypes are checked before
anything is read, so a few MB of compressed zeros cannot ask for gigabytes."""

MAX_TEXT_EVENTS: int = 100_000_000
"""Most event lines a text file (``.txt``, ``.txt.gz``) may hold: 100 million, which load
in about 3 GiB. Reading stops one line past it, so a gzip of a few MB that unpacks to
gigabytes of lines cannot fill the memory."""

_COLUMNS = ("x", "y", "t", "p")


def _check_declared(path: Path, declared: dict[str, tuple]) -> None:
    """Refuse columns (name -> declared shape, dtype) that are not plain numbers or that
    together take more than :data:`MAX_EVENT_BYTES`, before they are read."""
    total = 0.0
    for name, (shape, dtype, *_) in declared.items():
        if dtype.kind not in "biuf" or dtype.fields is not None or dtype.subdtype is not None:
            raise ValueError(f"{path}: the array {name!r} holds {dtype}, not plain numbers; "
                             "write the file again with e2vlib.io.save_events")
        total += float(np.prod(shape, dtype=np.float64)) * dtype.itemsize
    if total > MAX_EVENT_BYTES:
        raise ValueError(f"{path}: the event arrays declare {total / 2**30:.3g} GiB "
                         f"({', '.join(f'{k} {list(v[0])}' for k, v in declared.items())}), "
                         f"more than io.MAX_EVENT_BYTES = {MAX_EVENT_BYTES / 2**30:.0f} GiB "
                         "(about 300 M events); split the recording into shorter files")


def _npz_headers(path: Path, names: tuple[str, ...]) -> dict[str, tuple]:
    """Declared ``(shape, dtype, held)`` of the ``.npy`` members ``names`` of a zip, read
    from their headers only (``held``: the bytes of data the member holds after its header;
    members that are missing are left out: the reader reports them)."""
    fmt = np.lib.format
    headers = {}
    with zipfile.ZipFile(path) as archive:
        present = set(archive.namelist())
        for name in names:
            if f"{name}.npy" not in present:
                continue
            with archive.open(f"{name}.npy") as member:
                version = fmt.read_magic(member)
                read = {(1, 0): fmt.read_array_header_1_0,
                        (2, 0): fmt.read_array_header_2_0}.get(version)
                if read is None:
                    raise ValueError(f"{path}: the array {name!r} is in .npy format version "
                                     f"{version}, which e2vlib does not read; write the file "
                                     "again with e2vlib.io.save_events")
                shape, _, dtype = read(member)
                held = archive.getinfo(f"{name}.npy").file_size - member.tell()
            headers[name] = (tuple(shape), np.dtype(dtype), held)
    return headers


def _check_held(path: Path, declared: dict[str, tuple]) -> None:
    """Refuse a member holding fewer bytes than its header declares: the file is truncated
    (or its header altered), which reading would only find at the end."""
    for name, (shape, dtype, held) in declared.items():
        needed = float(np.prod(shape, dtype=np.float64)) * dtype.itemsize
        if needed > held:
            raise ValueError(f"{path}: truncated: the array {name!r} declares {list(shape)} "
                             f"values of {dtype} ({needed:.0f} bytes) but holds {held} bytes; "
                             "the file was cut short or altered: copy it again, or write it "
                             "with e2vlib.io.save_events")


def _format_of(path: Path) -> str:
    name = path.name.lower()
    for ending in sorted(FORMATS, key=len, reverse=True):
        if name.endswith(ending):
            return ending
    raise ValueError(
        f"{path}: unknown event file type; use one of {', '.join(FORMATS)} "
        "(convert other formats to .npz or .h5 first)"
    )


def sniff_format(path: str | os.PathLike) -> str | None:
    r"""What a file's first bytes say it is: ``"hdf5"``, ``"npz"`` (zip), ``"npy"``,
    ``"gzip"``, ``"aedat4"``, ``"text"``, ``"empty"``, or None (other binary data).

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "events.npz"
    >>> _ = path.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(8))
    >>> sniff_format(path)
    'hdf5'
    """
    with open(path, "rb") as f:
        head = f.read(64)
    if not head:
        return "empty"
    for magic, kind in _MAGIC:
        if head.startswith(magic):
            return kind
    body = head[3:] if head.startswith(b"\xef\xbb\xbf") else head  # UTF-8 byte order mark
    if all(b >= 0x20 or b in b"\t\n\r\f" for b in body):  # no control bytes (bytes >= 0x80: UTF-8)
        return "text"
    return None


def _check_content(path: Path, fmt: str) -> None:
    """Raise a ValueError when the file's first bytes show another format than ``fmt``."""
    kind, expected = sniff_format(path), _KIND_OF_FORMAT[fmt]
    if kind == expected:
        return
    if kind == "empty":
        raise ValueError(f"{path}: the file is empty (0 bytes); write it again "
                         "(e2vlib.io.save_events) or copy it again")
    if expected == "gzip" and kind == "text":
        raise ValueError(f"{path}: this is plain text, not gzip-compressed; rename it .txt")
    if kind in _WHAT_KIND_IS:
        raise ValueError(f"{path}: {_WHAT_KIND_IS[kind]}")
    if expected == "text":
        raise ValueError(f"{path}: not a text event file (binary data); give rpg/ESIM text "
                         "lines 't x y p' or use the file's own ending")
    # Unknown binary data where a binary format was expected: the reader reports it.


def load_events(path: str | os.PathLike) -> tuple[np.ndarray, tuple[int, int]]:
    """Load an event file; return ``(events, sensor_size)`` with ``sensor_size=(W, H)``.

    Times come back as int64 microseconds, polarity as -1/+1, sorted by time (stable).
    Missing files raise FileNotFoundError, a directory IsADirectoryError; a file that is
    another format than its ending says, truncated or corrupted raises ValueError naming
    the file (and the line, for text); times outside int64 microseconds raise EventError.
    Introduced in notebooks/01_events.ipynb.

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
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a directory, not an event file; give a file "
                                f"inside it ({', '.join(FORMATS)})")
    input_file(path, "event file")
    _check_content(path, fmt)
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
    destroys an existing one. Every format keeps every valid event exactly (text writes
    seconds with six decimals from the integer microseconds). Introduced in
    notebooks/01_events.ipynb.
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


def _sensor_size(path: Path, where: str, values) -> tuple[int, int]:
    """A stored sensor size as ``(width, height)`` ints; whole positive numbers only."""
    values = np.asarray(values).reshape(-1)
    ok = (values.size == 2 and np.issubdtype(values.dtype, np.number)
          and values.dtype != bool and bool(np.all(np.isfinite(values)))
          and bool(np.all(values == np.round(values))) and bool(np.all(values >= 1)))
    if not ok or np.max(values) > MAX_SENSOR_SIDE:
        raise ValueError(f"{path}: {where} must be the sensor size (width, height) in whole "
                         f"positive pixels of at most {MAX_SENSOR_SIDE} (x and y are uint16), "
                         f"got {values.tolist()}; write it again with "
                         "save_events(path, events, (width, height))")
    return int(values[0]), int(values[1])


# --- .npz (native) -----------------------------------------------------------------------


def _write_npz(path: Path, events: np.ndarray, sensor_size: tuple[int, int]) -> None:
    with open(path, "wb") as f:
        np.savez_compressed(
            f, x=events["x"], y=events["y"], t=events["t"], p=events["p"],
            sensor_size=np.asarray(sensor_size, dtype=np.int64),
        )


def _read_npz(path: Path) -> tuple[np.ndarray, tuple[int, int]]:
    try:
        declared = _npz_headers(path, (*_COLUMNS, "sensor_size"))
        size = declared.pop("sensor_size", ((2,), np.dtype(np.int64), 16))
        _check_declared(path, declared)
        if np.prod(size[0], dtype=np.float64) > 16:
            raise ValueError(f"{path}: the array sensor_size has shape {list(size[0])}, not "
                             "(2,); write it again with save_events(path, events, "
                             "(width, height))")
        _check_held(path, {**declared, "sensor_size": size})
        with np.load(path, allow_pickle=False) as data:
            missing = {"x", "y", "t", "p", "sensor_size"} - set(data.files)
            if missing:
                raise ValueError(
                    f"{path}: not an e2vlib event file, missing arrays {sorted(missing)} "
                    "(expected x, y, t, p, sensor_size)"
                )
            columns = [data[k] for k in ("x", "y", "t", "p")]
            sensor_size = _sensor_size(path, "the array sensor_size", data["sensor_size"])
    except (zipfile.BadZipFile, EOFError, OSError) as err:
        if not _starts_as_zip(path):
            raise _not_npz(path) from err
        raise ValueError(f"{path}: corrupted or truncated .npz file ({err})") from err
    except ValueError as err:
        if str(err).startswith(f"{path}"):
            raise
        raise _not_npz(path) from err  # np.load calls a non-zip "pickled"; never unpickled
    return make_events(*columns), sensor_size


def _starts_as_zip(path: Path) -> bool:
    with open(path, "rb") as f:
        return f.read(2) == b"PK"


def _not_npz(path: Path) -> ValueError:
    return ValueError(f"{path}: not an .npz event file (neither a zip of x, y, t, p, "
                      "sensor_size arrays nor anything e2vlib reads; it was not unpickled): "
                      "write it again with e2vlib.io.save_events")


# --- rpg / ESIM text ---------------------------------------------------------------------

_TEXT_CHUNK = 1 << 16  # lines formatted per write


def _open_text(path: Path, mode: str):
    """Open a ``.txt``/``.txt.gz`` file as text; reading skips a UTF-8 byte order mark."""
    encoding = "utf-8-sig" if mode == "rt" else "utf-8"
    if path.name.lower().endswith(".gz"):
        return gzip.open(path, mode, encoding=encoding)
    return open(path, mode, encoding=encoding)


def _write_text(path: Path, events: np.ndarray, sensor_size: tuple[int, int]) -> None:
    with _open_text(path, "wt") as f:
        f.write(f"{sensor_size[0]} {sensor_size[1]}\n")
        for start in range(0, len(events), _TEXT_CHUNK):
            block = events[start:start + _TEXT_CHUNK]
            t = block["t"]
            negative = t < 0
            # |t| exactly, also for the most negative int64 (-(t + 1) + 1 in uint64)
            magnitude = np.where(negative, (-(t + 1)).astype(np.uint64) + np.uint64(1),
                                 t.astype(np.uint64))
            seconds, micro = np.divmod(magnitude, np.uint64(1_000_000))
            f.write("".join(
                f"{'-' if neg else ''}{sec}.{us:06d} {x} {y} {p}\n"
                for neg, sec, us, x, y, p in zip(
                    negative.tolist(), seconds.tolist(), micro.tolist(), block["x"].tolist(),
                    block["y"].tolist(), (block["p"] > 0).astype(np.int8).tolist(), strict=True)))


def _content_line(line: str) -> str:
    """A text line without its ``#`` comment and surrounding white space."""
    return line.split("#", 1)[0].strip()


def _parse_header(path: Path, lineno: int, text: str) -> tuple[int, int]:
    fix = ("the first line must be the sensor size 'width height' in whole pixels "
           "(e.g. '346 260' for a DAVIS346)")
    try:
        width, height = (int(v) for v in text.split())
    except ValueError:
        raise ValueError(f"{path}, line {lineno}: {fix}, got {text!r}; write the sensor's "
                         "width and height there") from None
    if width <= 0 or height <= 0:
        raise ValueError(f"{path}, line {lineno}: {fix}, got {text!r}; both must be positive")
    if max(width, height) > MAX_SENSOR_SIDE:
        raise ValueError(f"{path}, line {lineno}: {fix}, got {text!r}; events store x and y "
                         f"as uint16, so a side is at most {MAX_SENSOR_SIDE} px")
    return width, height


def _find_bad_line(path: Path, skip: int) -> str:
    """Locate the first data line (after ``skip`` lines) that is not 4 numbers 't x y p'."""
    with _open_text(path, "rt") as f:
        for lineno, line in enumerate(f, start=1):
            text = _content_line(line)
            if lineno <= skip or not text:
                continue
            values = text.split()
            try:
                [float(v) for v in values]
            except ValueError:
                return f"line {lineno}: expected 4 numbers 't x y p', got {text!r}"
            if len(values) != 4:
                return (f"line {lineno}: expected 4 columns 't x y p', found {len(values)} "
                        f"in {text!r}")
    return ""


def _read_text(path: Path) -> tuple[np.ndarray, tuple[int, int]]:
    header, skip = None, 0
    try:
        with _open_text(path, "rt") as f:
            while True:  # leading blank and comment lines, then the header or an event
                line = f.readline()
                if not line:
                    break
                skip += 1
                text = _content_line(line)
                if not text:
                    continue
                n_values = len(text.split())
                if n_values == 2:
                    header = _parse_header(path, skip, text)
                elif n_values == 4:
                    f.seek(0)
                    skip = 0
                else:
                    raise ValueError(
                        f"{path}, line {skip}: expected the sensor size 'width height' "
                        f"(e.g. '346 260') or an event 't x y p', got {n_values} values "
                        f"{text!r}")
                break
            if header is None and skip:
                raise ValueError(f"{path}: no header and no events, only comments or blank "
                                 "lines; start the file with 'width height'")
            if header is None and not skip and not line:
                raise ValueError(f"{path}: the file is empty; start it with 'width height'")
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", "loadtxt: input contained no data")
                warnings.filterwarnings("ignore", "Input line .* contained no data")  # max_rows
                table = np.loadtxt(f, ndmin=2, dtype=np.float64,
                                   max_rows=MAX_TEXT_EVENTS + 1)
            if len(table) > MAX_TEXT_EVENTS:
                raise ValueError(f"{path}: more than io.MAX_TEXT_EVENTS = {MAX_TEXT_EVENTS} "
                                 "event lines; split the recording into shorter files (or "
                                 "save it as .npz or .h5)")
    except (EOFError, OSError, gzip.BadGzipFile) as err:
        raise ValueError(f"{path}: corrupted or truncated text file ({err})") from err
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not UTF-8 text ({err}); give rpg/ESIM text lines "
                         "'t x y p'") from err
    except ValueError as err:
        if str(err).startswith(str(path)):
            raise
        where = _find_bad_line(path, skip)
        raise ValueError(f"{path}, {where}" if where else
                         f"{path}: cannot parse as 't x y p' lines ({err})") from err
    if table.size == 0:
        table = np.zeros((0, 4))
    if table.shape[1] != 4:
        raise ValueError(f"{path}: expected 4 columns 't x y p', found {table.shape[1]}")
    t_s, x, y, p = table.T
    events = make_events(x, y, _text_times_us(path, t_s, skip), p)
    if header is not None:
        sensor_size = header
    else:  # headerless ESIM output: the smallest sensor holding every event
        sensor_size = (int(x.max()) + 1, int(y.max()) + 1) if len(x) else (1, 1)
    return events, sensor_size


def _text_times_us(path: Path, t_s: np.ndarray, skip: int) -> np.ndarray:
    """Text times in seconds -> int64 microseconds, exact to the microsecond.

    Times below :data:`EXACT_TEXT_SECONDS` go through float64 exactly; larger ones are
    read again as written and converted digit by digit.
    """
    big = ~(np.abs(t_s) < EXACT_TEXT_SECONDS)  # also NaN/inf: times_to_us reports them
    if not big.any() or not np.all(np.isfinite(t_s)):
        return times_to_us(t_s, "s")
    with _open_text(path, "rt") as f:
        for _ in range(skip):
            f.readline()
        words = np.loadtxt(f, ndmin=1, dtype=str, usecols=0)
    t_us = np.zeros(len(t_s), dtype=np.int64)
    t_us[~big] = times_to_us(t_s[~big], "s")
    exact = [_decimal_seconds_to_us(str(w)) for w in words[big]]
    bad = [w for w, v in zip(words[big], exact, strict=True) if not INT64_MIN <= v <= INT64_MAX]
    if bad:
        raise EventError(f"t: {len(bad)} values outside {TIME_RANGE} (first: {bad[0]} s); "
                         "store times relative to the start of the recording")
    t_us[big] = exact
    return t_us


def _decimal_seconds_to_us(word: str) -> int:
    """``"9223372036854.775807"`` (seconds) -> 9223372036854775807 (us), rounded half to even."""
    try:
        return int(Decimal(word).scaleb(6).to_integral_value(rounding=ROUND_HALF_EVEN))
    except (InvalidOperation, ValueError, OverflowError) as err:
        raise EventError(f"t: cannot read {word!r} as seconds") from err


# --- HDF5 --------------------------------------------------------------------------------


def _write_hdf5(path: Path, events: np.ndarray, sensor_size: tuple[int, int]) -> None:
    import h5py

    with h5py.File(path, "w") as f:
        group = f.create_group("events")
        for name in ("x", "y", "t", "p"):
            group.create_dataset(name, data=events[name], compression="gzip", compression_opts=4)
        group.attrs["width"], group.attrs["height"] = sensor_size
        group.attrs["t_unit"] = "us"


def _time_unit(attrs, t: np.ndarray) -> str:
    """Unit of stored times: the ``t_unit`` attribute, else seconds for floats, else us."""
    unit = attrs.get("t_unit")
    if isinstance(unit, bytes):
        unit = unit.decode()
    if unit is not None:
        if unit not in TIME_UNITS:
            raise ValueError(f"unknown t_unit {unit!r}; expected one of {list(TIME_UNITS)}")
        return str(unit)
    return "s" if np.issubdtype(np.asarray(t).dtype, np.floating) else "us"


def _read_offset_us(node) -> int:
    """DSEC's ``t_offset`` in microseconds: its own ``t_unit`` attribute, else seconds for a
    float and microseconds for an integer (DSEC stores int64 microseconds)."""
    if getattr(node, "size", 1) != 1:  # checked before reading: it could declare gigabytes
        raise ValueError(f"t_offset must be a single number, got shape {node.shape}")
    value = np.asarray(node[()])
    if value.size != 1:
        raise ValueError(f"t_offset must be a single number, got shape {value.shape}")
    return int(times_to_us(value.reshape(1), _time_unit(node.attrs, value), "t_offset")[0])


def _read_hdf5(path: Path) -> tuple[np.ndarray, tuple[int, int]]:
    """Read e2vlib/DSEC ``events/{x,y,t,p}`` or v2e's ``(N, 4)`` table.

    Times are scaled to microseconds before anything is added to them: ``t`` by its unit
    (:func:`_time_unit`), then DSEC's ``t_offset`` (:func:`_read_offset_us`), with every
    step checked against int64 overflow.
    """
    import h5py

    offset_us = 0
    try:
        with h5py.File(path, "r") as f:
            node = f.get("events")
            if isinstance(node, h5py.Group):  # e2vlib and DSEC: events/{x,y,t,p}
                missing = {"x", "y", "t", "p"} - set(node.keys())
                if missing:
                    raise ValueError(f"{path}: group 'events' lacks datasets {sorted(missing)}")
                columns = {k: node[k] for k in _COLUMNS}
                not_arrays = [k for k, v in columns.items() if not isinstance(v, h5py.Dataset)]
                if not_arrays:
                    raise ValueError(f"{path}: events/{not_arrays[0]} is a group, not a "
                                     "dataset of numbers")
                _check_declared(path, {f"events/{k}": (v.shape, v.dtype)
                                       for k, v in columns.items()})
                x, y, t, p = (columns[k][()] for k in _COLUMNS)
                attrs = {**dict(f.attrs), **dict(node.attrs)}
                if "t_offset" in f:  # DSEC stores times relative to t_offset
                    offset_us = _read_offset_us(f["t_offset"])
            elif isinstance(node, h5py.Dataset) and node.ndim == 2 and node.shape[1] == 4:
                _check_declared(path, {"events": (node.shape, node.dtype)})
                table = node[()]  # v2e: rows of (t, x, y, p)
                t, x, y, p = table.T
                attrs = {**dict(f.attrs), **dict(node.attrs)}
            else:
                raise ValueError(
                    f"{path}: no events found; expected a group 'events' with x, y, t, p "
                    "datasets or an (N, 4) dataset 'events' of t, x, y, p"
                )
    except OSError as err:
        raise ValueError(f"{path}: corrupted or truncated HDF5 file ({err})") from err
    except ValueError as err:
        if str(err).startswith(str(path)):
            raise
        raise ValueError(f"{path}: {err}") from err
    try:
        unit = _time_unit(attrs, t)
    except ValueError as err:
        raise ValueError(f"{path}: {err} (the t_unit attribute of the events); fix the "
                         "attribute or write the file again with e2vlib.io.save_events") from None
    t_us = add_time_offset(times_to_us(t, unit), offset_us)
    events = make_events(x, y, t_us, p)
    width = attrs.get("width", attrs.get("sensor_width"))
    height = attrs.get("height", attrs.get("sensor_height"))
    if width is None or height is None:
        width = int(events["x"].max()) + 1 if len(events) else 1
        height = int(events["y"].max()) + 1 if len(events) else 1
    return events, _sensor_size(path, "the width/height attributes", (width, height))


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
    return make_events(raw["x"], raw["y"], times_to_us(raw["t"], "us"), raw["on"]), sensor_size
