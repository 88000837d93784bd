"""Wrong answers for lesson 13 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the best seeds compared instead of the means, and "beyond" read from the means alone
    1: """answer_1 = (max(by_config["bce_dice"]["values"]) - max(by_config["base"]["values"]),
            by_config["bce_dice"]["mean"] > by_config["base"]["mean"])
""",
    # categories counted instead of objects: the share of categories whose mean is higher
    2: """_cats = sorted({o["category"] for o in objects})
answer_2 = float(np.mean([
    np.mean([o["scores"]["best"]["iou@0.3"] for o in objects if o["category"] == c])
    > np.mean([o["scores"]["visual_hull"]["iou@0.3"] for o in objects if o["category"] == c])
    for c in _cats]))
""",
    # the largest gain instead of the largest loss (the sign of the difference turned round)
    3: "answer_3 = min(drop, key=drop.get)\n",
    # units that fire for every object instead of for at least one
    4: """def _alive_all(model, layer):
    caught = []
    handle = layer.register_forward_hook(lambda m, i, o: caught.append(o.detach()))
    with torch.no_grad():
        model(preload(E2VDataset(DATA, "test"), progress=False).frames.float())
    handle.remove()
    return float((torch.cat(caught).flatten(1) > 0).all(0).float().mean())


answer_4 = {"best": _alive_all(best_model, best_model.bridge.seed_norm),
            "tiny": _alive_all(tiny_model, tiny_model.bridge.fc)}
""",
}
