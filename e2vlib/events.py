"""Event streams as numpy structured arrays, and their validation.

An event is ``(x, y, t, p)``: pixel column ``x`` and row ``y`` (uint16), time ``t`` in
integer **microseconds** (int64) and polarity ``p`` in ``{-1, +1}`` (int8). A stream is a
1-D structured array of :data:`EVENT_DTYPE` sorted by ``t``; the sensor size is
``(width, height)``.

Times never wrap around: :func:`make_events` refuses times outside :data:`TIME_RANGE`,
:func:`times_to_us` converts seconds/milliseconds/nanoseconds to microseconds exactly (in
integers) or in float64, and :func:`add_time_offset` adds an offset with an overflow check;
readers (:mod:`e2vlib.io`) use them for every file format.

Introduced in notebooks/01_events.ipynb.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

EVENT_DTYPE = np.dtype([("x", np.uint16), ("y", np.uint16), ("t", np.int64), ("p", np.int8)])
"""Structured dtype of one event: x, y (uint16), t (int64 microseconds), p (int8, -1/+1)."""


class EventError(ValueError):
    """An event stream breaks the conventions (order, range, polarity, dtype)."""


def _as_polarity(p: np.ndarray) -> np.ndarray:
    """Map polarity given as -1/+1, 0/1 or bool to int8 -1/+1; raise on anything else."""
    p = np.asarray(p)
    if p.dtype == bool:
        return np.where(p, 1, -1).astype(np.int8)
    if p.size == 0:
        return p.astype(np.int8)
    if not np.issubdtype(p.dtype, np.number):
        raise EventError(f"polarity must be numeric or bool, got dtype {p.dtype}")
    if np.issubdtype(p.dtype, np.floating) and not np.all(np.isfinite(p)):
        raise EventError(f"polarity has {int(np.sum(~np.isfinite(p)))} NaN/inf values")
    values = np.unique(p)
    if np.all(np.isin(values, (-1, 1))):
        return p.astype(np.int8)
    if np.all(np.isin(values, (0, 1))):
        return np.where(p > 0, 1, -1).astype(np.int8)
    bad = ~np.isin(p, (-1, 0, 1))
    raise EventError(
        f"polarity must be -1/+1, 0/1 or bool; {int(bad.sum()) or 'some'} events have other "
        f"values (seen: {values[:8].tolist()}). Map them to -1 (OFF) / +1 (ON) first."
    )


INT64_MIN, INT64_MAX = int(np.iinfo(np.int64).min), int(np.iinfo(np.int64).max)
"""Range of event times: int64 microseconds, about +-292,000 years around 0."""

TIME_RANGE = f"the int64 microsecond range [{INT64_MIN}, {INT64_MAX}] (about +-292,000 years)"
"""How error messages name the range of :data:`EVENT_DTYPE` times."""

_TIME_FIX = "store times relative to the start of the recording"


def _check_int_range(name: str, a: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Check that ``a`` holds whole numbers in ``[lo, hi]``; return it (not yet cast).

    Floats are compared against ``hi + 1`` (exclusive) so that a float that rounds to
    ``2**63`` is caught before a cast to int64 could wrap it around.
    """
    a = np.asarray(a)
    if a.size and np.issubdtype(a.dtype, np.floating):
        if not np.all(np.isfinite(a)):
            raise EventError(f"{name} has {int(np.sum(~np.isfinite(a)))} NaN/inf values")
        if not np.all(a == np.round(a)):
            raise EventError(f"{name} must hold whole numbers; round or convert units first")
        bad = (a < lo) | (a >= hi + 1)  # hi + 1 is exact in float64 for int64 and uint16
    elif a.size and not np.issubdtype(a.dtype, np.integer):
        raise EventError(f"{name} must be integer, got dtype {a.dtype}")
    else:
        bad = (a < lo) | (a > hi) if a.size else np.zeros(0, bool)
    if bad.any():
        first = a[np.flatnonzero(bad)[0]].item()
        what = TIME_RANGE if name == "t" else f"[{lo}, {hi}]"
        fix = f"; {_TIME_FIX}" if name == "t" else ""
        unit = " us" if name == "t" else ""
        raise EventError(f"{name}: {int(bad.sum())} values outside {what} (first: "
                         f"{first!r}{unit}){fix}")
    return a


