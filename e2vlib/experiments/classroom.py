"""A study a student runs inside a lesson: a mini dataset, two configs, a few seeds, one figure.

Lessons 09-13 each pose one question and answer it twice: first with a *class study* the
student runs (this module), then with the recorded full study that confirms or corrects it.
A class study is an ordinary :func:`~e2vlib.experiments.runner.run_study` of a recorded study's
configs, on a mini dataset of three categories built in the lesson (:func:`build_mini_dataset`)
and with a shorter budget (:data:`CLASS_EPOCHS`), so its records look like every other study's
and :func:`~e2vlib.experiments.summary.summarize` reads them.

Sizes (full mode, 2 CPU cores): 24 objects per category (20 train, 2 validation, 2 test after
the 8:1:1 split), 32 px frames, :data:`CLASS_EPOCHS` epochs per run; quick mode (CI) 3 objects
per category and 1 epoch, a smoke test of the same code.

>>> sorted(class_overrides("/data", quick=True))
['data', 'epochs', 'events', 'frame_size', 'per_category']
>>> class_overrides("/data", quick=False)["epochs"] == CLASS_EPOCHS["full"]
True
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from e2vlib.experiments.reports import load_results
from e2vlib.experiments.runner import run_study
from e2vlib.experiments.summary import is_real_difference, plot_summary, summarize

CLASS_CATEGORIES = ("chair", "table", "airplane")
"""The mini dataset's categories: a thin, a flat and a winged shape."""
CLASS_PER_CATEGORY = {"quick": 3, "full": 24}
"""Objects per category of the mini dataset (split 8:1:1 per category)."""
CLASS_EPOCHS = {"quick": 1, "full": 30}
"""Epochs per class-study run."""
CLASS_SEEDS = (0, 1, 2)
"""Seeds of a class study: three, the fewest that give a 95 % interval of usable width."""
CLASS_FRAME_SIZE = 32
"""Frame side of the mini dataset in pixels (data_small uses 64)."""


def _mode(quick: bool) -> str:
    return "quick" if quick else "full"


def build_mini_dataset(folder: str | os.PathLike, quick: bool, grey_video: bool = False,
                       progress: bool = True) -> Path:
    """Build the class studies' mini dataset into ``folder`` and return its path.

    Three categories (:data:`CLASS_CATEGORIES`), :data:`CLASS_PER_CATEGORY` objects each, the
    data_small pipeline at a 64 px sensor and 32 px frames, raw events of every object (studies
    that change the input recompute it from them) and, with ``grey_video``, the grey video too.
    A build resumes where an interrupted one stopped.
    """
    from e2vlib.data import BuildConfig, build_dataset

    n = CLASS_PER_CATEGORY[_mode(quick)]
    config = BuildConfig(categories=CLASS_CATEGORIES, per_category=n, resolution=64,
                         frame_size=CLASS_FRAME_SIZE, oversample=2, raw_events_per_category=n,
                         grey_video=grey_video)
    build_dataset(Path(folder), config, progress=progress)
    return Path(folder)


def class_overrides(data: str | os.PathLike, quick: bool, **changes) -> dict:
    """The protocol changes that point a study at the mini dataset ``data`` with the class
    budget; ``changes`` adds more (for example ``{"noise": "medium"}``)."""
    return {"data": str(data), "events": str(data), "frame_size": CLASS_FRAME_SIZE,
            "epochs": CLASS_EPOCHS[_mode(quick)], "per_category": None, **changes}


def run_class_study(study: str, configs: Sequence[str], data: str | os.PathLike,
                    out: str | os.PathLike, quick: bool, seeds: Sequence[int] = CLASS_SEEDS,
                    metric: str = "iou@0.3", progress: bool = True, **changes) -> list[dict]:
    """Run ``configs`` of the recorded ``study`` on the mini dataset ``data`` for ``seeds``
    (records in ``out/STUDY.json``; recorded runs are skipped, so a rerun resumes) and return
    their :func:`summarize` rows for ``metric`` (mean, 95 % interval, one value per seed)."""
    run_study(study, list(configs), seeds=list(seeds), out=out, quick=True, progress=progress,
              base_overrides=class_overrides(data, quick, **changes))
    rows = summarize(load_results(study, out), metric)
    return [r for r in rows if r["config"] in configs]


