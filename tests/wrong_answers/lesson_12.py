"""Wrong answers for lesson 12 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # shot noise only: the leak events of the preset left out
    1: """answer_1 = NOISE_LEVELS["medium"]["shot_noise_rate_hz"] * 128 * 128 * 0.5
""",
    # the promise typed in place of the measurement
    2: "answer_2 = {r: r for r in (0.1, 1.0, 10.0)}\n",
    # 2 ms compared with intervals in microseconds as if they were milliseconds
    3: "answer_3 = float(np.mean(intervals < 2))\n",
    # the numbers right, but "wins back" judged against zero instead of half the loss
    4: """def _mean(config, level):
    runs = reports.runs_of(noise_results, config)
    return np.mean([r["metrics"][f"{level}:iou@0.3"] for r in runs])


answer_4 = (_mean("train_clean", "clean") - _mean("train_clean", "high"),
            _mean("train_medium", "high") - _mean("train_clean", "high"))
most_4 = bool(answer_4[1] > 0)
""",
    # the three smallest sizes instead of the three largest
    5: """_runs = reports.load_results("data_scale")["runs"]
_sizes = sorted({r["n_train"] for r in _runs})[:3]
_means = [np.mean([r["metrics"]["iou@0.3"] for r in _runs if r["n_train"] == n]) for n in _sizes]
answer_5 = float(np.polyfit(np.log2(_sizes), _means, 1)[0])
""",
}
