"""Wrong answers for lesson 03 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the reference reset to the top of the ramp after the ON events (no carry-over)
    1: """l0, l1, l2 = np.log(np.array([0.2, 0.9, 0.5]) + 1e-3)
n_on = int(np.floor((l1 - l0) / 0.2))
on = [(round(k * 0.2 / (l1 - l0) * 1000), 1) for k in range(1, n_on + 1)]
n_off = int(np.floor((l1 - l2) / 0.2))
off = [(round(1000 + k * 0.2 / (l1 - l2) * 1000), -1) for k in range(1, n_off + 1)]
answer_1 = on + off
""",
    # each change rounded to the nearest event instead of rounded down
    2: """answer_2 = {"reset": 4 * round(0.155 / 0.2), "carry_over": round(4 * 0.155 / 0.2)}
""",
    # motion scaled with the pixel count (resolution squared) instead of the resolution
    3: """worst_128 = orbit.pixel_motion_per_frame(N_VIDEO, 128, 1).max()
pixel_ratio = (paper.RENDER_SIZE_PX / 128) ** 2
answer_3 = (int(np.ceil(worst_128 * pixel_ratio)), int(np.ceil(worst_128 / 0.5)))
""",
    # only C = 0.2 and 0.4 simulated; the other counts scaled as 1 / C from C = 0.2
    4: """thresholds = (0.05, 0.1, 0.2, 0.4, 0.8)
answer_4 = {c: round(len(events) * 0.2 / c) for c in thresholds}
answer_4[0.4] = len(simulate.simulate_events(video, t_us, contrast_pos=0.4, contrast_neg=0.4))
exponent_4 = -np.polyfit(np.log(thresholds), np.log(list(answer_4.values())), 1)[0]
""",
    # the 5 ms period simulated; 1 and 20 ms scaled from it in proportion to the period
    5: """ev = simulate.simulate_events(video, t_us, CONTRAST, CONTRAST, refractory_us=5_000)
kept = frames.accumulate(ev, sensor_size, dt_us=DT_US, t0_us=0, n_frames=N_FRAMES).sum()
lost = 1 - kept / stack.sum()
answer_5 = {1_000: lost / 5, 5_000: lost, 20_000: min(4 * lost, 0.99)}
""",
}
