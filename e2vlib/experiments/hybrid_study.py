"""The ``hybrid`` study read object by object: learned configs beside the geometry baselines.

The training runs come from ``python -m e2vlib experiment hybrid`` (one record per config and
seed in ``experiments/results/hybrid.json``, each holding its test objects' IoU@0.3 by id);
the baselines that need no training (visual hull, event carving, mean shape) from the
geometry study's records of the same test objects (``geometry.json``). Every comparison is
paired: each object's IoU averaged over a config's seeds, minus the other method's IoU on
the same object, with the 95 % interval of the mean difference over the objects
(:func:`e2vlib.metrics.interval95`). Introduced in notebooks/15_learning_meets_geometry.ipynb.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from e2vlib import metrics

PER_OBJECT = "per_object_iou@0.3"
"""The metrics key of a run's per-object test IoUs (threshold 0.3, ``{id: IoU}``)."""

BASELINES = ("visual_hull", "events_carving", "mean_shape")
"""The geometry study's methods that need no training, in table order."""


def learned_per_object(results: Mapping, config: str) -> dict[str, float]:
    """``{object id: IoU@0.3}`` of ``config``, each object's IoU averaged over the config's
    recorded seeds (runs recorded without per-object scores are left out; KeyError when
    none has them).

    >>> runs = [{"config": "a", "metrics": {PER_OBJECT: {"x": 0.5, "y": 0.2}}},
    ...         {"config": "a", "metrics": {PER_OBJECT: {"x": 0.7, "y": 0.4}}}]
    >>> {k: round(v, 3) for k, v in learned_per_object({"runs": runs}, "a").items()}
    {'x': 0.6, 'y': 0.3}
    """
    runs = [r["metrics"][PER_OBJECT] for r in results["runs"]
            if r["config"] == config and PER_OBJECT in r["metrics"]]
    if not runs:
        raise KeyError(f"no run of {config!r} records per-object scores; run "
                       f"`python -m e2vlib experiment hybrid --configs {config}`")
    ids = list(runs[0])
    return {i: float(np.mean([run[i] for run in runs])) for i in ids}


def baseline_per_object(geometry: Mapping, method: str) -> dict[str, float]:
    """``{object id: IoU@0.3}`` of a geometry-study ``method`` (e.g. ``"visual_hull"``).

    >>> geometry = {"runs": [{"id": "x", "scores": {"visual_hull": {"iou@0.3": 0.6}}}]}
    >>> baseline_per_object(geometry, "visual_hull")
    {'x': 0.6}
    """
    return {r["id"]: float(r["scores"][method]["iou@0.3"]) for r in geometry["runs"]
            if method in r["scores"]}


def seeds_of(results: Mapping, config: str) -> list[float]:
    """Each recorded seed's mean test IoU@0.3 of ``config``, in record order."""
    return [float(r["metrics"]["iou@0.3"]) for r in results["runs"] if r["config"] == config]


def paired(first: Mapping[str, float], second: Mapping[str, float],
           categories: Mapping[str, str] | None = None) -> dict:
    """``first`` minus ``second`` on the objects both scored: ``{"n", "mean", "ci95",
    "wins"}`` (wins: objects where ``first`` is higher) and, given ``{id: category}``,
    ``"per_category"``: ``{category: mean difference}``.

    >>> d = paired({"x": 0.6, "y": 0.4, "z": 0.9}, {"x": 0.5, "y": 0.5, "z": 0.7})
    >>> d["n"], round(d["mean"], 3), d["wins"]      # +0.1, -0.1, +0.2
    (3, 0.067, 2)
    """
    ids = [i for i in first if i in second]
    if not ids:
        raise ValueError("the two methods share no scored object; were they scored on the "
                         "same test split?")
    diff = np.array([first[i] - second[i] for i in ids])
    out = {"n": len(ids), "mean": float(diff.mean()), "ci95": metrics.interval95(diff),
           "wins": int((diff > 0).sum())}
    if categories is not None:
        by = {}
        for i, d in zip(ids, diff, strict=True):
            by.setdefault(categories[i], []).append(d)
        out["per_category"] = {c: float(np.mean(v)) for c, v in by.items()}
    return out


def methods(results: Mapping, geometry: Mapping) -> dict[str, dict[str, float]]:
    """Every method's per-object IoU@0.3: each learned config with per-object scores (in
    study order), then :data:`BASELINES`, restricted to the objects the learned runs scored."""
    out = {}
    for config in dict.fromkeys(r["config"] for r in results["runs"]):
        try:
            out[config] = learned_per_object(results, config)
        except KeyError:
            continue
    scored = set().union(*map(set, out.values())) if out else None
    for method in BASELINES:
        values = baseline_per_object(geometry, method)
        out[method] = {i: v for i, v in values.items() if scored is None or i in scored}
    return out


def hybrid_table(results: Mapping, geometry: Mapping, against: tuple[str, ...] = (
        "visual_hull", "e2v")) -> str:
    """A Markdown table: per method, its seeds, mean test IoU@0.3 (over objects, seeds
    averaged; the interval over seeds for learned configs) and the paired difference with
    each method of ``against`` that is recorded (mean, 95 % interval, objects won)."""
    scores = methods(results, geometry)
    against = tuple(a for a in against if a in scores)
    head = ("| method | seeds | IoU@0.3 | interval over seeds | "
            + " | ".join(f"minus {a} (paired, wins)" for a in against) + " |")
    lines = [head, "|" + " --- |" * (4 + len(against))]
    for name, values in scores.items():
        seeds = seeds_of(results, name) if name not in BASELINES else []
        low, high = metrics.interval95(seeds) if len(seeds) > 1 else (np.nan, np.nan)
        spread = f"{low:.3f} to {high:.3f}" if seeds and low == low else "-"
        cells = []
        for other in against:
            if other == name:
                cells.append("-")
                continue
            d = paired(values, scores[other])
            cells.append(f"{d['mean']:+.3f} [{d['ci95'][0]:+.3f}, {d['ci95'][1]:+.3f}] "
                         f"({d['wins']}/{d['n']})")
        lines.append(f"| {name} | {len(seeds) or '-'} | {np.mean(list(values.values())):.3f} "
                     f"| {spread} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