_US_PER = {"s": 10**6, "ms": 10**3, "us": 1}
TIME_UNITS = ("s", "ms", "us", "ns")
"""Time units :func:`times_to_us` converts from."""


def times_to_us(t: ArrayLike, unit: str = "us", name: str = "t") -> np.ndarray:
    """Times in ``unit`` (``"s"``, ``"ms"``, ``"us"``, ``"ns"``) as int64 microseconds.

    Integers are converted exactly (``ns`` rounded to the nearest microsecond, halves to
    even); floats are scaled in float64 and rounded (``np.rint``). A result outside
    :data:`TIME_RANGE` raises :class:`EventError` naming the range instead of wrapping
    around, as do NaN/inf and non-numeric times. ``name`` names the times in messages.

    Examples
    --------
    >>> times_to_us([0.5, 1.25], "s").tolist()
    [500000, 1250000]
    >>> times_to_us(np.array([1499, 1500, 2500], np.int64), "ns").tolist()
    [1, 2, 2]
    >>> times_to_us([2.0**63], "us")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.events.EventError: t: 1 values outside the int64 microsecond range [...] ...
    """
    if unit not in TIME_UNITS:
        raise ValueError(f"unknown time unit {unit!r}; expected one of {TIME_UNITS}")
    a = np.atleast_1d(np.asarray(t))
    if a.dtype == bool or not np.issubdtype(a.dtype, np.number) or np.iscomplexobj(a):
        raise EventError(f"{name} must be numeric times, got dtype {a.dtype}")
    if a.size == 0:
        return a.astype(np.int64)
    if np.issubdtype(a.dtype, np.floating):
        a = a.astype(np.float64)
        if not np.all(np.isfinite(a)):
            raise EventError(f"{name} has {int(np.sum(~np.isfinite(a)))} NaN/inf values")
        us = np.rint(a / 1000.0 if unit == "ns" else a * _US_PER[unit])
        bad = (us < INT64_MIN) | (us >= INT64_MAX + 1)  # both bounds exact in float64
        if bad.any():
            _out_of_range(name, a, bad, unit)
        return us.astype(np.int64)
    if unit == "ns":
        if a.dtype == np.uint64:
            q, r = np.divmod(a, np.uint64(1000))
            q, r = q.astype(np.int64), r.astype(np.int64)  # q < 2**64 / 1000 fits
        else:
            q, r = np.divmod(a.astype(np.int64), 1000)
        return q + (r > 500) + ((r == 500) & (q % 2 == 1))
    factor = _US_PER[unit]
    bad = (a > INT64_MAX // factor) | (a < -(-INT64_MIN // factor))
    if bad.any():
        _out_of_range(name, a, bad, unit)
    return a.astype(np.int64) * factor


def _out_of_range(name: str, a: np.ndarray, bad: np.ndarray, unit: str) -> None:
    first = a[np.flatnonzero(bad)[0]].item()
    raise EventError(
        f"{name}: {int(bad.sum())} values outside {TIME_RANGE} (first: {first!r} {unit}); "
        f"{_TIME_FIX}")


def add_time_offset(t_us: np.ndarray, offset_us: int, name: str = "t") -> np.ndarray:
    """``t_us + offset_us`` (int64 microseconds), refusing results outside :data:`TIME_RANGE`.

    Examples
    --------
    >>> add_time_offset(np.array([0, 10]), 1_000_000).tolist()
    [1000000, 1000010]
    >>> add_time_offset(np.array([0, 10]), 2**63 - 1)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.events.EventError: t + offset 9223372036854775807 us: 1 values outside the int64 ...
    """
    offset = int(offset_us)
    t = np.asarray(t_us, dtype=np.int64)
    if not INT64_MIN <= offset <= INT64_MAX:
        raise EventError(f"time offset {offset} us lies outside {TIME_RANGE}; {_TIME_FIX}")
    if offset == 0 or t.size == 0:
        return t.copy()
    bad = t > INT64_MAX - offset if offset > 0 else t < INT64_MIN - offset
    if bad.any():
        first = t[np.flatnonzero(bad)[0]].item()
        raise EventError(
            f"{name} + offset {offset} us: {int(bad.sum())} values outside {TIME_RANGE} "
            f"(first: {first} us + offset); {_TIME_FIX}")
    return t + offset


def make_events(x: ArrayLike, y: ArrayLike, t: ArrayLike, p: ArrayLike) -> np.ndarray:
    """Build an event array of :data:`EVENT_DTYPE` from four equal-length columns.

    ``t`` is in microseconds (integers, or floats holding whole numbers) within
    :data:`TIME_RANGE` (values outside raise instead of wrapping around); ``p`` may be
    -1/+1, 0/1 or bool. The events are **not** reordered: call :func:`validate` or sort
    by ``t`` yourself. Raises :class:`EventError` on mismatched lengths or bad values.

    Examples
    --------
    >>> ev = make_events(x=[3, 0], y=[1, 2], t=[10, 25], p=[1, 0])   # p 0/1 becomes -1/+1
    >>> ev["t"].tolist(), ev["p"].tolist()
    ([10, 25], [1, -1])
    >>> make_events([0], [0], [1.5], [1])
    Traceback (most recent call last):
    ...
    e2vlib.events.EventError: t must hold whole numbers; round or convert units first
    """
    cols = [np.atleast_1d(np.asarray(c)) for c in (x, y, t, p)]
    lengths = {len(c) for c in cols}
    if len(lengths) != 1 or any(c.ndim != 1 for c in cols):
        raise EventError(
            f"x, y, t, p must be 1-D and of equal length, got shapes {[c.shape for c in cols]}"
        )
    x_, y_, t_, p_ = cols
    out = np.empty(len(x_), dtype=EVENT_DTYPE)
    out["x"] = _check_int_range("x", x_, 0, np.iinfo(np.uint16).max)
    out["y"] = _check_int_range("y", y_, 0, np.iinfo(np.uint16).max)
    out["t"] = _check_int_range("t", t_, INT64_MIN, INT64_MAX)
    out["p"] = _as_polarity(p_)
    return out


CHUNK = 1 << 16
"""Events processed per step by chunked loops: small enough that a chunk's fields stay in
the CPU cache while several checks read them, large enough to keep numpy's overhead low."""


def iter_checked_chunks(events: np.ndarray, sensor_size: tuple[int, int], chunk: int = CHUNK):
    """Yield ``(start, block)`` slices of ``events`` after checking each against the rules.

    This is :func:`validate` done block by block, so functions that read the events anyway
    (like :func:`e2vlib.frames.accumulate`) can check and use each block while it is still
    in the CPU cache. On the first broken block the whole stream is re-checked by
    :func:`validate`, which raises the detailed :class:`EventError`.
    """
    _check_dtype(events)
    width, height = check_sensor_size(sensor_size)
    t = events["t"]
    for start in range(0, len(events), chunk):
        block = events[start:start + chunk]
        bt, p = block["t"], block["p"]
        ok = (
            block["x"].max() < width
            and block["y"].max() < height
            and np.count_nonzero(p * p != 1) == 0  # p is -1 or +1 (int8: no overflow)
            and bool(np.all(bt[1:] >= bt[:-1]))
            and (start == 0 or t[start - 1] <= bt[0])
        )
        if not ok:
            _report(events, (width, height))
        yield start, block


def _check_dtype(events: np.ndarray) -> None:
    if not isinstance(events, np.ndarray) or events.dtype != EVENT_DTYPE:
        got = getattr(events, "dtype", type(events).__name__)
        raise EventError(
            f"events must be a numpy array of e2vlib.events.EVENT_DTYPE, got {got}; "
            "build one with e2vlib.events.make_events(x, y, t, p)"
        )
    if events.ndim != 1:
        raise EventError(f"events must be 1-D, got shape {events.shape}")


def _report(events: np.ndarray, sensor_size: tuple[int, int]) -> None:
    """Check the whole stream at once and raise an EventError counting what is wrong."""
    width, height = sensor_size
    outside = (events["x"] >= width) | (events["y"] >= height)
    if outside.any():
        raise EventError(
            f"{int(outside.sum())} of {len(events)} events lie outside the {width}x{height} "
            "sensor (x must be < width, y < height); check sensor_size=(width, height) "
            "or crop the events"
        )
    bad_p = (events["p"] != 1) & (events["p"] != -1)
    if bad_p.any():
        raise EventError(
            f"{int(bad_p.sum())} events have polarity other than -1/+1; "
            "build events with make_events, which maps 0/1 and bool"
        )
    backwards = np.diff(events["t"]) < 0
    if backwards.any():
        raise EventError(
            f"timestamps are not sorted: {int(backwards.sum())} events are earlier than the "
            "event before them; sort with events[np.argsort(events['t'], kind='stable')]"
        )


def validate(events: np.ndarray, sensor_size: tuple[int, int]) -> np.ndarray:
    """Check that ``events`` follow the conventions; return them unchanged if so.

    Checks: dtype is :data:`EVENT_DTYPE`, ``sensor_size`` is ``(width, height)`` of
    positive ints, every ``x < width`` and ``y < height``, polarity is -1 or +1, and
    timestamps never decrease. Raises :class:`EventError` naming the problem, how many
    events it affects, and the fix. Introduced in notebooks/01_events.ipynb.

    Examples
    --------
    >>> ev = make_events(x=[0, 5], y=[0, 0], t=[0, 1], p=[1, 1])
    >>> len(validate(ev, (8, 4)))
    2
    >>> validate(ev, (4, 4))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.events.EventError: 1 of 2 events lie outside the 4x4 sensor (x must be < width, ...
    """
    for _ in iter_checked_chunks(events, sensor_size):
        pass
    return events


MAX_SENSOR_SIDE = 65536
"""Largest sensor side in px: x and y are uint16 (0..65535)."""


def check_sensor_size(sensor_size: tuple[int, int]) -> tuple[int, int]:
    """Return ``(width, height)`` as ints, raising :class:`EventError` if malformed."""
    try:
        width, height = (int(v) for v in sensor_size)
        whole = all(float(v) == int(v) and not isinstance(v, (bool, np.bool_))
                    for v in sensor_size)
    except (TypeError, ValueError, OverflowError) as err:
        raise EventError(
            f"sensor_size must be (width, height), got {sensor_size!r}"
        ) from err
    if not whole:
        raise EventError(f"sensor_size must be whole pixels (width, height), got "
                         f"{tuple(sensor_size)!r}")
    if width <= 0 or height <= 0:
        raise EventError(f"sensor_size must be positive (width, height), got {sensor_size!r}")
    if max(width, height) > MAX_SENSOR_SIDE:
        raise EventError(f"sensor_size {(width, height)} is larger than events can address: "
                         f"x and y are uint16, so each side is at most {MAX_SENSOR_SIDE} px")
    return width, height


def sort_events(events: np.ndarray) -> np.ndarray:
    """Return a copy sorted by time (stable, so equal timestamps keep their order)."""
    return events[np.argsort(events["t"], kind="stable")]
