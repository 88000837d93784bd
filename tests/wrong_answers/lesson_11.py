"""Wrong answers for lesson 11 (see tests/wrong_answers/__init__.py)."""

WRONG = {
    # the event frames counted as one byte per pixel, as they are stored before packing
    1: "answer_1 = (100 * 64 * 64, 100 * 64 * 64, 64 * 64)\n",
    # the first n views of the orbit instead of n evenly spaced ones
    2: """answer_2 = {}
for n in (1, 2, 4, 8, 16, 32, 120):
    views = np.arange(n)
    carved_n = geometry.visual_hull(silhouettes[views], cameras[views], config.resolution)
    answer_2[n] = geometry.score_occupancy(carved_n, label)["iou@0.3"]
""",
    # the library's default threshold taken for the best one, without scoring
    3: "answer_3 = float(geometry.EVENT_VOTE_THRESHOLD)\n",
    # a normal quantile (1.96) instead of Student's t with n - 1 degrees of freedom
    4: """answer_4 = {}
for config_name in experiments.STUDIES["input"].configs:
    runs = reports.runs_of(input_results, config_name)
    values = np.array([r["metrics"]["iou@0.3"] for r in runs])
    half = 1.96 * values.std(ddof=1) / np.sqrt(len(values))
    answer_4[config_name] = (values.mean() - half, values.mean() + half)
""",
    # the first recipe's model (record key learned, first_recipe.pt) taken for e2v_tiny.pt
    5: """by_category = {}
for run in geometry_runs:
    s = run["scores"]
    by_category.setdefault(run["category"], []).append(
        s["learned"]["iou@0.3"] - s["visual_hull"]["iou@0.3"])
answer_5 = sorted(c for c, lead in by_category.items() if np.mean(lead) > 0)
""",
}
