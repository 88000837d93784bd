"""Wrong answers for lesson 14 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # unpaired: each model's own interval per category, subtracted bound by bound
    1: """answer_1 = {}
for _c, _n in Counter(real["test"].categories).items():
    if _n >= 3:
        _a, _b = after[real_categories == _c], before[real_categories == _c]
        (_a_lo, _a_hi), (_b_lo, _b_hi) = metrics.interval95(_a), metrics.interval95(_b)
        answer_1[_c] = (float(_a.mean() - _b.mean()), _a_lo - _b_lo, _a_hi - _b_hi)
""",
    # the oracle built from the procedural training objects, not the real ones
    2: """_shapes = {c: v.numpy() for c, v in category_mean_shapes(
    preload(E2VDataset(DATA, "train"), progress=False)).items()}
_t = experiments.best_threshold(np.stack([_shapes[c] for c in real["val"].categories]),
                                real["val"].voxels.numpy())
answer_2 = (_t, float(metrics.iou(np.stack([_shapes[c] for c in real["test"].categories]),
                                  real["test"].voxels.numpy(), _t).mean()))
""",
    # the "real" threshold picked on the test objects themselves
    3: """_stored = read_checkpoint(CHECKPOINT)["val_threshold"]
_picked = experiments.best_threshold(p_real, real["test"].voxels)
answer_3 = (_stored, _picked,
            float(metrics.iou(p_real, real["test"].voxels.numpy(), _stored).mean()),
            float(metrics.iou(p_real, real["test"].voxels.numpy(), _picked).mean()))
""",
    # section 3's fine-tune reused: its encoder changed too
    4: 'answer_4 = {"model": fine_tuned, "threshold": t_after, "iou": after}\n',
}
