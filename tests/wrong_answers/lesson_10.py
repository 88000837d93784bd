"""Wrong answers for lesson 10 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the class weight alpha forgotten
    1: """bce_by_hand = -np.log(0.8)
answer_1 = (bce_by_hand, (1 - 0.8) ** 2 * bce_by_hand)
""",
    # one bias vector per gate instead of two (PyTorch keeps b_ih and b_hh)
    2: """n_in, hidden = 64, 256
answer_2 = 3 * (hidden * n_in + hidden * hidden + hidden)
""",
    # the smoothing term left out: 1 - 2|A n B| / (|A| + |B|)
    3: """answer_3 = 1 - 2 * 800 / ((800 + 200) + 1000)
""",
    # the runs are made, but the answer copies the recorded study's means instead of the measurement
    4: """experiments.run_study("loss", ["bce", "bce_dice"], seeds=[0], out=live / "results",
                      quick=True, progress=False, base_overrides=overrides)
answer_4 = {r["config"]: r["mean"] for r in loss_rows["iou@val_threshold"]
            if r["config"] in ("bce", "bce_dice")}
""",
    # only the comparisons with the baseline, as section 3 prints them
    5: """answer_5 = sorted(tuple(sorted(("bce", d["config"])))
                  for d in experiments.compare(loss_rows["iou@val_threshold"], "bce")
                  if d["clear"])
""",
}
