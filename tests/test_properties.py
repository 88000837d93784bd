"""Property-based tests (Hypothesis): file round trips and frame accumulation invariants.

Each property is checked on generated examples (small sensors, short streams): 10 under
``make test``, 150 under ``make test-all`` (the Hypothesis profiles in tests/conftest.py).
Hypothesis shrinks any failure to a minimal event stream.
"""

from __future__ import annotations

import contextlib
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from e2vlib import frames
from e2vlib.events import EVENT_DTYPE, INT64_MAX, INT64_MIN, EventError, make_events
from e2vlib.frames import accumulate
from e2vlib.io import load_events, save_events

WRITABLE = (".npz", ".txt", ".txt.gz", ".h5")


@st.composite
def event_streams(draw, t_min: int = INT64_MIN, t_max: int = INT64_MAX, max_events: int = 40,
                  max_side: int = 70_000):
    """``(events, sensor_size)``: any valid stream (sorted times in ``[t_min, t_max]``)."""
    width = draw(st.integers(1, min(max_side, 65_536)))
    height = draw(st.integers(1, min(max_side, 65_536)))
    n = draw(st.integers(0, max_events))
    x = draw(st.lists(st.integers(0, width - 1), min_size=n, max_size=n))
    y = draw(st.lists(st.integers(0, height - 1), min_size=n, max_size=n))
    t = sorted(draw(st.lists(st.integers(t_min, t_max), min_size=n, max_size=n)))
    p = draw(st.lists(st.sampled_from([-1, 1]), min_size=n, max_size=n))
    events = make_events(np.array(x, np.int64), np.array(y, np.int64),
                         np.array(t, np.int64), np.array(p, np.int64))
    return events, (width, height)


@given(stream=event_streams())
@pytest.mark.parametrize("ending", WRITABLE)
def test_any_valid_events_survive_save_and_load_exactly(ending, stream):
    events, sensor_size = stream
    with tempfile.TemporaryDirectory() as folder:
        path = save_events(Path(folder) / f"events{ending}", events, sensor_size)
        loaded, loaded_size = load_events(path)
        assert [p.name for p in Path(folder).iterdir()] == [path.name]  # no temp file left
    assert loaded.dtype == EVENT_DTYPE
    assert loaded_size == sensor_size
    np.testing.assert_array_equal(loaded, events)


# --- frames ---------------------------------------------------------------------------------

# Times within a few hundred windows of their start, so frame stacks stay small; the start
# itself may be far from 0 (a Unix-time recording in microseconds, or negative).
SMALL_STREAMS = st.tuples(
    st.sampled_from([0, -5_000_000, 1_700_000_000_000_000]),
    event_streams(t_min=0, t_max=20_000, max_events=60, max_side=9),
)


def _shifted(stream):
    offset, (events, sensor_size) = stream
    events = events.copy()
    events["t"] += offset
    return events, sensor_size, offset


def _eq5_inside(t: np.ndarray, dt: int, t0: int, n_frames: int | None) -> np.ndarray:
    """Which events the paper's Eq. 5 groups hold, found by a plain loop (the reference)."""
    inside = np.zeros(len(t), dtype=bool)
    i, groups = int(np.searchsorted(t, t0, side="left")), 0
    while i < len(t) and (n_frames is None or groups < n_frames):
        j = i
        while j < len(t) and t[j] - t[i] <= dt:
            j += 1
        inside[i:j] = True
        groups += 1
        i = j
    return inside


@given(stream=SMALL_STREAMS, dt=st.integers(100, 5_000),
       t0_shift=st.one_of(st.none(), st.integers(-3_000, 20_000)),
       n_frames=st.one_of(st.none(), st.integers(0, 40)))
