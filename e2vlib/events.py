"""Event streams as numpy structured arrays, and their validation.

An event is ``(x, y, t, p)``: pixel column ``x`` and row ``y`` (uint16), time ``t`` in
integer **microseconds** (int64) and polarity ``p`` in ``{-1, +1}`` (int8). A stream is a
1-D structured array of :data:`EVENT_DTYPE` sorted by ``t``; the sensor size is
``(width, height)``.

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


def _check_int_range(name: str, a: np.ndarray, lo: int, hi: int) -> np.ndarray:
    a = np.asarray(a)
    if a.size and np.issubdtype(a.dtype, np.floating):
        if not np.all(np.isfinite(a)):
            raise EventError(f"{name} has {int(np.sum(~np.isfinite(a)))} NaN/inf values")
        if not np.all(a == np.round(a)):
            raise EventError(f"{name} must hold whole numbers; round or convert units first")
    elif a.size and not np.issubdtype(a.dtype, np.integer):
        raise EventError(f"{name} must be integer, got dtype {a.dtype}")
    if a.size and (a.min() < lo or a.max() > hi):
        n_bad = int(np.sum((a < lo) | (a > hi)))
        raise EventError(f"{name}: {n_bad} values outside [{lo}, {hi}]")
    return a


def make_events(x: ArrayLike, y: ArrayLike, t: ArrayLike, p: ArrayLike) -> np.ndarray:
    """Build an event array of :data:`EVENT_DTYPE` from four equal-length columns.

    ``t`` is in microseconds (integers, or floats holding whole numbers); ``p`` may be
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
    out["t"] = _check_int_range("t", t_, np.iinfo(np.int64).min, np.iinfo(np.int64).max)
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
    >>> validate(ev, (4, 4))
    Traceback (most recent call last):
    ...
    e2vlib.events.EventError: 1 of 2 events lie outside the 4x4 sensor (x must be < width, y < height); check sensor_size=(width, height) or crop the events
    """
    for _ in iter_checked_chunks(events, sensor_size):
        pass
    return events


def check_sensor_size(sensor_size: tuple[int, int]) -> tuple[int, int]:
    """Return ``(width, height)`` as ints, raising :class:`EventError` if malformed."""
    try:
        width, height = (int(v) for v in sensor_size)
    except (TypeError, ValueError) as err:
        raise EventError(
            f"sensor_size must be (width, height), got {sensor_size!r}"
        ) from err
    if width <= 0 or height <= 0:
        raise EventError(f"sensor_size must be positive (width, height), got {sensor_size!r}")
    return width, height


def sort_events(events: np.ndarray) -> np.ndarray:
    """Return a copy sorted by time (stable, so equal timestamps keep their order)."""
    return events[np.argsort(events["t"], kind="stable")]
