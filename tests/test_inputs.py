"""Tests for e2vlib.inputs (representations of one recording) and the frame helpers behind it."""

import math

import numpy as np
import pytest

from e2vlib.data import load_sample
from e2vlib.events import EventError, make_events
from e2vlib.experiments import explore
from e2vlib.frames import (
    accumulate,
    downsample,
    sobel_edges,
    time_surface,
    time_surface_stack,
    voxel_grid,
)
from e2vlib.inputs import (
    REPRESENTATIONS,
    events_to_input,
    input_channels,
    orbit_input,
    recording_input,
)
from e2vlib.io import load_events
from e2vlib.paper import RECORDING_US

from .conftest import REPO


def _random_events(n=4000, size=16, span=50_000, seed=0):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.integers(0, span, n))
    return make_events(rng.integers(0, size, n), rng.integers(0, size, n), t,
                       rng.choice([-1, 1], n))


def test_time_surface_stack_is_time_surface_at_each_window_end():
    ev = _random_events()
    stack = time_surface_stack(ev, (16, 16), dt_us=5000, n_frames=10, tau_us=3000)
    for k in range(10):
        expected = time_surface(ev, (16, 16), t_us=(k + 1) * 5000 - 1, tau_us=3000,
                                split_polarity=False)
        np.testing.assert_allclose(stack[k], expected, rtol=1e-6)


def test_sobel_edges_of_a_flat_frame_are_zero_and_of_a_step_are_one_column_pair():
    flat = np.ones((2, 6, 6), np.uint8)
    assert sobel_edges(flat).max() == 0  # no edge anywhere, not even at the border
    step = np.zeros((1, 6, 6), np.uint8)
    step[0, :, 3:] = 1
    edges = sobel_edges(step)[0]
    assert np.all(edges[:, [2, 3]] == pytest.approx(1 / np.sqrt(2)))
    assert np.all(edges[:, [0, 1, 4, 5]] == 0)


@pytest.fixture(scope="module")
def recording():
    path = sorted((REPO / "data_small" / "events").glob("*.npz"))[0]
    events, sensor = load_events(path)
    frames, _ = load_sample(REPO / "data_small" / "samples" / path.name)
    return events, sensor, frames


def test_binary_input_is_exactly_what_data_small_stores(recording):
    events, sensor, stored = recording
    np.testing.assert_array_equal(orbit_input(events, sensor), stored)


def test_every_representation_has_the_documented_shape(recording):
    events, sensor, _ = recording
    for name in REPRESENTATIONS:
        x = orbit_input(events, sensor, 32, representation=name, n_frames=20, dt_us=25_000)
        expected = (20, 32, 32) if input_channels(name) == 1 else (2, 20, 32, 32)
        assert x.shape == expected, name
        assert np.all(np.isfinite(x)), name


def test_counts_polarity_and_voxel_grid_keep_their_sums(recording):
    events, sensor, _ = recording
    inside = events[events["t"] < 500_000]
    count = orbit_input(events, sensor, representation="count")
    polarity = orbit_input(events, sensor, representation="polarity")
    assert count.sum() == len(inside)
    np.testing.assert_array_equal(polarity.sum(axis=0), count)
    assert polarity[1].sum() == np.sum(inside["p"] > 0)
    grid = orbit_input(events, sensor, representation="voxel_grid")
    assert grid.sum() == pytest.approx(float(inside["p"].sum()), abs=1e-2)
    binary = orbit_input(events, sensor)
    np.testing.assert_array_equal(binary, (count > 0).astype(np.uint8))


def test_unknown_representation_is_named():
    with pytest.raises(ValueError, match="unknown representation 'rgb'"):
        orbit_input(_random_events(), (16, 16), 8, representation="rgb")


# --- one home for events -> model input: the old four give what they gave (issue 24) ------------
#
# The reference functions below are the bodies of the four old functions as they were before
# inputs.orbit_input / recording_input replaced them (older frame functions of data,
# inputs.events_to_input, explore._frames_at), written out with
# frames.accumulate / downsample; the new names must give the same
# arrays, dtypes and shapes.


