"""Known answers and invariants for e2vlib.simulate (the ESIM event simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from e2vlib.events import EVENT_DTYPE, validate
from e2vlib.simulate import (
    MIN_CONTRAST,
    apply_refractory,
    draw_thresholds,
    simulate_events,
)

EPS = 1e-3


def intensity(log_level: float) -> float:
    """Intensity whose ESIM log value log(I + EPS) equals ``log_level``."""
    return math.exp(log_level) - EPS


def one_pixel_video(log_levels: list[float]) -> np.ndarray:
    """(n, 1, 1) float64 video whose single pixel has the given log intensities."""
    return np.array([intensity(v) for v in log_levels], dtype=np.float64).reshape(-1, 1, 1)


L0 = math.log(0.2 + EPS)  # a mid-gray starting level


def test_static_video_gives_no_events():
    video = np.full((5, 4, 6), 0.4, dtype=np.float32)
    events = simulate_events(video, np.arange(5) * 1000)
    assert events.dtype == EVENT_DTYPE
    assert len(events) == 0
    assert len(simulate_events(np.full((3, 2, 2), 77, np.uint8), [0, 10, 20])) == 0


def test_ramp_of_1_05_gives_five_on_events_at_interpolated_times():
    dt = 10_000
    events = simulate_events(one_pixel_video([L0, L0 + 1.05]), [0, dt], contrast_pos=0.2)
    expected = np.rint(np.arange(1, 6) * 0.2 / 1.05 * dt).astype(np.int64)
    assert expected.tolist() == [1905, 3810, 5714, 7619, 9524]
    np.testing.assert_array_equal(events["t"], expected)
    assert np.all(events["p"] == 1)
    assert np.all(events["x"] == 0) and np.all(events["y"] == 0)


def test_decreasing_ramp_gives_off_events():
    dt = 10_000
    events = simulate_events(one_pixel_video([L0 + 1.05, L0]), [500, 500 + dt])
    expected = 500 + np.rint(np.arange(1, 6) * 0.2 / 1.05 * dt).astype(np.int64)
    np.testing.assert_array_equal(events["t"], expected)
    assert np.all(events["p"] == -1)


def test_reference_carries_over_between_frames():
    # +0.15 then +0.15: nothing in the first interval, one event when the total reaches 0.2,
    # a third of the way into the second interval
    events = simulate_events(one_pixel_video([L0, L0 + 0.15, L0 + 0.30]), [0, 1000, 2000])
    assert len(events) == 1
    assert events["t"][0] == 1333 and events["p"][0] == 1


def test_asymmetric_thresholds():
    # up by 0.45 with C_on = 0.1: 4 ON events, reference ends at +0.4; back down to 0 with
    # C_off = 0.3: one OFF event when the signal reaches 0.4 - 0.3 = 0.1
    video = one_pixel_video([L0, L0 + 0.45, L0])
    events = simulate_events(video, [0, 9000, 18000], contrast_pos=0.1, contrast_neg=0.3)
    on = np.rint(np.arange(1, 5) * 0.1 / 0.45 * 9000)
    off = np.rint(9000 + (0.45 - 0.1) / 0.45 * 9000)
    np.testing.assert_array_equal(events["t"], np.append(on, off).astype(np.int64))
    np.testing.assert_array_equal(events["p"], [1, 1, 1, 1, -1])


def test_refractory_drops_events_but_reference_still_moves():
    dt = 10_000
    video = one_pixel_video([L0, L0 + 1.05, L0 + 1.15, L0 + 1.25])
    times = [0, dt, 2 * dt, 3 * dt]
    events = simulate_events(video, times, refractory_us=3000)
    # crossings at 1905, 3810, 5714, 7619, 9524: every second one is too soon after the last
    # emitted one. The reference still reaches +1.0, so +1.15 makes nothing and +1.25 one
    # event at level 1.2, half way through the last interval.
    np.testing.assert_array_equal(events["t"], [1905, 5714, 9524, 25000])
    assert len(simulate_events(video, times)) == 6  # without refractory: all 5 + 1


def test_refractory_is_per_pixel():
    video = np.concatenate([one_pixel_video([L0, L0 + 1.05])] * 2, axis=2)  # (2, 1, 2)
    events = simulate_events(video, [0, 10_000], refractory_us=3000)
    for x in (0, 1):
        np.testing.assert_array_equal(events["t"][events["x"] == x], [1905, 5714, 9524])


def test_coordinates_follow_frame_indexing():
    video = np.full((3, 3, 5), 0.5, dtype=np.float32)  # H = 3, W = 5
    video[1:, 1, 4] = 0.9  # row y = 1, column x = 4 brightens
    events = simulate_events(video, [0, 100, 200])
    validate(events, (5, 3))
    assert len(events) == math.floor((math.log(0.9 + EPS) - math.log(0.5 + EPS)) / 0.2)
    assert set(events["x"].tolist()) == {4} and set(events["y"].tolist()) == {1}


def scalar_esim(video, t_us, c_on, c_off, refractory_us=0, drift=None, offset=None):
    """Hand-written one-pixel-at-a-time ESIM that steps the reference one threshold at a
    time (an independent formulation of the same model). ``drift`` (log intensity per us)
    and ``offset`` (added to the first reference) are per-pixel arrays or None."""
    n, h, w = video.shape
    ramp = np.zeros((h, w)) if drift is None else drift
    logs = [np.log(video[j].astype(np.float64) + EPS) + ramp * float(t_us[j] - t_us[0])
            for j in range(n)]
    out = []
    for y in range(h):
        for x in range(w):
            ref, last = logs[0][y, x] + (0.0 if offset is None else offset[y, x]), -(10**18)
            for j in range(n - 1):
                l0, l1 = logs[j][y, x], logs[j + 1][y, x]
                if l1 == l0:
                    continue
                crossings = []
                if l1 > ref:
                    while l1 - ref >= c_on[y, x]:
                        ref += c_on[y, x]
                        crossings.append((ref, 1))
                else:
                    while ref - l1 >= c_off[y, x]:
                        ref -= c_off[y, x]
                        crossings.append((ref, -1))
                for level, p in crossings:
                    frac = min(max((level - l0) / (l1 - l0), 0.0), 1.0)
                    t = round(t_us[j] + frac * (t_us[j + 1] - t_us[j]))
                    if t - last >= refractory_us:
                        out.append((x, y, t, p))
                        last = t
    return out


def as_sorted_tuples(events):
    order = np.lexsort((events["p"], events["x"], events["y"], events["t"]))
    return [tuple(int(v) for v in e) for e in events[order]]


@pytest.mark.parametrize("sigma, refractory", [(0.0, 0), (0.05, 0), (0.05, 700)])
def test_matches_hand_written_scalar_simulator(sigma, refractory):
    rng = np.random.default_rng(7)
    video = np.clip(0.5 + 0.35 * np.cumsum(rng.normal(size=(8, 4, 5)), axis=0) / 3, 0, 1)
    video[:, 0, 0] = 0.3  # one static pixel
    t_us = np.cumsum(rng.integers(500, 3000, size=8))
    c_on, c_off = draw_thresholds((4, 5), 0.15, 0.25, sigma, seed=11)
    events = simulate_events(video, t_us, 0.15, 0.25, sigma, refractory, seed=11)
    validate(events, (5, 4))
    expected = scalar_esim(video, t_us, c_on, c_off, refractory)
    assert len(events) > 50
    assert as_sorted_tuples(events) == sorted(expected, key=lambda e: (e[2], e[1], e[0], e[3]))
    assert not np.any((events["x"] == 0) & (events["y"] == 0))


def test_drift_and_reference_offset_match_the_scalar_simulator():
    # the two hooks e2vlib.noise fills for leak events: a log-intensity ramp per pixel and a
    # shifted first reference, checked against the one-pixel-at-a-time loop
    rng = np.random.default_rng(12)
    video = np.clip(0.5 + 0.2 * np.cumsum(rng.normal(size=(10, 3, 4)), axis=0) / 3, 0, 1)
    t_us = np.cumsum(rng.integers(500, 3000, size=10))
    c_on, c_off = draw_thresholds((3, 4), 0.15, 0.2, 0.03, seed=2)
    drift = rng.uniform(0, 2e-4, (3, 4))  # up to 0.2 per ms: several extra ON crossings
    offset = -rng.random((3, 4)) * c_on
    for refractory in (0, 400):
        events = simulate_events(video, t_us, c_on, c_off, refractory_us=refractory,
                                 drift_per_us=drift, reference_offset=offset)
        expected = scalar_esim(video, t_us, c_on, c_off, refractory, drift, offset)
        assert len(events) > 60
        assert as_sorted_tuples(events) == sorted(expected, key=lambda e: (e[2], e[1], e[0], e[3]))


def test_drift_alone_makes_on_events_at_known_times():
    # a static pixel whose log intensity ramps up by 0.05 per ms crosses C = 0.2 every 4 ms;
    # with the reference lowered by 0.1 the first crossing comes after 2 ms (9 ms: 2 events)
    video = np.full((2, 1, 1), 0.5)
    events = simulate_events(video, [0, 9000], drift_per_us=0.05 / 1000, reference_offset=-0.1)
    np.testing.assert_array_equal(events["t"], [2000, 6000])
    assert np.all(events["p"] == 1)


def test_per_pixel_threshold_arrays_equal_the_drawn_ones():
    video = np.random.default_rng(13).random((6, 5, 7))
    t = np.arange(6) * 1000
    c_on, c_off = draw_thresholds((5, 7), 0.15, 0.25, 0.05, seed=4)
    np.testing.assert_array_equal(simulate_events(video, t, c_on, c_off),
                                  simulate_events(video, t, 0.15, 0.25, 0.05, seed=4))
    with pytest.raises(ValueError, match=r"one threshold per pixel \(5, 7\)"):
        simulate_events(video, t, c_on[:, :3])
    with pytest.raises(ValueError, match="contrast_neg must hold finite thresholds > 0"):
        simulate_events(video, t, c_on, -c_off)


def test_apply_refractory_hand_computed():
    from e2vlib.events import make_events

    # pixel (0, 0) at 0, 100, 300, 350, 700 with 300 us: 0 kept, 100 dropped, 300 kept,
    # 350 dropped, 700 kept; pixel (1, 0) on its own; the order of the stream is kept
    events = make_events([0, 1, 0, 0, 1, 0, 0], [0, 0, 0, 0, 0, 0, 0],
                         [0, 50, 100, 300, 320, 350, 700], [1, -1, 1, -1, 1, 1, 1])
    kept = apply_refractory(events, 300)
    assert kept["t"].tolist() == [0, 50, 300, 700]
    assert kept["x"].tolist() == [0, 1, 0, 0] and kept["p"].tolist() == [1, -1, -1, 1]
    # at equal times the earlier event in the stream wins
    tie = make_events([2, 2], [1, 1], [10, 10], [-1, 1])
    assert apply_refractory(tie, 1)["p"].tolist() == [-1]
    assert apply_refractory(events, 0) is events
    with pytest.raises(ValueError, match="refractory_us must be a finite number >= 0"):
        apply_refractory(events, -5)


def test_apply_refractory_matches_a_loop_over_events():
    from e2vlib.events import make_events

    rng = np.random.default_rng(14)
    n = 3000
    events = make_events(rng.integers(0, 4, n), rng.integers(0, 3, n),
                         np.sort(rng.integers(0, 200_000, n)), rng.choice([-1, 1], n))
    last, expected = {}, []
    for e in events.tolist():
        x, y, t, _ = e
        if t - last.get((x, y), -(10**18)) >= 700:
            last[(x, y)] = t
            expected.append(e)
    assert apply_refractory(events, 700).tolist() == expected
    assert 100 < len(expected) < n


def test_net_polarity_tracks_total_log_change():
    # invariant: per pixel, n_on*C_on - n_off*C_off is the reference's total move, and the
    # last frame lies within one threshold of the reference
    rng = np.random.default_rng(3)
    video = rng.integers(0, 256, size=(10, 6, 7), dtype=np.uint8)
    events = simulate_events(video, np.arange(10) * 1000, contrast_pos=0.1, contrast_neg=0.3)
    logs = np.log(video / 255.0 + EPS)
    net = np.zeros((6, 7))
    np.add.at(net, (events["y"], events["x"]), np.where(events["p"] > 0, 0.1, -0.3))
    residual = logs[-1] - (logs[0] + net)
    assert np.all(residual > -0.3 - 1e-9) and np.all(residual < 0.1 + 1e-9)
    assert np.all(events["t"] >= 0) and np.all(events["t"] <= 9000)


def test_events_sorted_and_valid():
    rng = np.random.default_rng(0)
    video = rng.random((6, 9, 11)).astype(np.float32)
    events = simulate_events(video, [0, 7, 20, 33, 50, 51])
    validate(events, (11, 9))
    assert np.all(np.diff(events["t"]) >= 0)
    # every event lies inside the frame interval that made it, and frame pairs come in order
    assert events["t"].min() >= 0 and events["t"].max() <= 51


def test_uint8_equals_float_divided_by_255():
    rng = np.random.default_rng(1)
    video = rng.integers(0, 256, size=(6, 5, 8), dtype=np.uint8)
    t = np.arange(6) * 400
    a = simulate_events(video, t, contrast_sigma=0.03, seed=2)
    b = simulate_events(video.astype(np.float64) / 255.0, t, contrast_sigma=0.03, seed=2)
    assert len(a) > 100
    np.testing.assert_array_equal(a, b)


def test_threshold_spread_is_deterministic_per_seed():
    rng = np.random.default_rng(4)
    video = rng.random((5, 8, 8))
    t = np.arange(5) * 1000
    a = simulate_events(video, t, contrast_sigma=0.05, seed=1)
    b = simulate_events(video, t, contrast_sigma=0.05, seed=1)
    c = simulate_events(video, t, contrast_sigma=0.05, seed=2)
    plain = simulate_events(video, t)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert not np.array_equal(a, plain)


def test_draw_thresholds_clip_and_constant():
    on, off = draw_thresholds((50, 50), 0.2, 0.3, contrast_sigma=0.5, seed=0)
    assert on.min() == MIN_CONTRAST and off.min() == MIN_CONTRAST
    assert abs(np.median(on) - 0.2) < 0.05 and abs(np.median(off) - 0.3) < 0.05
    on, off = draw_thresholds((2, 3), 0.2, 0.3)
    assert np.all(on == 0.2) and np.all(off == 0.3) and on.shape == (2, 3)


def test_input_is_not_modified():
    rng = np.random.default_rng(5)
    video = rng.random((4, 3, 3)).astype(np.float32)
    t = np.array([0, 10, 20, 30])
    before, t_before = video.copy(), t.copy()
    simulate_events(video, t, refractory_us=5, contrast_sigma=0.1, seed=0)
    np.testing.assert_array_equal(video, before)
    np.testing.assert_array_equal(t, t_before)


@pytest.mark.parametrize(
    "video, t_us, kwargs, match",
    [
        (np.zeros((3, 4)), [0, 1, 2], {}, "shape"),
        (np.zeros((3, 2, 2, 3)), [0, 1, 2], {}, "shape"),
        (np.zeros((1, 2, 2)), [0], {}, "at least 2 frames"),
        (np.zeros((3, 2, 2)), [0, 1], {}, "one time per frame"),
        (np.zeros((3, 2, 2)), [0, 2, 2], {}, "strictly increasing"),
        (np.zeros((3, 2, 2)), [0, 2, 1], {}, "strictly increasing"),
        (np.zeros((3, 2, 2)), [0, 1.5, 3], {}, "whole microseconds"),
        (np.full((3, 2, 2), np.nan), [0, 1, 2], {}, "NaN/inf"),
        (np.array([[[0.1]], [[np.inf]]]), [0, 1], {}, "NaN/inf values in 1 frames"),
        (np.full((2, 2, 2), -0.1), [0, 1], {}, r"\[0, 1\]"),
        (np.full((2, 2, 2), 1.5), [0, 1], {}, r"\[0, 1\]"),
        (np.zeros((2, 2, 2), dtype=np.int16), [0, 1], {}, "uint8"),
        (np.zeros((2, 2, 2)), [0, 1], {"contrast_pos": 0}, "contrast_pos"),
        (np.zeros((2, 2, 2)), [0, 1], {"contrast_neg": -0.2}, "contrast_neg"),
        (np.zeros((2, 2, 2)), [0, 1], {"contrast_sigma": -1}, "contrast_sigma"),
        (np.zeros((2, 2, 2)), [0, 1], {"refractory_us": -1}, "refractory_us"),
        (np.zeros((2, 2, 2)), [0, 1], {"log_eps": 0}, "log_eps"),
        (np.zeros((2, 2, 2)), [0, 1], {"drift_per_us": np.zeros((3, 3))}, r"per pixel \(2, 2\)"),
        (np.zeros((2, 2, 2)), [0, 1], {"reference_offset": np.nan}, "reference_offset"),
        (np.zeros((2, 2, 2)), [0, 1], {"contrast_pos": np.ones((2, 3))}, "one threshold per pixel"),
    ],
)
def test_bad_input_raises_value_error(video, t_us, kwargs, match):
    with pytest.raises(ValueError, match=match):
        simulate_events(video, t_us, **kwargs)


# --- bounded memory and time range (issue 14) ---------------------------------------------


def _noise_video(n=20, side=8, seed=0):
    return np.random.default_rng(seed).random((n, side, side))


def test_tiny_contrast_raises_before_allocating(monkeypatch):
    # contrast 1e-6 on an 8 x 8 noise video: about 1.2e9 events (once 65 M were made)
    import tracemalloc

    from e2vlib.simulate import MAX_EVENTS, TooManyEventsError

    video = _noise_video()
    tracemalloc.start()
    with pytest.raises(TooManyEventsError, match=r"more than max_events=50,000,000 events") as info:
        simulate_events(video, np.arange(20) * 1000, contrast_pos=1e-6, contrast_neg=1e-6)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 10 * 2**20  # nothing near the 65 M events was allocated
    message = str(info.value)
    assert "Raise the contrast thresholds" in message and "contrast_pos=1e-06" in message
    assert "simulate.event_count_bound" in message
    assert MAX_EVENTS == 50_000_000
    assert issubclass(TooManyEventsError, ValueError)


def test_max_events_is_exact_and_overridable():
    from e2vlib.simulate import TooManyEventsError

    video, t = _noise_video(), np.arange(20) * 1000
    n = len(simulate_events(video, t, 0.05, 0.05))
    assert n > 1000
    assert len(simulate_events(video, t, 0.05, 0.05, max_events=n)) == n  # at the limit: fine
    with pytest.raises(TooManyEventsError, match=f"max_events={n - 1:,}"):
        simulate_events(video, t, 0.05, 0.05, max_events=n - 1)
    with pytest.raises(ValueError, match="max_events must be a whole number"):
        simulate_events(video, t, max_events=-1)


def test_threshold_so_small_the_count_overflows_int64_is_refused():
    from e2vlib.simulate import TooManyEventsError

    video = np.array([0.0, 1.0]).reshape(2, 1, 1)  # log change 6.9 / 1e-300 events
    with pytest.raises(TooManyEventsError):
        simulate_events(video, [0, 1000], contrast_pos=1e-300, contrast_neg=1e-300)


@pytest.mark.parametrize("contrast, sigma", [(0.2, 0.0), (0.05, 0.0), (0.1, 0.03)])
def test_event_count_bound_is_an_upper_bound(contrast, sigma):
    from e2vlib.simulate import draw_thresholds, event_count_bound

    video = _noise_video(30, 6, seed=3).astype(np.float32)
    events = simulate_events(video, np.arange(30) * 100, contrast, contrast,
                             contrast_sigma=sigma, seed=1)
    on, off = draw_thresholds((6, 6), contrast, contrast, sigma, seed=1)
    bound = event_count_bound(video, on, off)
    assert len(events) <= bound
    assert bound < 1.5 * len(events) + 36  # and not a wild over-estimate on noise


def test_event_count_bound_known_answer_for_uint8():
    from e2vlib.simulate import event_count_bound

    video = np.array([0, 255, 0], np.uint8).reshape(3, 1, 1)
    expected = 2 * (math.log(1 + EPS) - math.log(EPS)) / 0.25
    assert event_count_bound(video, 0.5, 0.25) == pytest.approx(expected)


@pytest.mark.parametrize("t_us", [
    np.array([0.0, 2.0**63]),                        # wraps to -2**63 when cast
    np.array([0, 2**63 + 10], np.uint64),            # wraps as well
    np.array([0, 2**53 + 2], np.int64),              # not exact in float64
    np.array([-(2**62), 0], np.int64),
])
def test_frame_times_outside_the_exact_range_raise(t_us):
    with pytest.raises(ValueError, match=r"t_us must lie within \+-9007199254740992 us"):
        simulate_events(np.zeros((2, 1, 1)), t_us)


def test_frame_times_near_the_limit_are_exact():
    from e2vlib.simulate import MAX_ABS_TIME_US

    start = MAX_ABS_TIME_US - 10_000
    events = simulate_events(one_pixel_video([L0, L0 + 1.05]), [start, start + 10_000])
    expected = start + np.rint(np.arange(1, 6) * 0.2 / 1.05 * 10_000).astype(np.int64)
    np.testing.assert_array_equal(events["t"], expected)


def test_long_frame_gaps_on_big_frames_sort_without_overflow():
    # (time since the frame) * pixels would pass int64 for a 2**54 us gap on 32 x 32 pixels;
    # the order must still be by time, then pixel
    video = np.full((2, 32, 32), 0.2)
    video[1] = np.random.default_rng(0).uniform(0.3, 0.9, (32, 32))
    t = np.array([-(2**53), 2**53], np.int64)
    events = simulate_events(video, t)
    assert len(events) > 1024
    key = np.lexsort((events["y"].astype(int) * 32 + events["x"], events["t"]))
    np.testing.assert_array_equal(key, np.arange(len(events)))
    assert events["t"].min() >= -(2**53) and events["t"].max() <= 2**53
