"""Wrong answers for lesson 12 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # shot noise only: the leak events of the preset left out
    1: """answer_1 = NOISE_LEVELS["medium"]["shot_noise_rate_hz"] * 128 * 128 * 0.5
""",
    # the promise typed in place of the measurement
    2: "answer_2 = {r: r for r in (0.1, 1.0, 10.0)}\n",
    # 2 ms compared with intervals in microseconds as if they were milliseconds
    3: "answer_3 = float(np.mean(intervals < 2))\n",
    # what training with noise wins back read on the medium test set instead of high
    4: """_clean, _noisy = noise_rows["train_clean"], noise_rows["train_medium"]
answer_4 = (_clean["clean"]["mean"] - _clean["high"]["mean"],
            _noisy["medium"]["mean"] - _clean["medium"]["mean"])
""",
    # the three smallest sizes instead of the three largest
    5: """_smallest = sorted(scale_rows, key=lambda r: n_train[r["config"]])[:3]
answer_5 = float(np.polyfit(np.log2([n_train[r["config"]] for r in _smallest]),
                            [r["mean"] for r in _smallest], 1)[0])
""",
}
