import subprocess
import sys

import numpy as np
import pytest

from e2vlib.events import EventError, make_events
from e2vlib.frames import (
    accumulate,
    downsample,
    paper_group_bounds,
    time_surface,
    voxel_grid,
    window_count,
)


def test_binary_frames_by_hand(small_events):
    # windows of 5000 us from t0 = 0: [0,5000) holds events 0,1,2; [5000,10000) holds 3,4;
    # [10000,15000) holds 5 (the last event gets a window of its own, nothing is dropped)
    frames = accumulate(small_events, (4, 3), dt_us=5000)
    assert frames.shape == (3, 3, 4) and frames.dtype == np.uint8
    expected = np.zeros((3, 3, 4), dtype=np.uint8)
    expected[0, 0, 0] = expected[0, 0, 1] = 1  # (x=1, y=0) fired twice: still 1
    expected[1, 2, 3] = expected[1, 1, 0] = 1
    expected[2, 2, 2] = 1
    np.testing.assert_array_equal(frames, expected)


def test_count_and_polarity_frames_by_hand(small_events):
    counts = accumulate(small_events, (4, 3), dt_us=5000, mode="count")
    assert counts[0, 0, 1] == 2 and counts.sum() == 6
    pol = accumulate(small_events, (4, 3), dt_us=5000, mode="polarity")
    assert pol.shape == (3, 2, 3, 4)
    assert pol[0, 0, 0, 1] == 1 and pol[0, 1, 0, 1] == 1  # one OFF and one ON at (1, 0)
    assert pol[0, 1, 0, 0] == 1 and pol[0, 0, 0, 0] == 0  # ON at (0, 0)
    assert pol[2, 0, 2, 2] == 1  # the last event is OFF
    np.testing.assert_array_equal(pol.sum(axis=1), counts)


def test_windows_are_half_open():
    ev = make_events([0, 0, 0], [0, 0, 0], [4999, 5000, 5001], [1, 1, 1])
    counts = accumulate(ev, (1, 1), dt_us=5000, t0_us=0, mode="count")
    assert counts[:, 0, 0].tolist() == [1, 2]


def test_paper_setting_keeps_every_event_of_half_a_second():
    # 100 windows of 5 ms over [0, 500000): events right at both ends must be kept
    rng = np.random.default_rng(1)
    t = np.sort(np.concatenate([[0, 499_999], rng.integers(0, 500_000, 10_000)]))
    ev = make_events(rng.integers(0, 16, len(t)), rng.integers(0, 8, len(t)), t,
                     np.ones(len(t), dtype=int))
    counts = accumulate(ev, (16, 8), dt_us=5000, t0_us=0, n_frames=100, mode="count")
    assert counts.shape == (100, 8, 16)
    assert counts.sum() == len(ev)
    assert counts[0].sum() == np.sum(t < 5000) and counts[99].sum() == np.sum(t >= 495_000)


def test_events_outside_the_windows_are_left_out(small_events):
    counts = accumulate(small_events, (4, 3), dt_us=5000, t0_us=5000, n_frames=1, mode="count")
    assert counts.shape == (1, 3, 4) and counts.sum() == 2


def test_explicit_empty_windows_and_empty_stream(small_events):
    frames = accumulate(small_events, (4, 3), dt_us=1000, t0_us=100_000, n_frames=3)
    assert frames.shape == (3, 3, 4) and frames.sum() == 0
    empty = small_events[:0]
    assert accumulate(empty, (4, 3)).shape == (0, 3, 4)
    assert window_count(0, 499_999, 5000, 0) == 100
    assert window_count(0, 500_000, 5000, 0) == 101