def _old_events_to_frames(events, sensor_size, frame_size, t0_us=0, n_frames=100, dt_us=5000,
                          windows="fixed"):
    width, height = sensor_size
    assert width == height and width % frame_size == 0
    frames = accumulate(events, sensor_size, dt_us=dt_us, t0_us=t0_us, n_frames=n_frames,
                        windows=windows)
    return downsample(frames, width // frame_size)


def _old_events_to_model_input(events, sensor_size, frame_size, n_frames=100, dt_us=5000,
                               windows="fixed"):
    width, height = sensor_size
    factor = min(width, height) // frame_size
    t0 = int(events["t"][0]) if len(events) else 0
    frames = accumulate(events, sensor_size, dt_us=dt_us, t0_us=t0, n_frames=n_frames,
                        windows=windows)
    side = factor * frame_size
    top, left = (height - side) // 2, (width - side) // 2
    return downsample(frames[:, top:top + side, left:left + side], factor)


def _old_events_to_input(events, sensor_size, representation, frame_size, n_frames, dt_us,
                         t0_us=0):
    factor = sensor_size[0] // frame_size
    windows = {"n_frames": n_frames, "dt_us": dt_us, "t0_us": t0_us}
    if representation in ("binary", "binary_paper"):
        frames = accumulate(events, sensor_size, **windows,
                            windows="paper" if representation == "binary_paper" else "fixed")
        return downsample(frames, factor, "max")
    if representation == "count":
        counts = accumulate(events, sensor_size, **windows, mode="count")
        return downsample(counts, factor, "sum").astype(np.float32)
    if representation == "polarity":
        counts = accumulate(events, sensor_size, **windows, mode="polarity")
        return downsample(counts, factor, "sum").astype(np.float32).transpose(1, 0, 2, 3).copy()
    if representation == "time_surface":
        surfaces = time_surface_stack(events, sensor_size, dt_us, n_frames, t0_us)
        return downsample(surfaces, factor, "max")
    if representation == "voxel_grid":
        inside = events[(events["t"] >= t0_us) & (events["t"] < t0_us + n_frames * dt_us)]
        return downsample(voxel_grid(inside, sensor_size, n_frames), factor, "sum").astype(
            np.float32)
    binary = accumulate(events, sensor_size, **windows)
    return downsample(sobel_edges(binary), factor, "max")


def _old_frames_at(events, sensor_size, dt_ms):
    dt_us = max(1, round(dt_ms * 1000))
    n = math.ceil(RECORDING_US / dt_us)
    return accumulate(events, sensor_size, dt_us=dt_us, t0_us=0, n_frames=n)


def _stream(width, height, start_us, n=3000, span=60_000, seed=1):
    rng = np.random.default_rng(seed)
    t = start_us + np.sort(rng.integers(0, span, n))
    return make_events(rng.integers(0, width, n), rng.integers(0, height, n), t,
                       rng.choice([-1, 1], n))


def _same(new, old):
    assert new.dtype == old.dtype and new.shape == old.shape
    np.testing.assert_array_equal(new, old)


STREAMS = {"from t=0": (16, 16, 0), "from t=12345 us": (16, 16, 12_345),
           "late and sparse": (16, 16, 40_000)}
NON_SQUARE = {"24x16 from t=0": (24, 16, 0), "20x13 from t=7777 us": (20, 13, 7_777)}


@pytest.mark.parametrize("stream", list(STREAMS))
@pytest.mark.parametrize("windows", ["fixed", "paper"])
@pytest.mark.parametrize("frame_size", [16, 8, 4])
def test_orbit_input_gives_the_old_events_to_frames(stream, windows, frame_size):
    width, height, start = STREAMS[stream]
    events = _stream(width, height, start)
    for t0 in (0, start):
        old = _old_events_to_frames(events, (width, height), frame_size, t0, 12, 5000, windows)
        _same(orbit_input(events, (width, height), frame_size, n_frames=12, dt_us=5000,
                          t0_us=t0, windows=windows), old)
        _same(orbit_input(events, (width, height), frame_size, t0_us=t0, n_frames=12,
                          dt_us=5000, windows=windows), old)


@pytest.mark.parametrize("stream", list(STREAMS))
@pytest.mark.parametrize("name", list(REPRESENTATIONS))
def test_orbit_input_gives_the_old_events_to_input(stream, name):
    width, height, start = STREAMS[stream]
    events = _stream(width, height, start)
    for frame_size, t0 in ((8, 0), (4, start), (16, 2_500)):
        old = _old_events_to_input(events, (width, height), name, frame_size, 12, 5000, t0)
        _same(orbit_input(events, (width, height), frame_size, representation=name,
                          n_frames=12, dt_us=5000, t0_us=t0), old)
        # the published contract's name and argument order (tests outside the repo call it)
        _same(events_to_input(events, (width, height), name, frame_size, 12, 5000, t0), old)


@pytest.mark.parametrize("stream", list(STREAMS) + list(NON_SQUARE))
@pytest.mark.parametrize("windows", ["fixed", "paper"])
@pytest.mark.parametrize("frame_size", [8, 4, 3])
def test_recording_input_gives_the_old_events_to_model_input(stream, windows, frame_size):
    width, height, start = {**STREAMS, **NON_SQUARE}[stream]
    events = _stream(width, height, start)
    old = _old_events_to_model_input(events, (width, height), frame_size, 12, 5000, windows)
    _same(recording_input(events, (width, height), frame_size, n_frames=12, dt_us=5000,
                          windows=windows), old)
    _same(recording_input(events, (width, height), frame_size, n_frames=12, dt_us=5000,
                          windows=windows), old)


@pytest.mark.parametrize("stream", list(STREAMS) + list(NON_SQUARE))
@pytest.mark.parametrize("dt_ms", [5.0, 2.5, 0.7, 50.0])
def test_the_explorer_frames_are_orbit_input_at_the_sensor_resolution(stream, dt_ms):
    width, height, start = {**STREAMS, **NON_SQUARE}[stream]
    events = _stream(width, height, start, span=480_000)
    _same(explore._frames_at(events, (width, height), dt_ms),
          _old_frames_at(events, (width, height), dt_ms))


def test_recording_input_on_a_square_sensor_is_orbit_input_from_the_first_event():
    events = _stream(16, 16, 12_345)
    for name in REPRESENTATIONS:
        _same(recording_input(events, (16, 16), 8, representation=name, n_frames=12),
              orbit_input(events, (16, 16), 8, representation=name, n_frames=12,
                          t0_us=int(events["t"][0])))


def test_the_builder_and_the_scan_reader_share_one_function():
    import e2vlib.data.samples
    import e2vlib.data.synthevox3d

    assert e2vlib.data.samples.orbit_input is orbit_input
    assert e2vlib.data.synthevox3d.orbit_input is orbit_input


def test_the_two_clocks_refuse_what_they_cannot_make():
    events = _stream(24, 16, 0)
    with pytest.raises(ValueError, match="sensor 24x16 must be square and a multiple of "
                                         "frame_size 8"):
        orbit_input(events, (24, 16), 8)
    with pytest.raises(ValueError, match="a 24x16 sensor is smaller than frame_size 32"):
        recording_input(events, (24, 16), 32, n_frames=12)
    with pytest.raises(EventError, match="3000 event\\(s\\) cannot make the model's input"):
        recording_input(events, (24, 16), 8, n_frames=3001)
    with pytest.raises(ValueError, match="windows must be one of"):
        orbit_input(events[:0], (16, 16), 8, windows="sliding")
    with pytest.raises(ValueError, match="makes binary frames only"):
        orbit_input(events[:0], (16, 16), 8, representation="count", windows="paper")
    with pytest.raises(ValueError, match="'binary_paper' groups events as the paper's Eq. 5"):
        orbit_input(events[:0], (16, 16), 8, representation="binary_paper", windows="fixed")
    square = _stream(16, 16, 0)
    _same(orbit_input(square, (16, 16), 8, representation="binary_paper", n_frames=12),
          orbit_input(square, (16, 16), 8, windows="paper", n_frames=12))
