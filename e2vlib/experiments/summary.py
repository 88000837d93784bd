"""A study's results as numbers: mean, spread and 95 % interval per config, the rule for a real
difference, comparisons with a baseline, and the bar chart.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Hashable

import numpy as np

from e2vlib.metrics import interval95


def _seed(value: object) -> object:
    """A seed as recorded, ``"0"`` read as 0 (other values as they are)."""
    return int(value.strip()) if isinstance(value, str) and value.strip().isdigit() else value


def run_key(run: dict) -> tuple:
    """What names a training run: ``(config, seed)``, a seed recorded as text read as a number."""
    return run.get("config"), _seed(run.get("seed"))


def unique_runs(runs: list[dict], key: Callable[[dict], Hashable] = run_key,
                source: str = "the results") -> list[dict]:
    """``runs`` with each ``key`` once (its first record), warning when any was left out.

    Examples
    --------
    >>> import warnings
    >>> runs = [{"config": "a", "seed": 0}, {"config": "a", "seed": "0"}]
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     len(unique_runs(runs))
    1
    >>> print(caught[0].message)
    the results: ignored 1 duplicate record(s): a seed 0 (each run counts once; remove the \
copies from the file)
    """
    kept: dict[Hashable, dict] = {}
    copies = []
    for run in runs:
        name = key(run)
        if name in kept:
            copies.append(" seed ".join(map(str, name)) if isinstance(name, tuple) else name)
        else:
            kept[name] = run
    if copies:
        warnings.warn(f"{source}: ignored {len(copies)} duplicate record(s): "
                      f"{', '.join(map(str, copies))} (each run counts once; remove the copies "
                      "from the file)", stacklevel=3)
    return list(kept.values())


def summarize(results: dict | str | os.PathLike, metric: str = "iou@0.3") -> list[dict]:
    """Mean, standard deviation and 95 % interval of ``metric`` per config, in study order.

    Each row: ``{"config", "params", "n", "mean", "std", "ci95": (low, high), "values"}``;
    the interval is Student's t over the seeds (``std`` with ``ddof=1``; NaN for one seed).
    Each (config, seed) counts once (:func:`unique_runs` warns about copies).

    Examples
    --------
    >>> runs = [{"config": "a", "params": {}, "seed": s, "metrics": {"iou@0.3": v}}
    ...         for s, v in enumerate([0.40, 0.42, 0.44])]
    >>> row = summarize({"runs": runs})[0]
    >>> row["n"], round(row["mean"], 3), round(row["std"], 3)
    (3, 0.42, 0.02)
    >>> [round(v, 3) for v in row["ci95"]]   # 0.42 -+ 4.303 * 0.02 / sqrt(3)
    [0.37, 0.47]
    """

    source = "the results"
    if not isinstance(results, dict):
        from e2vlib.experiments.runner import read_results

        source, results = str(results), read_results(results)
        if results is None:
            raise FileNotFoundError(f"no results file at {source}; run its study first")
    rows: dict[str, dict] = {}
    for run in unique_runs(results["runs"], source=source):
        row = rows.setdefault(run["config"], {"config": run["config"],
                                              "params": run.get("params", {}), "values": []})
        row["values"].append(float(run["metrics"][metric]))
    for row in rows.values():
        values = np.asarray(row["values"])
        row["n"] = len(values)
        row["mean"] = float(values.mean())
        row["std"] = float(values.std(ddof=1)) if len(values) > 1 else float("nan")
        row["ci95"] = interval95(values)
    return list(rows.values())


def format_study_table(rows: list[dict], metric: str = "iou@0.3") -> str:
    """A markdown table of :func:`summarize` rows."""
    lines = [f"| config | n | {metric} mean ± std | 95 % interval |", "| --- | --- | --- | --- |"]
    for row in rows:
        lines.append(f"| {row['config']} | {row['n']} | {row['mean']:.3f} ± {row['std']:.3f} | "
                     f"{row['ci95'][0]:.3f}–{row['ci95'][1]:.3f} |")
    return "\n".join(lines)


def plot_summary(rows: list[dict], ax=None, metric: str = "iou@0.3",
                 reference: float | None = None,
                 title: str | None = None):
    """Bar chart of :func:`summarize` rows: mean with 95 % interval error bars, seeds as dots.

    ``reference`` draws a dashed line (e.g. the base config's mean). Returns the axes.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(1.1 * len(rows) + 2, 3.2))
    x = np.arange(len(rows))
    means = [r["mean"] for r in rows]
    errors = np.array([[r["mean"] - r["ci95"][0], r["ci95"][1] - r["mean"]] for r in rows]).T
    ax.bar(x, means, color="#8fa8c8", width=0.6, yerr=np.nan_to_num(errors), capsize=4,
           label="mean, 95 % interval")
    for i, row in enumerate(rows):
        ax.plot(np.full(len(row["values"]), i) + np.linspace(-0.12, 0.12, len(row["values"])),
                row["values"], "o", color="#333333", markersize=3.5,
                label="one seed" if i == 0 else None)
    if reference is not None:
        ax.axhline(reference, color="#d62728", linestyle="--", linewidth=1)
    ax.set_xticks(x, [r["config"] for r in rows], rotation=20, ha="right")
    ax.set_ylabel(f"test {metric}")
    low = min(min(r["values"]) for r in rows)
    ax.set_ylim(max(0.0, low - 0.1), min(1.0, max(max(r["values"]) for r in rows) + 0.06))
    if title:
        ax.set_title(title)
    ax.legend(loc="lower right", fontsize=8)
    return ax


def is_real_difference(row: dict, base: dict) -> bool:
    """True when the 95 % intervals of two :func:`summarize` rows do not overlap (the one
    rule every study lesson uses for "a real difference"); False when either has one seed."""
    low, high = row["ci95"]
    base_low, base_high = base["ci95"]
    if not all(np.isfinite([low, high, base_low, base_high])):
        return False
    return bool(low > base_high or high < base_low)


def compare(rows: list[dict], baseline: str) -> list[dict]:
    """Each config's difference from ``baseline``, with Welch's t-test p-value over seeds.

    Returns ``[{"config", "difference", "p_value", "clear"}]`` where ``clear`` is
    :func:`is_real_difference` (a conservative reading with 3 seeds).
    """
    from scipy import stats

    base = next((r for r in rows if r["config"] == baseline), None)
    if base is None:
        raise ValueError(f"no config {baseline!r} among {[r['config'] for r in rows]}")
    out = []
    for row in rows:
        if row is base:
            continue
        p = (float(stats.ttest_ind(row["values"], base["values"], equal_var=False).pvalue)
             if row["n"] > 1 and base["n"] > 1 else float("nan"))
        out.append({"config": row["config"], "difference": row["mean"] - base["mean"],
                    "p_value": p, "clear": is_real_difference(row, base)})
    return out

