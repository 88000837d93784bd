"""Sensor noise (e2vlib.noise): v2e's shot noise and leak events on top of the simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from e2vlib.events import EVENT_DTYPE, make_events, validate
from e2vlib.noise import (
    NOISE_LEVELS,
    add_shot_noise,
    leak_drift,
    noise_rng,
    simulate_noisy_events,
)
from e2vlib.simulate import TooManyEventsError, apply_refractory, draw_thresholds, simulate_events

TEN_S = np.array([0, 10_000_000])  # two frames 10 s apart: a static scene is exact with two


def _static(h=40, w=50, value=0.5):
    return np.full((2, h, w), value)


def _per_pixel(events, width):
    return events["y"].astype(int) * width + events["x"]


def test_leak_rate_measured_on_a_static_scene():
    # each pixel's reference drifts by C_on * rate per second, so it fires ON events every
    # 1 / rate seconds from a uniform random phase: per pixel floor(u + rate * T) events,
    # mean rate * T = 3.7, standard deviation of the mean sqrt(0.7 * 0.3 / 2000) = 0.010
    events = simulate_noisy_events(_static(), TEN_S, contrast_sigma=0.05, leak_rate_hz=0.37,
                                   seed=1)
    validate(events, (50, 40))
    assert np.all(events["p"] == 1)
    per_pixel = np.bincount(_per_pixel(events, 50), minlength=2000)
    assert set(per_pixel.tolist()) <= {3, 4}
    assert abs(per_pixel.mean() - 3.7) < 4 * 0.0103
    # within a pixel the leak events are exactly 1 / rate apart (to the rounding microsecond)
    pixel = events[(events["x"] == 7) & (events["y"] == 3)]
    np.testing.assert_allclose(np.diff(pixel["t"]), 1e6 / 0.37, atol=1.0)


def test_shot_noise_rate_and_on_off_balance():
    # Poisson: 2 Hz x 2000 px x 10 s = 40,000 expected events, sd 200; ON share 1/2, sd 0.0025
    events = simulate_noisy_events(_static(), TEN_S, shot_noise_rate_hz=2.0, seed=2)
    validate(events, (50, 40))
    assert abs(len(events) - 40_000) < 4 * 200
    assert abs(np.mean(events["p"] == 1) - 0.5) < 4 * 0.0025
    # Poisson counts per pixel: variance equals the mean (index of dispersion 1 +- 4 * 0.032)
    per_pixel = np.bincount(_per_pixel(events, 50), minlength=2000)
    assert abs(per_pixel.var() / per_pixel.mean() - 1) < 4 * math.sqrt(2 / 1999)
    assert events["t"].min() >= 0 and events["t"].max() < 10_000_000


def test_refractory_period_holds_for_noise_events():
    # non-paralysable dead time tau: a Poisson rate r is thinned to r / (1 + r tau);
    # 200 Hz with 2 ms gives 142.86 Hz, 22,857 events on 16 px in 10 s (sd below 151)
    events = simulate_noisy_events(_static(4, 4), TEN_S, shot_noise_rate_hz=200.0,
                                   refractory_us=2000, seed=3)
    expected = 16 * 10 * 200 / (1 + 200 * 0.002)
    assert abs(len(events) - expected) < 4 * math.sqrt(expected)
    for pixel in range(16):
        times = events["t"][_per_pixel(events, 4) == pixel]
        assert np.all(np.diff(times) >= 2000)


def test_refractory_period_holds_across_signal_and_noise():
    rng = np.random.default_rng(5)
    video = np.clip(0.5 + 0.3 * np.cumsum(rng.normal(size=(30, 5, 6)), axis=0) / 4, 0, 1)
    t = np.arange(30) * 2000
    events = simulate_noisy_events(video, t, 0.1, 0.1, refractory_us=1500, seed=0,
                                   shot_noise_rate_hz=300.0, leak_rate_hz=20.0)
    validate(events, (6, 5))
    assert np.all(np.diff(events["t"]) >= 0)
    for pixel in range(30):
        times = events["t"][_per_pixel(events, 6) == pixel]
        assert np.all(np.diff(times) >= 1500)


def test_noisy_output_is_sorted_valid_and_contains_the_signal():
    rng = np.random.default_rng(6)
    video = rng.random((8, 9, 11)).astype(np.float32)
    t = np.array([0, 7, 20, 33, 50, 51, 4000, 9000])
    clean = simulate_events(video, t)
    noisy = simulate_noisy_events(video, t, shot_noise_rate_hz=50.0, seed=4)
    validate(noisy, (11, 9))
    assert np.all(np.diff(noisy["t"]) >= 0)
    assert noisy["t"].min() >= 0 and noisy["t"].max() <= 9000
    # shot noise does not move the reference: the signal events are all still there
    assert len(noisy) > len(clean)
    signal = {tuple(int(v) for v in e) for e in clean}
    assert signal <= {tuple(int(v) for v in e) for e in noisy}


def test_zero_noise_gives_simulate_events_exactly():
    rng = np.random.default_rng(7)
    video = rng.random((10, 6, 7))
    t = np.arange(10) * 1000
    for kwargs in ({}, {"contrast_sigma": 0.05, "refractory_us": 300},
                   {"contrast_pos": 0.1, "contrast_neg": 0.3}):
        plain = simulate_events(video, t, seed=9, **kwargs)
        zero = simulate_noisy_events(video, t, seed=9, shot_noise_rate_hz=0.0, leak_rate_hz=0,
                                     **kwargs)
        assert plain.tobytes() == zero.tobytes()
    np.testing.assert_array_equal(simulate_noisy_events(video, t, **NOISE_LEVELS["clean"]),
                                  simulate_events(video, t))


def test_noisy_events_are_the_composition_of_the_parts():
    # simulate_noisy_events = thresholds, leak drift, simulate_events, shot noise, refractory,
    # with the noise drawn from the stream noise_rng(seed) (leak phase first)
    rng = np.random.default_rng(15)
    video = np.clip(0.5 + 0.2 * np.cumsum(rng.normal(size=(12, 6, 8)), axis=0) / 3, 0, 1)
    t = np.arange(12) * 3000
    kw = {"contrast_sigma": 0.04, "refractory_us": 500.0, "shot_noise_rate_hz": 80.0,
          "leak_rate_hz": 30.0}
    got = simulate_noisy_events(video, t, 0.15, 0.15, seed=5, **kw)
    c_on, c_off = draw_thresholds((6, 8), 0.15, 0.15, 0.04, seed=5)
    stream = noise_rng(5)
    drift, offset = leak_drift(c_on, 30.0, stream)
    events = simulate_events(video, t, c_on, c_off, drift_per_us=drift, reference_offset=offset)
    events = add_shot_noise(events, (8, 6), 0, 33_000, 80.0, stream)
    np.testing.assert_array_equal(got, apply_refractory(events, 500.0))
    assert len(got) > 200


def test_noise_is_reproducible_per_seed_and_keeps_the_thresholds():
    video = np.random.default_rng(8).random((6, 8, 8))
    t = np.arange(6) * 100_000
    kw = {"contrast_sigma": 0.05, "shot_noise_rate_hz": 5.0, "leak_rate_hz": 1.0}
    a = simulate_noisy_events(video, t, seed=1, **kw)
    np.testing.assert_array_equal(a, simulate_noisy_events(video, t, seed=1, **kw))
    assert not np.array_equal(a, simulate_noisy_events(video, t, seed=2, **kw))
    g1 = simulate_noisy_events(video, t, seed=np.random.default_rng(3), **kw)
    np.testing.assert_array_equal(
        g1, simulate_noisy_events(video, t, seed=np.random.default_rng(3), **kw))
    # the thresholds do not depend on the noise: with shot noise only (no refractory), the
    # signal events are exactly those of simulate_events with the same seed
    clean = simulate_events(video, t, contrast_sigma=0.05, seed=1)
    shot = simulate_noisy_events(video, t, contrast_sigma=0.05, seed=1, shot_noise_rate_hz=5.0)
    assert {tuple(e) for e in clean.tolist()} <= {tuple(e) for e in shot.tolist()}


def test_add_shot_noise_puts_events_first_at_a_tie_and_sorts_by_time_then_pixel():
    # a 2 x 1 px sensor and a one-microsecond window: every noise event ties with the signal
    # (given out of pixel order); per pixel the signal event comes first, then the noise
    signal = make_events([1, 0], [0, 0], [5, 5], [1, -1])
    noise_only = add_shot_noise(np.empty(0, EVENT_DTYPE), (2, 1), 5, 6, 5e6, seed=0)
    both = add_shot_noise(signal, (2, 1), 5, 6, 5e6, seed=0)
    assert np.all(both["t"] == 5) and len(both) == 2 + len(noise_only)
    assert np.all(np.diff(both["x"].astype(int)) >= 0)  # by pixel within the microsecond
    first = {x: int(np.flatnonzero(both["x"] == x)[0]) for x in (0, 1)}
    assert tuple(both[first[0]].tolist()) == (0, 0, 5, -1)
    assert tuple(both[first[1]].tolist()) == (1, 0, 5, 1)
    # the rest are exactly the noise drawn alone, in the same stable order
    rest = np.delete(both, list(first.values()))
    np.testing.assert_array_equal(rest, noise_only[np.argsort(noise_only["x"], kind="stable")])
    assert 0 < np.sum(rest["x"] == 0) < len(rest)  # both pixels got noise (mean 10)


def test_leak_drift_known_answer():
    drift, offset = leak_drift(np.array([[0.2, 0.4]]), 0.5, seed=np.random.default_rng(0))
    np.testing.assert_allclose(drift, [[1e-7, 2e-7]])
    u = np.random.default_rng(0).random((1, 2))
    np.testing.assert_array_equal(offset, -(u * [[0.2, 0.4]]))


def test_noise_levels_presets():
    assert list(NOISE_LEVELS) == ["clean", "low", "medium", "high"]
    keys = ("contrast_sigma", "shot_noise_rate_hz", "leak_rate_hz", "refractory_us")
    for key in keys:
        values = [NOISE_LEVELS[level][key] for level in NOISE_LEVELS]
        assert values == sorted(values) and values[0] == 0
    assert NOISE_LEVELS["high"]["shot_noise_rate_hz"] == 5.0  # v2e's 'noisy' preset
    n = [len(simulate_noisy_events(_static(8, 8), TEN_S, seed=0, **NOISE_LEVELS[k]))
         for k in NOISE_LEVELS]
    assert n == sorted(n) and n[0] == 0 and n[-1] > 3000


@pytest.mark.parametrize("name", ["shot_noise_rate_hz", "leak_rate_hz", "refractory_us"])
@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf")])
def test_bad_noise_values_raise(name, value):
    with pytest.raises(ValueError, match=name):
        simulate_noisy_events(_static(2, 2), [0, 1000], **{name: value})


def test_v2e_spellings_are_not_second_names():
    with pytest.raises(TypeError, match="sigma_thres"):
        simulate_noisy_events(_static(2, 2), [0, 1000], sigma_thres=0.03)


def test_shot_noise_beyond_max_events_is_refused_before_drawing():
    with pytest.raises(TooManyEventsError, match="lower shot_noise_rate_hz"):
        simulate_noisy_events(_static(100, 100), [0, 10**9], shot_noise_rate_hz=1e3)
    with pytest.raises(TooManyEventsError, match="max_events=100"):
        simulate_noisy_events(_static(4, 4), TEN_S, shot_noise_rate_hz=1.0, max_events=100)