def test_fixed_windows_never_lose_an_event_inside_them(stream, dt, t0_shift, n_frames):
    events, sensor_size, offset = _shifted(stream)
    t0 = None if t0_shift is None else offset + t0_shift
    counts = accumulate(events, sensor_size, dt_us=dt, t0_us=t0, n_frames=n_frames,
                        mode="count")
    t = events["t"]
    start = (int(t[0]) if len(t) else 0) if t0 is None else t0
    n = counts.shape[0]
    if n_frames is not None:
        assert n == n_frames
    end = start + n * dt
    if n_frames is None and len(t):
        assert int(t[-1]) < end  # the default covers the last event
    inside = int(np.count_nonzero((t >= start) & (t < end)))
    assert int(counts.sum()) == inside
    # and each event lands in its own window and pixel
    keep = (t >= start) & (t < end)
    expected = np.zeros_like(counts)
    np.add.at(expected, ((t[keep] - start) // dt, events["y"][keep], events["x"][keep]), 1)
    np.testing.assert_array_equal(counts, expected)


@given(stream=SMALL_STREAMS, dt=st.integers(100, 5_000),
       t0_shift=st.one_of(st.none(), st.integers(-3_000, 20_000)),
       n_frames=st.one_of(st.none(), st.integers(0, 40)))
def test_paper_windows_never_lose_an_event_inside_them(stream, dt, t0_shift, n_frames):
    events, sensor_size, offset = _shifted(stream)
    t0 = None if t0_shift is None else offset + t0_shift
    counts = accumulate(events, sensor_size, dt_us=dt, t0_us=t0, n_frames=n_frames,
                        mode="count", windows="paper")
    t = events["t"]
    start = (int(t[0]) if len(t) else 0) if t0 is None else t0
    assert int(counts.sum()) == int(_eq5_inside(t, dt, start, n_frames).sum())
    if n_frames is None:  # every event from t0 on is in some group, and no group is empty
        assert int(counts.sum()) == int(np.count_nonzero(t >= start))
        assert np.all(counts.sum(axis=(1, 2)) > 0)


@given(stream=SMALL_STREAMS, dt=st.integers(100, 5_000),
       windows=st.sampled_from(["fixed", "paper"]),
       n_frames=st.one_of(st.none(), st.integers(0, 40)))
def test_binary_at_most_count_and_polarity_channels_sum_to_count(stream, dt, windows,
                                                                  n_frames):
    events, sensor_size, _ = _shifted(stream)
    kwargs = {"dt_us": dt, "n_frames": n_frames, "windows": windows}
    binary = accumulate(events, sensor_size, mode="binary", **kwargs)
    count = accumulate(events, sensor_size, mode="count", **kwargs)
    polarity = accumulate(events, sensor_size, mode="polarity", **kwargs)
    assert binary.shape == count.shape and polarity.shape[1] == 2
    assert polarity.shape[0] == count.shape[0] and polarity.shape[2:] == count.shape[1:]
    assert np.all(binary.astype(np.int64) <= count)
    np.testing.assert_array_equal(binary, (count > 0).astype(binary.dtype))
    np.testing.assert_array_equal(polarity[:, 0] + polarity[:, 1], count)
    # channel 0 counts the OFF (-1) events inside the windows, channel 1 the ON (+1) ones
    t = events["t"]
    start = int(t[0]) if len(t) else 0
    if windows == "fixed":
        inside = (t >= start) & (t < start + count.shape[0] * dt)
    else:
        inside = _eq5_inside(t, dt, start, n_frames)
    assert int(polarity[:, 0].sum()) == int(np.count_nonzero(inside & (events["p"] == -1)))
    assert int(polarity[:, 1].sum()) == int(np.count_nonzero(inside & (events["p"] == 1)))


# --- accumulate_fast (numba) equals accumulate (numpy) ----------------------------------------

try:
    from e2vlib.scale import frames_numba
except ImportError:  # numba is not installed
    frames_numba = None
needs_numba = pytest.mark.skipif(frames_numba is None, reason="numba is not installed")


@contextlib.contextmanager
def _threads(on: bool):
    """With ``on``, ``accumulate_fast`` cuts every stream into parts counted in threads (as
    it does for streams of a million events and more), up to 4 parts whatever the cores."""
    if not on:
        yield
        return
    with mock.patch.object(frames_numba, "THREADED_MIN_EVENTS", 1), \
            mock.patch.object(frames_numba, "_cores", lambda: 4):
        yield


@contextlib.contextmanager
def _memory_limit(limit: int = 2**28):
    """Both accumulators' memory limit fixed at ``limit`` bytes, whatever memory is free:
    both holding stacks of gigabytes ran a 23 GiB machine out of memory, and the free
    memory changes between the two calls (so could their limits, and answers)."""
    with mock.patch.object(frames, "MAX_FRAMES_BYTES", limit), \
            mock.patch.object(frames_numba, "available_memory", lambda: 2**50):
        yield


def _outcome(events, sensor_size, fast=False, **kwargs):
    """The frames of ``accumulate`` (``accumulate_fast`` when ``fast``), or the text of the
    EventError it raised."""
    try:
        if fast:
            return frames_numba.accumulate_fast(events, sensor_size, **kwargs)
        return accumulate(events, sensor_size, **kwargs)
    except EventError as err:
        return str(err)


def _assert_same(reference, fast):
    if isinstance(reference, str) or isinstance(fast, str):
        assert fast == reference
        return
    assert fast.dtype == reference.dtype and fast.shape == reference.shape
    np.testing.assert_array_equal(fast, reference)


@needs_numba
@given(stream=SMALL_STREAMS, dt=st.integers(1, 5_000),
       t0_shift=st.one_of(st.none(), st.integers(-3_000, 20_000)),
       n_frames=st.one_of(st.none(), st.integers(0, 40)),
       mode=st.sampled_from(["binary", "count", "polarity"]),
       windows=st.sampled_from(["fixed", "paper"]), threads=st.booleans())
def test_accumulate_fast_and_accumulate_give_identical_frames(stream, dt, t0_shift, n_frames,
                                                              mode, windows, threads):
    events, sensor_size, offset = _shifted(stream)
    kwargs = {"dt_us": dt, "t0_us": None if t0_shift is None else offset + t0_shift,
              "n_frames": n_frames, "mode": mode, "windows": windows}
    with _threads(threads):
        fast = _outcome(events, sensor_size, fast=True, **kwargs)
    _assert_same(_outcome(events, sensor_size, **kwargs), fast)


@needs_numba
@given(stream=event_streams(max_events=12, max_side=6), dt=st.integers(1, 2**63 - 1),
       n_frames=st.one_of(st.none(), st.integers(0, 6)),
       mode=st.sampled_from(["binary", "count", "polarity"]),
       windows=st.sampled_from(["fixed", "paper"]), threads=st.booleans())
def test_both_agree_anywhere_in_the_int64_time_range(stream, dt, n_frames, mode, windows,
                                                    threads):
    # times anywhere in int64, windows up to 2^63 us: spans that overflow int64 arithmetic,
    # and stacks too large to allocate (both must refuse them alike: over 256 MiB)
    events, sensor_size = stream
    kwargs = {"dt_us": dt, "n_frames": n_frames, "mode": mode, "windows": windows}
    with _memory_limit():
        with _threads(threads):
            fast = _outcome(events, sensor_size, fast=True, **kwargs)
        _assert_same(_outcome(events, sensor_size, **kwargs), fast)


@needs_numba
@given(stream=SMALL_STREAMS, broken=st.sampled_from(["x", "y", "p", "t"]),
       where=st.floats(0, 1), windows=st.sampled_from(["fixed", "paper"]),
       threads=st.booleans())
def test_both_reject_broken_events_alike(stream, broken, where, windows, threads):
    events, sensor_size, _ = _shifted(stream)
    if len(events) < 2:
        return
    events = events.copy()
    i = min(int(where * len(events)), len(events) - 1)
    if broken == "x":
        events["x"][i] = sensor_size[0]
    elif broken == "y":
        events["y"][i] = sensor_size[1]
    elif broken == "p":
        events["p"][i] = 0
    else:
        events["t"][i] = events["t"][i - 1] - 1 if i else events["t"][1] + 1
    reference = _outcome(events, sensor_size, dt_us=500, windows=windows)
    assert isinstance(reference, str)
    with _threads(threads):
        assert _outcome(events, sensor_size, dt_us=500, windows=windows,
                        fast=True) == reference
