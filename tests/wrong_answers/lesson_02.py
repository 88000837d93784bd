"""Wrong answers for lesson 02 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # groups chained from the previous event (t_i - t_{i-1} <= dt) instead of the group's first
    1: """answer_1 = {"groups": 4, "starts": [0, 12, 30, 41],
            "fixed_windows": 9, "empty_windows": 3}
""",
    # a window without an Eq. 5 group taken as an empty window (1 - groups / windows)
    2: """answer_2 = {}
for dt in (100, 200, 500, 1000, 2000, 5000):
    n_windows = paper.RECORDING_US // dt
    n_groups = len(frames.paper_group_bounds(events["t"], dt)) - 1
    answer_2[dt] = (1 - n_groups / n_windows, n_groups)
""",
    # kept the paper's 100 frames, so the stream is cut after 0.5 s
    3: """paused = events.copy()
paused["t"][paused["t"] >= t0 + 250_000] += 50_000
fixed3 = frames.accumulate(paused, sensor_size, dt_us=DT_US, t0_us=t0, n_frames=N_FRAMES)
answer_3 = {"fixed_windows": len(fixed3),
            "empty_windows": int(np.sum(fixed3.sum(axis=(1, 2)) == 0)),
            "groups": len(frames.paper_group_bounds(paused["t"], DT_US)) - 1}
""",
    # divided by the ON pixels instead of all pixels that are 1
    4: """answer_4 = {}
for dt in (5000, 50_000):
    n = paper.RECORDING_US // dt
    on = frames.accumulate(events[events["p"] > 0], sensor_size, dt_us=dt, t0_us=t0, n_frames=n)
    off = frames.accumulate(events[events["p"] < 0], sensor_size, dt_us=dt, t0_us=t0, n_frames=n)
    answer_4[dt] = (on & off).sum() / on.sum()
""",
    # pixel (0, 0)'s first event used instead of its latest
    5: "answer_5 = [np.exp(-(50 - 0) / 10), np.exp(-(50 - 40) / 10), 0.0]\n",
}
