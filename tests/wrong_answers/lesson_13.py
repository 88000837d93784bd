"""Wrong answers for lesson 13 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the share of units firing per object, averaged, instead of "for at least one object"
    1: """answer_1 = {name: (units[name] > 0).float().mean(dim=0)
            .view(model.bridge.channels, -1).mean(dim=1).tolist()
            for name, model in models.items()}
""",
    # unpaired: each model's own 95 % interval, "beyond" when the two do not overlap
    2: """_own = {n: metrics.iou(p.numpy(), test.voxels.numpy()) for n, p in probabilities.items()}
_a, _b = metrics.interval95(_own["e2v_tiny.pt"]), metrics.interval95(_own["first_recipe.pt"])
answer_2 = (float(_own["e2v_tiny.pt"].mean() - _own["first_recipe.pt"].mean()),
            bool(_a[0] > _b[1] or _a[1] < _b[0]))
""",
    # the mean probability under 0.3 read as a failure: the learning run C given even odds
    3: 'answer_3 = {"A": "normalise", "B": "even odds", "C": "even odds"}\n',
    # the class study's rows reused: no new seed trained
    4: "answer_4 = (fixed_row, first_row)\n",
}
