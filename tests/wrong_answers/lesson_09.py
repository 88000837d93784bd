"""Wrong answers for lesson 09 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # x and y swapped: pixel (x=3, y=1) put in row 1, column 0
    1: """answer_1 = [[[1, 0], [1, 0]],
            [[0, 0], [1, 0]]]
""",
    # the window length left at 5 ms for every N: 10 frames cover 50 ms, 200 frames run past 0.5 s
    2: """answer_2 = {n: float(inputs.orbit_input(events, sensor_size, representation="binary",
                                           n_frames=n).mean())
            for n in (10, 100, 200)}
""",
    # the interval right, but "clearly better" read off the higher mean
    3: """values = np.array([0.47, 0.50, 0.44])
half = 4.303 * values.std(ddof=1) / np.sqrt(3)
answer_3 = (values.mean() - half, values.mean() + half)
clearly_3 = 0.52 > values.mean()
""",
    # the runs are made, but the answer copies the recorded study's means instead of the measurement
    4: """experiments.run_class_study("time", ["10x50ms", "100x5ms"], data, live / "results", QUICK,
                            seeds=[0], progress=False)
answer_4 = {c: by_name[c]["mean"] for c in ("10x50ms", "100x5ms")}
""",
    # the intervals and seeds right, but "apart" read off the means: every config above binary
    5: """answer_5 = {c: experiments.summarize({"runs": reports.runs_of(results, c)})[0]["ci95"]
            for c in experiments.STUDIES["representation"].configs}
apart_5 = sorted(c for c in answer_5 if c != "binary" and
                 sum(answer_5[c]) > sum(answer_5["binary"]))
_m = {c: np.mean([r["metrics"]["iou@0.3"] for r in reports.runs_of(results, c)])
      for c in ("voxel_grid", "binary")}
_s = {c: np.std([r["metrics"]["iou@0.3"] for r in reports.runs_of(results, c)], ddof=1)
      for c in ("voxel_grid", "binary")}
seeds_5 = next(n for n in range(2, 1000)
               if _m["voxel_grid"] - stats.t.ppf(0.975, n - 1) * _s["voxel_grid"] / np.sqrt(n)
               > _m["binary"] + stats.t.ppf(0.975, n - 1) * _s["binary"] / np.sqrt(n))
""",
}
