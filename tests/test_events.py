import numpy as np
import pytest

from e2vlib.events import EVENT_DTYPE, EventError, make_events, sort_events, validate


def test_dtype_fields_and_units():
    assert EVENT_DTYPE.names == ("x", "y", "t", "p")
    assert [EVENT_DTYPE[n] for n in EVENT_DTYPE.names] == [
        np.dtype(np.uint16), np.dtype(np.uint16), np.dtype(np.int64), np.dtype(np.int8)
    ]


@pytest.mark.parametrize(
    "p_in", [[-1, 1, 1], [0, 1, 1], [False, True, True], np.array([0.0, 1.0, 1.0])]
)
def test_make_events_maps_polarity_conventions(p_in):
    ev = make_events([1, 2, 3], [4, 5, 6], [10, 20, 30], p_in)
    assert ev.dtype == EVENT_DTYPE
    assert ev["p"].tolist() == [-1, 1, 1]
    assert ev["x"].tolist() == [1, 2, 3] and ev["t"].tolist() == [10, 20, 30]


def test_make_events_rejects_bad_polarity_and_lengths():
    with pytest.raises(EventError, match="polarity"):
        make_events([1, 2], [1, 2], [1, 2], [2, 1])
    with pytest.raises(EventError, match="equal length"):
        make_events([1, 2], [1], [1, 2], [1, 1])
    with pytest.raises(EventError, match="NaN"):
        make_events([1.0, np.nan], [1, 1], [1, 2], [1, 1])
    with pytest.raises(EventError, match="whole numbers"):
        make_events([1, 2], [1, 1], [0.5, 2], [1, 1])
    with pytest.raises(EventError, match="outside"):
        make_events([-1, 2], [1, 1], [1, 2], [1, 1])


def test_validate_accepts_good_stream(small_events):
    assert validate(small_events, (4, 3)) is small_events


def test_validate_counts_unsorted_events(small_events):
    shuffled = small_events[[0, 2, 1, 3, 5, 4]]
    with pytest.raises(EventError, match="2 events are earlier") as info:
        validate(shuffled, (4, 3))
    assert "sort" in str(info.value)


def test_validate_counts_pixels_outside_sensor(small_events):
    # x=3 is outside a width-3 sensor and y=2 outside height 2: events 3 and 5
    with pytest.raises(EventError, match="2 of 6 events lie outside the 3x2 sensor"):
        validate(small_events, (3, 2))


def test_validate_rejects_bad_polarity_and_dtype(small_events):
    bad = small_events.copy()
    bad["p"][[1, 2]] = 0
    with pytest.raises(EventError, match="2 events have polarity"):
        validate(bad, (4, 3))
    with pytest.raises(EventError, match="EVENT_DTYPE"):
        validate(np.zeros((3, 4)), (4, 3))
    with pytest.raises(EventError, match="sensor_size"):
        validate(small_events, (4,))
    with pytest.raises(EventError, match="positive"):
        validate(small_events, (0, 3))


def test_event_error_is_value_error():
    assert issubclass(EventError, ValueError)


def test_sort_events_is_stable_and_copies(small_events):
    ev = small_events[::-1].copy()
    ev["t"][:] = [5, 5, 3, 3, 1, 1]
    out = sort_events(ev)
    assert out["t"].tolist() == [1, 1, 3, 3, 5, 5]
    assert out["x"].tolist() == [1, 0, 3, 1, 2, 0]  # equal times keep their order
    assert ev["t"][0] == 5  # the input is unchanged


# --- int64 time range: out-of-range times raise instead of wrapping (issue 14) ---------------


def test_float_time_2_pow_63_raises_naming_the_range():
    # 2**63 is one past int64's largest value; a cast would wrap it to -2**63
    expected = r"outside the int64 microsecond range \[-9223372036854775808, 9223372036854775807\]"
    with pytest.raises(EventError, match=expected):
        make_events([0], [0], [2.0**63], [1])
    with pytest.raises(EventError, match="int64 microsecond range"):
        make_events([0], [0], [-2.0**64], [1])


def test_uint64_time_above_int64_raises():
    with pytest.raises(EventError, match="int64 microsecond range"):
        make_events([0], [0], np.array([2**63 + 5], np.uint64), [1])


def test_extreme_int64_times_are_kept_exactly():
    ev = make_events([0, 0], [0, 0], np.array([-2**63, 2**63 - 1], np.int64), [1, 1])
    assert ev["t"].tolist() == [-2**63, 2**63 - 1]
    ev = make_events([0], [0], np.array([2**63 - 1], np.uint64), [1])
    assert ev["t"].tolist() == [2**63 - 1]
    # the largest float below 2**63 is still a valid time
    assert make_events([0], [0], [np.nextafter(2.0**63, 0)], [1])["t"][0] == 2**63 - 1024


@pytest.mark.parametrize("unit, values, expected", [
    ("s", [0.5, 1.25, -0.000001], [500_000, 1_250_000, -1]),
    ("ms", np.array([3, -2], np.int32), [3000, -2000]),
    ("us", np.array([7], np.uint32), [7]),
    ("ns", np.array([1499, 1500, 2500, -1500, 2**63 - 1], np.int64),
     [1, 2, 2, -2, (2**63 - 1) // 1000 + 1]),
    ("ns", np.array([2**64 - 1], np.uint64), [(2**64 - 1) // 1000 + 1]),
    ("s", np.array([1.5], np.float32), [1_500_000]),
])
def test_times_to_us_known_answers(unit, values, expected):
    from e2vlib.events import times_to_us

    out = times_to_us(values, unit)
    assert out.dtype == np.int64 and out.tolist() == expected


def test_float32_seconds_are_scaled_in_float64():
    from e2vlib.events import times_to_us

    t = np.array([123.456789], np.float32)  # float32 holds 123.45678710937500 exactly
    assert times_to_us(t, "s").tolist() == [123_456_787]  # float32 arithmetic: 123_456_784


@pytest.mark.parametrize("unit, value", [
    ("s", 9223372036854.775808 * 1.001), ("s", 1e300), ("ms", 2**62), ("us", 2**63),
    ("s", -(2**62)), ("us", 2.0**63),
])
def test_times_to_us_refuses_overflow(unit, value):
    from e2vlib.events import times_to_us

    with pytest.raises(EventError, match=r"int64 microsecond range .* store times relative"):
        times_to_us(np.array([value]), unit)


def test_times_to_us_refuses_nan_and_text():
    from e2vlib.events import times_to_us

    with pytest.raises(EventError, match="NaN"):
        times_to_us([0.1, np.nan], "s")
    with pytest.raises(EventError, match="numeric"):
        times_to_us(np.array(["1"]), "s")
    with pytest.raises(ValueError, match="unknown time unit"):
        times_to_us([1], "hours")


def test_add_time_offset_refuses_overflow_both_ways():
    from e2vlib.events import add_time_offset

    assert add_time_offset(np.array([0, 5]), 2**63 - 6).tolist() == [2**63 - 6, 2**63 - 1]
    with pytest.raises(EventError, match="outside the int64"):
        add_time_offset(np.array([0, 6]), 2**63 - 6)
    with pytest.raises(EventError, match="outside the int64"):
        add_time_offset(np.array([-1, 0]), -(2**63))
    with pytest.raises(EventError, match="offset .* outside"):
        add_time_offset(np.array([0]), 2**63)


def test_sensor_size_must_be_whole_pixels(small_events):
    with pytest.raises(EventError, match=r"whole pixels .* got \(50.5, 40\)"):
        validate(small_events, (50.5, 40))
    assert validate(small_events, (4.0, np.int64(3))) is small_events
