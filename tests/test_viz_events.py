import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from e2vlib import viz  # noqa: E402
from e2vlib.frames import accumulate  # noqa: E402


@pytest.mark.parametrize("dt_ms,index", [(5.0, 0), (5.0, 50), (1.0, 3), (50.0, 9), (20.0, 999)])
def test_show_frame_returns_the_accumulated_frame(random_events, dt_ms, index):
    ev, size = random_events
    frame, ax = viz.show_frame(ev, size, dt_ms=dt_ms, index=index)
    stack = accumulate(ev, size, dt_us=round(dt_ms * 1000))
    expected = stack[min(index, len(stack) - 1)]  # an index past the end shows the last frame
    np.testing.assert_array_equal(frame, expected)
    assert ax.images[0].get_array().shape == (24, 32)
    plt.close("all")


def test_event_rate_integrates_to_event_count(random_events):
    ev, _ = random_events
    ax = viz.plot_event_rate(ev, bin_us=10_000)
    total = 0.0
    for artist in ax.patches:  # one stairs artist per polarity, values in events/s
        total += artist.get_data().values.sum() * 0.01
    assert total == pytest.approx(len(ev))
    plt.close("all")


def test_events_3d_draws_both_polarities_and_subsamples(random_events):
    ev, size = random_events
    ax = viz.plot_events_3d(ev, size, max_events=1000)
    sizes = [len(c.get_offsets()) for c in ax.collections]
    assert len(sizes) == 2 and sum(sizes) == 1000
    plt.close("all")


def test_frame_grid_and_animation_shapes():
    stack = np.zeros((7, 4, 6), dtype=np.uint8)
    fig = viz.plot_frame_grid(stack, n_cols=3)
    assert sum(1 for ax in fig.axes if ax.images) == 7 and len(fig.axes) == 9
    anim = viz.animate_frames(stack, interval_ms=10)
    assert "<script" in anim.to_jshtml()
    with pytest.raises(ValueError, match=r"\(n, H, W\)"):
        viz.plot_frame_grid(np.zeros((4, 6)))
    plt.close("all")
