"""Wrong answers for lesson 06 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the probability q used as the logit (sigmoid left out)
    1: """labels = train_set.voxels.float()
answer_1 = (q, nn.BCEWithLogitsLoss()(torch.full_like(labels, q), labels).item())
""",
    # both learning rates read from the 2-epoch schedule
    2: """two = replace(tiny_recipe, epochs=2)
answer_2 = (train.lr_schedule(two, 1), train.lr_schedule(two, 1))
""",
    # the weight inverted: q / (1 - q) instead of (1 - q) / q
    3: "answer_3 = (q / (1 - q), 0.0)\n",
    # the smallest gap instead of the largest
    4: """our_gaps = {c: a - b for c, a, b in zip(cats, per_train, per_test, strict=True)}
paper_gaps = {c: paper.TABLE_I["train"][c] - paper.TABLE_I["test"][c] for c in paper.CATEGORIES}
answer_4 = (min(our_gaps, key=our_gaps.get), min(paper_gaps, key=paper_gaps.get))
""",
    # lr= left out of fit: both runs train at the recipe's learning rate
    5: """histories_5 = {}
with tempfile.TemporaryDirectory() as tmp:
    for lr in (train.RECIPES["paper"].lr, tiny_recipe.lr):
        histories_5[lr] = train.fit(build_e2v("tiny", seed=SEED), subset(train_set, LR_TRAIN),
                                    subset(val_set, LR_VAL), Path(tmp) / f"lr_{lr:g}",
                                    recipe="tiny", epochs=LR_EPOCHS, seed=SEED, progress=False)
answer_5 = min(histories_5, key=lambda lr: histories_5[lr][-1]["val_loss"])
""",
}
