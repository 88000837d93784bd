"""The hybrid study's object-by-object comparisons, on hand-made records with known answers."""

import math

import pytest

from e2vlib.experiments import hybrid_study as hs


def _run(config, seed, per_object):
    mean = sum(per_object.values()) / len(per_object)
    return {"config": config, "seed": seed,
            "metrics": {"iou@0.3": mean, hs.PER_OBJECT: per_object}}


RESULTS = {"runs": [
    _run("e2v", 0, {"a": 0.4, "b": 0.5, "c": 0.6}),
    _run("e2v", 1, {"a": 0.6, "b": 0.5, "c": 0.4}),
    _run("hybrid", 0, {"a": 0.8, "b": 0.7, "c": 0.6}),
    _run("hybrid", 1, {"a": 0.6, "b": 0.7, "c": 0.8}),
    {"config": "old", "seed": 0, "metrics": {"iou@0.3": 0.3}},  # recorded before per-object
]}
GEOMETRY = {"runs": [
    {"id": i, "category": c, "scores": {m: {"iou@0.3": v} for m, v in s.items()}}
    for i, c, s in [("a", "chair", {"visual_hull": 0.6, "events_carving": 0.3, "mean_shape": 0.1}),
                    ("b", "chair", {"visual_hull": 0.7, "events_carving": 0.4, "mean_shape": 0.2}),
                    ("c", "lamp", {"visual_hull": 0.5, "events_carving": 0.2, "mean_shape": 0.1}),
                    ("z", "lamp", {"visual_hull": 0.9, "events_carving": 0.9, "mean_shape": 0.9})]
]}


def test_each_objects_iou_is_averaged_over_the_seeds():
    assert hs.learned_per_object(RESULTS, "hybrid") == pytest.approx({"a": 0.7, "b": 0.7,
                                                                      "c": 0.7})
    with pytest.raises(KeyError, match="no run of 'old' records per-object scores"):
        hs.learned_per_object(RESULTS, "old")


def test_the_paired_difference_with_the_hull_by_hand():
    hybrid = hs.learned_per_object(RESULTS, "hybrid")
    hull = hs.baseline_per_object(GEOMETRY, "visual_hull")
    categories = {r["id"]: r["category"] for r in GEOMETRY["runs"]}
    d = hs.paired(hybrid, hull, categories)
    # differences +0.1, 0.0, +0.2 on a, b, c ('z' was not scored by the hybrid)
    assert d["n"] == 3 and d["wins"] == 2
    assert d["mean"] == pytest.approx(0.1)
    half = 4.302653 * 0.1 / math.sqrt(3)  # t(0.975, 2) * s / sqrt(n), s = 0.1
    assert d["ci95"] == pytest.approx((0.1 - half, 0.1 + half), abs=1e-6)
    assert d["per_category"] == pytest.approx({"chair": 0.05, "lamp": 0.2})
    assert hs.paired(hull, hybrid)["mean"] == pytest.approx(-0.1)  # the order matters


def test_methods_without_a_shared_object_are_refused():
    with pytest.raises(ValueError, match="share no scored object"):
        hs.paired({"a": 0.5}, {"b": 0.5})


def test_the_table_has_every_method_and_the_baselines_on_the_learned_objects_only():
    table = hs.hybrid_table(RESULTS, GEOMETRY).splitlines()
    assert [row.split("|")[1].strip() for row in table[2:]] == [
        "e2v", "hybrid", "visual_hull", "events_carving", "mean_shape"]
    hull_row = table[4]
    assert "| 0.600 |" in hull_row  # (0.6 + 0.7 + 0.5) / 3: object z is left out
    hybrid_row = table[3]
    assert "| 2 | 0.700 |" in hybrid_row and "+0.100" in hybrid_row and "(2/3)" in hybrid_row
    assert "+0.200 [" in hybrid_row  # minus e2v: every object +0.2