def test_accumulate_matches_loop_reference(random_events):
    ev, size = random_events
    counts = accumulate(ev, size, dt_us=7000, mode="count")
    ref = np.zeros_like(counts)
    for e in ev:  # the definition, one event at a time
        ref[(e["t"] - ev["t"][0]) // 7000, e["y"], e["x"]] += 1
    np.testing.assert_array_equal(counts, ref)
    np.testing.assert_array_equal(accumulate(ev, size, dt_us=7000), (ref > 0).astype(np.uint8))


def test_accumulate_does_not_mutate_input(random_events):
    ev, size = random_events
    before = ev.copy()
    for mode in ("binary", "count", "polarity"):
        accumulate(ev, size, mode=mode)
    np.testing.assert_array_equal(ev, before)


def test_accumulate_rejects_bad_input(small_events):
    with pytest.raises(EventError, match="outside"):
        accumulate(small_events, (2, 2))
    with pytest.raises(EventError, match="not sorted"):
        accumulate(small_events[::-1], (4, 3))
    with pytest.raises(ValueError, match="mode"):
        accumulate(small_events, (4, 3), mode="sum")
    with pytest.raises(EventError, match="dt_us"):
        accumulate(small_events, (4, 3), dt_us=0)


def test_time_surface_by_hand(small_events):
    # at t = 10000 with tau = 5000: pixel (x=1,y=0) ON last fired at 4999, OFF at 10
    ts = time_surface(small_events, (4, 3), t_us=10_000, tau_us=5000)
    assert ts.shape == (2, 3, 4) and ts.dtype == np.float32
    assert ts[1, 0, 1] == pytest.approx(np.exp(-5001 / 5000))
    assert ts[0, 0, 1] == pytest.approx(np.exp(-9990 / 5000))
    assert ts[0, 2, 2] == pytest.approx(1.0)  # the OFF event at exactly t_us
    assert ts[1, 2, 2] == 0  # never an ON event there
    merged = time_surface(small_events, (4, 3), t_us=9_999, tau_us=5000, split_polarity=False)
    assert merged.shape == (3, 4)
    assert merged[0, 1] == pytest.approx(np.exp(-5000 / 5000))  # most recent of both: 4999
    assert merged[2, 2] == 0  # the event at 10000 is in the future


def test_voxel_grid_bilinear_in_time():
    # span 0..100 us, 3 bins -> t* = 0, 0.5, 2 for the three events
    ev = make_events([0, 1, 1], [0, 0, 0], [0, 25, 100], [1, -1, 1])
    vg = voxel_grid(ev, (2, 1), n_bins=3)
    assert vg.shape == (3, 1, 2) and vg.dtype == np.float32
    np.testing.assert_allclose(vg[:, 0, 0], [1, 0, 0])
    np.testing.assert_allclose(vg[:, 0, 1], [-0.5, -0.5, 1])


def test_voxel_grid_preserves_total_polarity(random_events):
    ev, size = random_events
    vg = voxel_grid(ev, size, n_bins=5)
    assert vg.sum() == pytest.approx(float(ev["p"].sum()), abs=1e-2)


def test_downsample_max_for_binary_sum_for_counts():
    frames = np.zeros((1, 4, 4), dtype=np.uint8)
    frames[0, 0, 0] = frames[0, 1, 1] = frames[0, 3, 2] = 1
    np.testing.assert_array_equal(downsample(frames, 2)[0], [[1, 0], [0, 1]])
    counts = frames.astype(np.int32) * 3
    np.testing.assert_array_equal(downsample(counts, 2)[0], [[6, 0], [0, 3]])
    pol = np.ones((2, 2, 4, 6), dtype=np.int32)
    assert downsample(pol, 2).shape == (2, 2, 2, 3) and downsample(pol, 2).sum() == pol.sum()
    with pytest.raises(ValueError, match="divisible"):
        downsample(np.zeros((1, 5, 4)), 2)


def test_downsample_pools_blocks_as_the_reshape_definition():
    # block (i, j) of the result pools rows f*i .. f*i+f-1 and columns f*j .. f*j+f-1
    rng = np.random.default_rng(2)
    for dtype, reduce, out in ((np.uint8, "max", np.uint8), (np.bool_, "max", np.bool_),
                               (np.int32, "sum", np.int64), (np.float32, "sum", np.float32),
                               (np.uint8, "sum", np.uint64), (np.int32, "max", np.int32)):
        a = (rng.random((3, 2, 6, 9)) * 4).astype(dtype)
        blocks = a.reshape(3, 2, 2, 3, 3, 3)
        expected = blocks.max(axis=(-3, -1)) if reduce == "max" else blocks.sum(axis=(-3, -1))
        got = downsample(a, 3, reduce)
        assert got.dtype == out and got.shape == (3, 2, 2, 3)
        np.testing.assert_array_equal(got, expected)
    assert downsample(np.zeros((0, 4, 4), np.uint8), 2).shape == (0, 2, 2)
    with pytest.raises(ValueError, match="factor must be a positive integer"):
        downsample(np.zeros((1, 4, 4)), 0)
    with pytest.raises(ValueError, match="at least 2 dimensions"):
        downsample(np.zeros(4), 2)
    with pytest.raises(ValueError, match="reduce must be"):
        downsample(np.zeros((1, 4, 4)), 2, "mean")


@pytest.mark.parametrize("t0", [2.5, "0", 2**63, float("nan")])
def test_bad_t0_is_a_named_error(small_events, t0):
    with pytest.raises(EventError, match="t0_us must be a whole number of microseconds"):
        accumulate(small_events, (4, 3), t0_us=t0)


def test_paper_group_bounds_read_the_strided_time_column(small_events):
    t = small_events["t"]  # a strided view into the structured array
    assert not t.flags.c_contiguous
    np.testing.assert_array_equal(paper_group_bounds(t, 5000), paper_group_bounds(t.copy(), 5000))
    bounds = paper_group_bounds(t, 5000)
    assert bounds[0] == 0 and bounds[-1] == len(t) and np.all(np.diff(bounds) > 0)
    for g in range(len(bounds) - 1):  # each group spans at most dt from its first event
        assert t[bounds[g + 1] - 1] - t[bounds[g]] <= 5000
        if bounds[g + 1] < len(t):  # and the next event is past it
            assert t[bounds[g + 1]] - t[bounds[g]] > 5000


# --- the paper's Eq. 5 grouping (windows="paper") ------------------------------------------


def _eq5_reference(t, dt):
    """Eq. 5 written out event by event: a list of groups (lists of event indices)."""
    groups, j = [], None
    for i, ti in enumerate(t):
        if j is None or ti - t[j] > dt:
            groups.append([])
            j = i
        groups[-1].append(i)
    return groups


def test_paper_groups_are_inclusive_and_start_at_events():
    # dt = 5: the group of t_j = 0 takes 0, 3 and 5 (5 - 0 <= 5, inclusive); 6 starts the
    # next group, whose window [6, 11] is closed at 11; 20 starts a third. Fixed windows
    # would instead split at the clock ticks 5, 10, 15, 20 and leave [15, 20) empty.
    ev = make_events([0, 1, 2, 3, 0, 1], [0] * 6, [0, 3, 5, 6, 11, 20], [1] * 6)
    paper = accumulate(ev, (4, 1), dt_us=5, mode="count", windows="paper")
    assert paper[:, 0].tolist() == [[1, 1, 1, 0], [1, 0, 0, 1], [0, 1, 0, 0]]
    fixed = accumulate(ev, (4, 1), dt_us=5, mode="count")
    assert fixed[:, 0].tolist() == [[1, 1, 0, 0], [0, 0, 1, 1], [1, 0, 0, 0], [0, 0, 0, 0],
                                    [0, 1, 0, 0]]


def test_paper_groups_are_never_empty_across_gaps():
    ev = make_events([0, 0, 0], [0, 0, 0], [0, 1_000, 1_000_000], [1, -1, 1])
    frames = accumulate(ev, (1, 1), dt_us=5000, windows="paper")
    assert frames.shape == (2, 1, 1) and frames.min() == 1  # two groups, none empty
    assert accumulate(ev, (1, 1), dt_us=5000).shape == (201, 1, 1)  # fixed: 199 empty


def test_paper_groups_with_n_frames_pad_at_the_end_and_drop_later_groups():
    ev = make_events([0, 1, 0], [0, 0, 0], [0, 10, 20], [1, 1, 1])
    padded = accumulate(ev, (2, 1), dt_us=5, n_frames=5, mode="count", windows="paper")
    assert padded[:, 0].tolist() == [[1, 0], [0, 1], [1, 0], [0, 0], [0, 0]]
    cut = accumulate(ev, (2, 1), dt_us=5, n_frames=2, mode="count", windows="paper")
    assert cut[:, 0].tolist() == [[1, 0], [0, 1]]  # the group at t = 20 is dropped


def test_paper_groups_start_at_t0():
    ev = make_events([0, 1, 0], [0, 0, 0], [0, 10, 12], [1, 1, 1])
    frames = accumulate(ev, (2, 1), dt_us=5, t0_us=5, mode="count", windows="paper")
    assert frames[:, 0].tolist() == [[1, 1]]  # the event at t = 0 is before t0: left out


def test_paper_groups_match_the_event_by_event_reference():
    rng = np.random.default_rng(3)
    # bursts and gaps, with repeated time stamps
    t = np.sort(np.concatenate([rng.integers(0, 40_000, 3_000),
                                rng.integers(90_000, 91_000, 500), [200_000] * 4]))
    x, y = rng.integers(0, 8, len(t)), rng.integers(0, 6, len(t))
    ev = make_events(x, y, t, rng.choice([-1, 1], len(t)))
    counts = accumulate(ev, (8, 6), dt_us=5000, mode="count", windows="paper")
    groups = _eq5_reference(t, 5000)
    assert len(counts) == len(groups) and counts.sum() == len(t)
    expected = np.zeros_like(counts)
    for k, members in enumerate(groups):
        np.add.at(expected[k], (y[members], x[members]), 1)
        assert t[members[-1]] - t[members[0]] <= 5000
    np.testing.assert_array_equal(counts, expected)
    binary = accumulate(ev, (8, 6), dt_us=5000, windows="paper")
    np.testing.assert_array_equal(binary, (expected > 0).astype(np.uint8))
    pol = accumulate(ev, (8, 6), dt_us=5000, mode="polarity", windows="paper")
    np.testing.assert_array_equal(pol.sum(axis=1), counts)


def test_windows_must_be_named():
    ev = make_events([0], [0], [0], [1])
    with pytest.raises(ValueError, match="windows must be one of"):
        accumulate(ev, (1, 1), windows="clock")


@pytest.mark.parametrize("dt", [float("nan"), float("inf"), 0, -5, 2.5, "5ms"])
def test_bad_dt_is_a_named_error(dt):
    ev = make_events([0], [0], [0], [1])
    for windows in ("fixed", "paper"):
        with pytest.raises(EventError, match="dt_us must be a positive whole number"):
            accumulate(ev, (1, 1), dt_us=dt, windows=windows)


def test_huge_frame_stacks_are_refused_before_allocating():
    # 1 us windows starting a day before the events would need ~ 86e9 frames
    ev = make_events([0], [0], [86_400_000_000], [1])
    with pytest.raises(EventError, match="GiB"):
        accumulate(ev, (64, 64), dt_us=1, t0_us=0)


# --- accumulate_fast (e2vlib.scale.frames_numba) against accumulate -----------------------

try:
    from e2vlib.scale import frames_numba
except ImportError:  # numba is not installed
    frames_numba = None
needs_numba = pytest.mark.skipif(frames_numba is None, reason="numba is not installed")
BACKENDS = ["numpy", pytest.param("numba", marks=needs_numba)]


def _accumulator(backend: str):
    """``accumulate`` (numpy) or ``accumulate_fast`` (numba): the same arguments."""
    return accumulate if backend == "numpy" else frames_numba.accumulate_fast


@pytest.mark.parametrize("backend", BACKENDS)
def test_each_backend_gives_the_hand_computed_frames(small_events, backend):
    acc, ev, size = _accumulator(backend), small_events, (4, 3)
    binary = acc(ev, size, dt_us=5000)
    expected = np.zeros((3, 3, 4), dtype=np.uint8)
    expected[0, 0, 0] = expected[0, 0, 1] = expected[1, 2, 3] = expected[1, 1, 0] = 1
    expected[2, 2, 2] = 1
    np.testing.assert_array_equal(binary, expected)
    assert binary.dtype == np.uint8
    counts = acc(ev, size, dt_us=5000, mode="count")
    assert counts.dtype == np.int32 and counts[0, 0, 1] == 2 and counts.sum() == 6
    pol = acc(ev, size, dt_us=5000, mode="polarity")
    assert pol.shape == (3, 2, 3, 4) and pol.dtype == np.int32
    assert pol[0, 0, 0, 1] == pol[0, 1, 0, 1] == pol[0, 1, 0, 0] == pol[2, 0, 2, 2] == 1
    np.testing.assert_array_equal(pol.sum(axis=1), counts)
    # t0 and n_frames: only [5000, 10000) is kept; padding windows after the events are empty
    one = acc(ev, size, dt_us=5000, t0_us=5000, n_frames=1, mode="count")
    assert one.shape == (1, 3, 4) and one.sum() == 2
    padded = acc(ev, size, dt_us=5000, t0_us=0, n_frames=5, mode="count")
    assert padded.shape == (5, 3, 4) and padded[:3].sum() == 6 and padded[3:].sum() == 0
    assert acc(ev, size, dt_us=5000, n_frames=0).shape == (0, 3, 4)
    late = acc(ev, size, dt_us=1000, t0_us=100_000, n_frames=3)
    assert late.shape == (3, 3, 4) and late.sum() == 0
    for mode, shape in (("binary", (0, 3, 4)), ("polarity", (0, 2, 3, 4))):
        assert acc(ev[:0], size, mode=mode).shape == shape
        assert acc(ev[:0], size, mode=mode, windows="paper").shape == shape


@pytest.mark.parametrize("backend", BACKENDS)
def test_each_backend_gives_the_hand_computed_paper_groups(backend):
    acc = _accumulator(backend)
    ev = make_events([0, 1, 2, 3, 0, 1], [0] * 6, [0, 3, 5, 6, 11, 20], [1, 1, -1, 1, 1, -1])
    kw = {"dt_us": 5, "windows": "paper"}
    counts = acc(ev, (4, 1), mode="count", **kw)
    assert counts[:, 0].tolist() == [[1, 1, 1, 0], [1, 0, 0, 1], [0, 1, 0, 0]]
    pol = acc(ev, (4, 1), mode="polarity", **kw)
    assert pol[:, 0, 0].tolist() == [[0, 0, 1, 0], [0, 0, 0, 0], [0, 1, 0, 0]]  # OFF
    assert pol[:, 1, 0].tolist() == [[1, 1, 0, 0], [1, 0, 0, 1], [0, 0, 0, 0]]  # ON
    # n_frames pads at the end and drops later groups; t0 leaves out earlier events
    padded = acc(ev, (4, 1), mode="count", n_frames=4, **kw)
    assert padded[:, 0].tolist() == counts[:, 0].tolist() + [[0, 0, 0, 0]]
    assert acc(ev, (4, 1), mode="count", n_frames=1, **kw)[:, 0].tolist() == [[1, 1, 1, 0]]
    late = acc(ev, (4, 1), mode="count", t0_us=4, **kw)  # groups {5, 6} {11} {20}
    assert late[:, 0].tolist() == [[0, 0, 1, 1], [1, 0, 0, 0], [0, 1, 0, 0]]
    gaps = make_events([0, 0, 0], [0, 0, 0], [0, 1_000, 1_000_000], [1, -1, 1])
    assert acc(gaps, (1, 1), dt_us=5000, windows="paper").shape[0] == 2


@pytest.mark.parametrize("backend", BACKENDS)
def test_each_backend_counts_past_uint16_and_times_at_the_int64_ends(backend):
    acc = _accumulator(backend)
    # 70,000 events on one pixel in one window: more than the kernel's uint16 scratch holds
    n = 70_000
    ev = make_events(np.zeros(n, int), np.zeros(n, int), np.arange(n) // 10, np.ones(n, int))
    counts = acc(ev, (3, 2), dt_us=10_000, mode="count")
    assert counts.shape == (1, 2, 3) and counts[0, 0, 0] == n and counts.sum() == n
    pol = acc(ev, (3, 2), dt_us=10_000, mode="polarity", windows="paper")
    assert pol[0, 1, 0, 0] == n and pol.sum() == n
    # times at both ends of int64: the span overflows int64, windows of 2^62 us still work
    lo, hi = np.iinfo(np.int64).min, np.iinfo(np.int64).max
    ends = make_events([0, 1, 1], [0, 0, 0], [lo, 0, hi], [1, -1, 1])
    wide = acc(ends, (2, 1), dt_us=2**62, mode="count")
    assert wide[:, 0].tolist() == [[1, 0], [0, 0], [0, 1], [0, 1]]
    groups = acc(ends, (2, 1), dt_us=2**63, mode="count", windows="paper")
    assert groups[:, 0].tolist() == [[1, 1], [0, 1]]  # 0 - lo = 2^63 <= dt; hi - 0 < dt too
    # one window as long as the whole int64 range: t - t0 = 2^64 - 1 is its last microsecond
    whole = acc(ends, (2, 1), dt_us=2**64 - 1, mode="count")
    assert whole[:, 0].tolist() == [[1, 1], [0, 1]]


@needs_numba
def test_backends_raise_the_same_errors(small_events):
    bad_p = small_events.copy()
    bad_p["p"][2] = 0
    wrong_dtype = np.zeros(3, dtype=[("x", "<i8"), ("y", "<i8"), ("t", "<i8"), ("p", "<i8")])
    cases = [(small_events, (2, 2), {}), (small_events[::-1], (4, 3), {}), (bad_p, (4, 3), {}),
             (wrong_dtype, (4, 3), {}), (np.zeros(3), (4, 3), {}),
             (small_events, (4, 3), {"dt_us": 0}), (small_events, (4, 3), {"t0_us": 2.5}),
             (small_events, (4, 3), {"n_frames": -1}),
             (bad_p, (4, 3), {"dt_us": 0}),  # broken events are reported before settings
             (small_events, (65535, 65535), {"t0_us": 0, "n_frames": 10**6})]
    for events, size, kwargs in cases:
        for windows in ("fixed", "paper"):
            messages = []
            for backend in ("numpy", "numba"):
                with pytest.raises(EventError) as err:
                    _accumulator(backend)(events, size, windows=windows, mode="count", **kwargs)
                messages.append(str(err.value))
            assert messages[0] == messages[1]


def test_frames_imports_neither_numba_nor_the_scale_band():
    code = ("import sys, e2vlib.frames; print(sorted(m for m in sys.modules "
            "if m.split('.')[0] == 'numba' or m.startswith('e2vlib.scale')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == "[]"


@needs_numba
@pytest.mark.parametrize("threads", [False, True])
@pytest.mark.parametrize("windows", ["fixed", "paper"])
@pytest.mark.parametrize("mode", ["binary", "count", "polarity"])
def test_backends_agree_on_sparse_and_busy_frames(mode, windows, threads, monkeypatch):
    if threads:  # cut into 3 parts counted in threads, as streams of >= 1 M events are
        monkeypatch.setattr(frames_numba, "THREADED_MIN_EVENTS", 1)
        monkeypatch.setattr(frames_numba, "_cores", lambda: 3)
    # a big sensor with a few events per frame (flushed event by event) and bursts that
    # fill frames (flushed pixel by pixel), with gaps, repeated times and a t0 inside
    rng = np.random.default_rng(7)
    t = np.sort(np.concatenate([rng.integers(0, 200_000, 300),
                                rng.integers(300_000, 310_000, 40_000), [400_000] * 5]))
    ev = make_events(rng.integers(0, 96, len(t)), rng.integers(0, 64, len(t)), t,
                     rng.choice([-1, 1], len(t)))
    for t0, n in ((None, None), (150_000, None), (0, 7), (5_000, 300)):
        kw = {"dt_us": 3_000, "t0_us": t0, "n_frames": n, "mode": mode, "windows": windows}
        ref = accumulate(ev, (96, 64), **kw)
        fast = frames_numba.accumulate_fast(ev, (96, 64), **kw)
        assert fast.dtype == ref.dtype and fast.shape == ref.shape
        np.testing.assert_array_equal(fast, ref)


@needs_numba
@pytest.mark.parametrize("windows", ["fixed", "paper"])
def test_threaded_counting_reports_unsorted_times(windows, monkeypatch):
    # each half sorted, the later half first: the cuts found by bisection or galloping mean
    # nothing then, and the parts' own checks (or the one across each cut) must report it
    monkeypatch.setattr(frames_numba, "THREADED_MIN_EVENTS", 1)
    monkeypatch.setattr(frames_numba, "_cores", lambda: 2)
    rng = np.random.default_rng(3)
    t = np.sort(rng.integers(0, 100_000, 2_000))
    t = np.concatenate([t[1_000:], t[:1_000]])
    ev = make_events(rng.integers(0, 8, 2_000), rng.integers(0, 8, 2_000), t,
                     rng.choice([-1, 1], 2_000))
    with pytest.raises(EventError, match="not sorted"):
        frames_numba.accumulate_fast(ev, (8, 8), dt_us=5_000, t0_us=0, n_frames=20,
                                     windows=windows)


@needs_numba
def test_accumulate_fast_matches_accumulate_on_many_random_streams():
    # a seeded sweep beside the Hypothesis properties (tests/test_properties.py): sensors,
    # lengths, bursts, t0 and n_frames drawn at random, every mode and both windows
    rng = np.random.default_rng(11)
    for _ in range(40):
        width, height = int(rng.integers(1, 50)), int(rng.integers(1, 40))
        n = int(rng.integers(0, 4_000))
        t = np.sort(rng.integers(0, int(rng.choice([1_000, 100_000, 2_000_000])), n))
        ev = make_events(rng.integers(0, width, n), rng.integers(0, height, n),
                         t + int(rng.choice([0, -10**6, 1_700_000_000_000_000])),
                         rng.choice([-1, 1], n))
        t0 = None if rng.random() < 0.5 or not n else int(ev["t"][int(rng.integers(0, n))])
        n_frames = None if rng.random() < 0.5 else int(rng.integers(0, 60))
        dt = int(rng.integers(1, 20_000))
        for mode in ("binary", "count", "polarity"):
            for windows in ("fixed", "paper"):
                kw = {"dt_us": dt, "t0_us": t0, "n_frames": n_frames, "mode": mode,
                      "windows": windows}
                ref = accumulate(ev, (width, height), **kw)
                fast = frames_numba.accumulate_fast(ev, (width, height), **kw)
                assert fast.dtype == ref.dtype and fast.shape == ref.shape
                np.testing.assert_array_equal(fast, ref)
