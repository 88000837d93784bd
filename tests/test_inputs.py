"""Tests for e2vlib.inputs (representations of one recording) and the frame helpers behind it."""

import numpy as np
import pytest

from e2vlib.data import load_sample
from e2vlib.events import make_events
from e2vlib.frames import sobel_edges, time_surface, time_surface_stack
from e2vlib.inputs import REPRESENTATIONS, events_to_input, input_channels
from e2vlib.io import load_events

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
    np.testing.assert_array_equal(events_to_input(events, sensor, "binary"), stored)


def test_every_representation_has_the_documented_shape(recording):
    events, sensor, _ = recording
    for name in REPRESENTATIONS:
        x = events_to_input(events, sensor, name, frame_size=32, n_frames=20, dt_us=25_000)
        expected = (20, 32, 32) if input_channels(name) == 1 else (2, 20, 32, 32)
        assert x.shape == expected, name
        assert np.all(np.isfinite(x)), name


def test_counts_polarity_and_voxel_grid_keep_their_sums(recording):
    events, sensor, _ = recording
    inside = events[events["t"] < 500_000]
    count = events_to_input(events, sensor, "count")
    polarity = events_to_input(events, sensor, "polarity")
    assert count.sum() == len(inside)
    np.testing.assert_array_equal(polarity.sum(axis=0), count)
    assert polarity[1].sum() == np.sum(inside["p"] > 0)
    grid = events_to_input(events, sensor, "voxel_grid")
    assert grid.sum() == pytest.approx(float(inside["p"].sum()), abs=1e-2)
    binary = events_to_input(events, sensor, "binary")
    np.testing.assert_array_equal(binary, (count > 0).astype(np.uint8))


def test_unknown_representation_is_named():
    with pytest.raises(ValueError, match="unknown representation 'rgb'"):
        events_to_input(_random_events(), (16, 16), "rgb", frame_size=8)
