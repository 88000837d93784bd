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