def _seeds(rows: Sequence[dict]) -> str:
    """The number of seeds per config: ``"3"``, or a range such as ``"3-5"``."""
    counts = sorted({r["n"] for r in rows})
    return str(counts[0]) if len(counts) == 1 else f"{counts[0]}-{counts[-1]}"


def plot_class_study(rows: list[dict], recorded: list[dict] | None = None,
                     metric: str = "iou@0.3", question: str = ""):
    """One figure: the student's class study (left) beside the recorded study's rows for the
    same configs (right, when ``recorded`` is given), each config as its mean with the 95 %
    interval and one dot per seed, both panels on one IoU axis from 0. Returns the figure."""
    import matplotlib.pyplot as plt

    panels = [(rows, f"your study ({_seeds(rows)} seeds, mini set)")]
    if recorded:
        names = [r["config"] for r in rows]
        same = [r for r in recorded if r["config"] in names]
        same.sort(key=lambda r: names.index(r["config"]))
        panels.append((same, f"recorded study ({_seeds(same)} seeds, data_small)"))
    fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * len(panels) + 0.6, 3.3),
                             sharey=True, squeeze=False, layout="constrained")
    top = max(max(r["values"]) for group, _ in panels for r in group)
    top = max([top] + [r["ci95"][1] for group, _ in panels for r in group
                       if r["ci95"][1] == r["ci95"][1]])  # NaN (one seed) is skipped
    for ax, (group, title) in zip(axes[0], panels, strict=True):
        plot_summary(group, ax=ax, metric=metric, title=title)
        ax.set_ylim(0, min(1.0, top + 0.12))  # from 0, so no interval is cut
    for ax in axes[0][1:]:
        ax.set_ylabel("")
        ax.get_legend().remove()
    axes[0][0].legend(loc="upper left", fontsize=8, ncol=2)
    if question:
        fig.suptitle(question, fontsize=10)
    return fig


def leader(rows: Sequence[dict]) -> str | None:
    """The config of two :func:`summarize` rows that is ahead beyond the seed spread (their
    95 % intervals do not overlap), or None when the rule cannot tell them apart."""
    first, second = rows
    if not is_real_difference(first, second):
        return None
    return first["config"] if first["mean"] > second["mean"] else second["config"]


def class_verdict(rows: Sequence[dict], recorded: Sequence[dict], quick: bool
                  ) -> tuple[str, str]:
    """How a class study's two rows compare with the recorded rows of the same configs:
    ``(verdict, sentence)``, the verdict a predicate for "your class study ...": ``"is a smoke
    test"`` (quick mode), ``"agrees"``, ``"cannot tell"`` (the record separates the configs,
    the class study does not) or ``"is corrected by the record"`` (the class study separates
    them and the record does not, or puts the other one ahead).

    >>> mine = [{"config": "a", "mean": 0.5, "ci95": (0.4, 0.6)},
    ...         {"config": "b", "mean": 0.55, "ci95": (0.45, 0.65)}]
    >>> record = [{"config": "b", "mean": 0.6, "ci95": (0.58, 0.62)},
    ...           {"config": "a", "mean": 0.4, "ci95": (0.38, 0.42)}]
    >>> class_verdict(mine, record, quick=False)[0]
    'cannot tell'
    """
    names = [r["config"] for r in rows]
    record = [next(r for r in recorded if r["config"] == name) for name in names]
    yours, theirs = leader(rows), leader(record)
    if quick:
        return "is a smoke test", ("Quick mode trains too little to compare: your panel is a smoke "
                              "test of the code; run the lesson without `E2V_QUICK` for yours.")
    if yours == theirs:
        return "agrees", ("Your class study **agrees** with the record: " + (
            "neither finds a difference beyond the seed spread." if theirs is None
            else f"both put `{theirs}` ahead."))
    if yours is None:
        return "cannot tell", (f"The record puts `{theirs}` ahead; your class study, with "
                               "fewer objects, **cannot tell** the two apart.")
    return "is corrected by the record", (f"Your class study puts `{yours}` ahead, the record " + (
        "finds no difference beyond the seed spread" if theirs is None
        else f"puts `{theirs}` ahead") + ": the record, on more objects, **corrects** it.")
