"""Wrong answers for lesson 07 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the threshold taken as exclusive (p > t): the voxels exactly at 0.3 are dropped
    1: "answer_1 = {0.3: (4, 4, 4), 0.5: (4, 4, 4)}\n",
    # the per-category thresholds chosen on the test split
    2: """test_cats_2 = np.array(test_set.categories)
test_iou = np.stack([metrics.iou(probs, labels, th) for th in thresholds])
best_by_cat = {c: float(thresholds[np.argmax(test_iou[:, test_cats_2 == c].mean(1))]) for c in cats}
row_of = [list(thresholds).index(best_by_cat[c]) for c in test_set.categories]
answer_2 = {"per_category": best_by_cat,
            "test_single": float(test_iou[list(thresholds).index(best_t)].mean()),
            "test_per_category": float(test_iou[row_of, np.arange(len(test_set))].mean())}
""",
    # the smallest labels first instead of the largest
    3: """size = metrics.category_means(labels.flatten(1).sum(1).numpy(), test_cats)
answer_3 = {"largest": sorted(size, key=size.get)[:3],
            "pooled_minus_mean": float(pooled - per_object.mean())}
""",
    # IoU as overlap over one box's size (7 / 8) instead of over the union
    4: 'answer_4 = {"iou": 7 / 8, "surface_f": 196 / 296}\n',
}
