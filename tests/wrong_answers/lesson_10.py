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
    # the runs are made, but the answer copies the recorded study's seed 0 (data_small), not the
    # records of the student's own runs on the mini dataset
    4: """experiments.run_class_study("loss", ["bce", "focal"], data, live / "results", QUICK,
                            seeds=[0], metric=METRIC, progress=False)
answer_4 = {r["config"]: (r["metrics"]["val_threshold"], r["metrics"]["iou@0.3"],
                          r["metrics"]["iou@val_threshold"])
            for r in loss_results["runs"] if r["seed"] == 0 and r["config"] in ("bce", "focal")}
""",
    # only the comparisons with the baseline, as section 4 reads them
    5: """answer_5 = sorted(tuple(sorted(("bce", d["config"])))
                  for d in experiments.compare(recorded, "bce")
                  if d["clear"])
""",
}
