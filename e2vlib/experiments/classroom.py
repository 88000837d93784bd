"""A study a student runs inside a lesson: a mini dataset, two configs, a few seeds, one figure.

Lessons 09-13 each pose one question and answer it twice: first with a *class study* the
student runs (this module, :func:`class_finding`), then with the recorded full study beside it
(:func:`class_verdict`: do the two agree?).
A class study is an ordinary :func:`~e2vlib.experiments.runner.run_study` of a recorded study's
configs, on a mini dataset of three categories built in the lesson (:func:`build_mini_dataset`)
and with a shorter budget (:data:`CLASS_EPOCHS`), so its records look like every other study's
and :func:`~e2vlib.experiments.summary.summarize` reads them.

Sizes (full mode, 2 CPU cores): 24 objects per category (20 train, 2 validation, 2 test after
the 8:1:1 split), 32 px frames, :data:`CLASS_EPOCHS` epochs per run; quick mode (CI) 3 objects
per category, 1 epoch and 2 seeds, a smoke test of the same code.

Every run is then scored on the *class test set* (:func:`class_test_path`): new objects of the
same three categories (another build seed), 26 per category in full mode, 78 in all, more than
the 60 a run trains on. Both configs of a class study see the same objects, so they are
compared object by object (:func:`paired_difference`): a paired 95 % interval over 78 objects
can separate configs that three seeds' intervals cannot.

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
from e2vlib.experiments.summary import is_real_difference, plot_summary

CLASS_CATEGORIES = ("chair", "table", "airplane")
"""The mini dataset's categories: a thin, a flat and a winged shape."""
CLASS_PER_CATEGORY = {"quick": 3, "full": 24}
"""Objects per category of the mini dataset (split 8:1:1 per category)."""
CLASS_EPOCHS = {"quick": 1, "full": 30}
"""Epochs per class-study run."""
CLASS_SEEDS = {"quick": (0, 1), "full": (0, 1, 2)}
"""Seeds of a class study: three, the fewest that give a 95 % interval of usable width (quick
mode, a smoke test: two, the fewest that give an interval at all)."""
CLASS_FRAME_SIZE = 32
"""Frame side of the mini dataset in pixels (data_small uses 64)."""
CLASS_TEST_PER_CATEGORY = {"quick": 1, "full": 26}
"""Objects per category of the class test set (full: 78 in all, as many as data_small's
test split)."""
CLASS_TEST_SEED = 1
"""Build seed of the class test set: other objects than the mini dataset's (seed 0)."""


def _mode(quick: bool) -> str:
    return "quick" if quick else "full"


def class_test_path(data: str | os.PathLike) -> Path:
    """Where :func:`build_mini_dataset` puts the class test set of the mini dataset ``data``:
    beside it, its name + ``_test`` (``live/data`` -> ``live/data_test``)."""
    data = Path(data)
    return data.with_name(data.name + "_test")


def build_mini_dataset(folder: str | os.PathLike, quick: bool, grey_video: bool = False,
                       progress: bool = True, noise: str = "clean") -> Path:
    """Build the class studies' mini dataset into ``folder`` and its class test set beside
    it (:func:`class_test_path`); return the mini dataset's path.

    Three categories (:data:`CLASS_CATEGORIES`), :data:`CLASS_PER_CATEGORY` objects each, the
    data_small pipeline at a 64 px sensor and 32 px frames, raw events of every object (studies
    that change the input recompute it from them), with ``grey_video`` the grey video too, and
    the simulator's sensor ``noise`` preset. The class test set holds
    :data:`CLASS_TEST_PER_CATEGORY` new objects per category (build seed
    :data:`CLASS_TEST_SEED`, test split only). A build resumes where an interrupted one stopped;
    one this machine has made before is copied (:func:`~e2vlib.experiments.build_cache.
    build_once`), so lessons after the first get theirs in a second.
    """
    from e2vlib.data import BuildConfig
    from e2vlib.experiments.build_cache import build_once

    n = CLASS_PER_CATEGORY[_mode(quick)]
    config = BuildConfig(categories=CLASS_CATEGORIES, per_category=n, resolution=64,
                         frame_size=CLASS_FRAME_SIZE, oversample=2, raw_events_per_category=n,
                         grey_video=grey_video, noise=noise)
    build_once(folder, config, progress=progress)
    # 10 n planned objects per category put n in the test split (8:1:1); only those are built
    n_test = CLASS_TEST_PER_CATEGORY[_mode(quick)]
    test = BuildConfig(**{**config.__dict__, "per_category": 10 * n_test,
                          "raw_events_per_category": n_test, "seed": CLASS_TEST_SEED,
                          "splits": ("test",)})
    build_once(class_test_path(folder), test, progress=progress)
    return Path(folder)


def class_overrides(data: str | os.PathLike, quick: bool, **changes) -> dict:
    """The protocol changes that point a study at the mini dataset ``data`` with the class
    budget; ``changes`` adds more (for example ``{"noise": "medium"}``)."""
    return {"data": str(data), "events": str(data), "frame_size": CLASS_FRAME_SIZE,
            "epochs": CLASS_EPOCHS[_mode(quick)], "per_category": None, **changes}


def run_class_study(study: str, configs: Sequence[str], data: str | os.PathLike,
                    out: str | os.PathLike, quick: bool, seeds: Sequence[int] | None = None,
                    metric: str = "iou@0.3", progress: bool = True, **changes) -> list[dict]:
    """Run ``configs`` of the recorded ``study`` on the mini dataset ``data`` for ``seeds``
    (None: the mode's :data:`CLASS_SEEDS`; records in ``out/STUDY.json``, best checkpoints in
    ``out/checkpoints``; recorded runs are skipped, so a rerun resumes) and return their rows
    scored on the class test set
    (:func:`score_class_study`)."""
    seeds = CLASS_SEEDS[_mode(quick)] if seeds is None else seeds
    run_study(study, list(configs), seeds=list(seeds), out=out, quick=True, progress=progress,
              base_overrides=class_overrides(data, quick, **changes),
              checkpoints=Path(out) / "checkpoints")
    return score_class_study(study, configs, data, out, seeds=seeds, metric=metric)


def score_class_study(study: str, configs: Sequence[str], data: str | os.PathLike,
                      out: str | os.PathLike, seeds: Sequence[int] | None = None,
                      metric: str = "iou@0.3") -> list[dict]:
    """The recorded class runs of ``configs`` (``seeds``; None: every recorded seed), each
    scored on every object of the class test set of ``data``, one row per config.

    ``metric``: ``iou@T`` at a fixed threshold T, ``iou@val_threshold`` at the threshold each
    run picked on the validation objects; ``LEVEL:`` before it tests on events with sensor
    noise ``LEVEL`` (``medium:iou@0.3``; the test set's noisy copy is found through the
    protocol's ``noise_events`` + ``_test``). A row is a :func:`summarize` row over seeds
    (``config``, ``n``, ``mean``, ``std``, ``ci95``, ``values``: each seed's mean over the
    objects) plus ``per_object``, each object's IoU averaged over the seeds, and ``ids``.
    """
    import numpy as np
    import torch

    from e2vlib.experiments.loader import load_split
    from e2vlib.experiments.protocol import Protocol
    from e2vlib.metrics import interval95, iou
    from e2vlib.model import load_checkpoint
    from e2vlib.train import predict

    results = load_results(study, out)
    protocol = Protocol.from_dict(results["protocol"])
    level, _, base = metric.rpartition(":")
    test = class_test_path(data)
    rows = []
    for config in configs:
        runs = sorted((r for r in results["runs"] if r["config"] == config
                       and (seeds is None or r["seed"] in set(seeds))), key=lambda r: r["seed"])
        if not runs:
            raise ValueError(f"no runs of {study}/{config} are recorded in {out}")
        scores = []
        for run in runs:
            if "checkpoint" not in run:
                raise ValueError(f"{study}/{config} seed {run['seed']} in {out} kept no "
                                 "checkpoint to score; run it with run_class_study")
            changes = {"data": str(test), "events": str(test)}
            if level:
                changes["noise"] = None if level == "clean" else level
                if level != "clean":
                    changes["noise_events"] = protocol.noise_events + "_test"
            split = load_split(protocol.updated(run.get("params", {})).updated(changes), "test")
            threshold = (run["metrics"]["val_threshold"] if base == "iou@val_threshold"
                         else float(base.removeprefix("iou@")))
            torch.set_num_threads(protocol.threads)
            probabilities = predict(load_checkpoint(run["checkpoint"]), split.frames, "cpu")
            scores.append(iou(probabilities.numpy(), split.voxels.numpy(), threshold=threshold))
        scores = np.asarray(scores)  # (seeds, objects)
        values = scores.mean(axis=1)
        rows.append({"config": config, "params": runs[0].get("params", {}),
                     "n": len(values), "mean": float(values.mean()),
                     "std": float(values.std(ddof=1)) if len(values) > 1 else float("nan"),
                     "ci95": interval95(values), "values": values.tolist(),
                     "per_object": scores.mean(axis=0).tolist(), "ids": list(split.ids)})
    return rows


def objects_to_tell(differences: Sequence[float]) -> int | None:
    """About how many objects a paired 95 % interval needs to exclude 0 at this mean
    difference and spread: ``(1.96 sd / mean)^2``; None when the mean is 0.

    >>> objects_to_tell([0.01, 0.03, -0.01, 0.05])   # mean 0.02, sd 0.0258
    7
    """
    import numpy as np

    d = np.asarray(differences, dtype=float)
    if d.mean() == 0:
        return None
    return int(np.ceil((1.96 * d.std(ddof=1) / abs(d.mean())) ** 2))


def paired_difference(rows: Sequence[dict], first: str, second: str) -> dict:
    """``first`` minus ``second`` object by object over the class test set (each object's IoU
    averaged over the seeds): ``{"n", "mean", "ci95", "wins", "objects_to_tell"}`` (wins:
    objects where ``first`` scores higher; :func:`objects_to_tell`).

    >>> rows = [{"config": "a", "per_object": [0.5, 0.6, 0.7]},
    ...         {"config": "b", "per_object": [0.4, 0.6, 0.5]}]
    >>> d = paired_difference(rows, "a", "b")
    >>> d["n"], round(d["mean"], 3), d["wins"]
    (3, 0.1, 2)
    """
    import numpy as np

    from e2vlib.metrics import interval95

    named = {r["config"]: np.asarray(r["per_object"], dtype=float) for r in rows}
    diff = named[first] - named[second]
    return {"n": int(diff.size), "mean": float(diff.mean()), "ci95": interval95(diff),
            "wins": int((diff > 0).sum()), "objects_to_tell": objects_to_tell(diff)}


def all_occupied_iou(data: str | os.PathLike) -> float:
    """The mean IoU of predicting every voxel occupied on the class test set of ``data``:
    each object's share of occupied voxels. A run that has learned nothing scores this."""
    import numpy as np

    from e2vlib.data import E2VDataset

    dataset = E2VDataset(class_test_path(data), "test")
    return float(np.mean([dataset.arrays(i)[1].mean() for i in range(len(dataset))]))


def class_finding(rows: Sequence[dict], base: str, other: str, data: str | os.PathLike,
                  quick: bool, brief: bool = False) -> str:
    """The class study's answer in Markdown: ``other`` against ``base`` on the class test set,
    object by object (:func:`paired_difference`), and whether that tells them apart; where it
    cannot, about how many objects would (:func:`objects_to_tell`). In quick mode, how many
    runs score what predicting every voxel occupied scores (:func:`all_occupied_iou`): the
    smoke test it is. ``brief``: one short clause, for a summary."""
    named = {r["config"]: r for r in rows}
    d = paired_difference(rows, other, base)
    low, high = d["ci95"]
    told = bool(low > 0 or high < 0)
    if quick:
        empty = all_occupied_iou(data)
        idle = sum(abs(v - empty) < 0.01 for r in rows for v in r["values"])
        smoke = (f"quick mode: {idle} of {sum(len(r['values']) for r in rows)} runs score within "
                 f"0.01 of {empty:.3f}, the all-occupied answer; a smoke test, not an answer")
        if brief:
            return "Your study: " + smoke
        return (f"**Your study** ({d['n']} test objects): `{other}` {named[other]['mean']:.3f}, "
                f"`{base}` {named[base]['mean']:.3f}; " + smoke + ".")
    pair = f"{d['mean']:+.3f} (95 % interval {low:+.3f} to {high:+.3f})"
    need = d["objects_to_tell"]
    verdict = ("**beyond chance**" if told else "**cannot tell**" + (
        f": about {need:,} objects would tell at this difference and spread" if need else ""))
    if brief:
        return f"Your study: `{other}` minus `{base}` {pair} object by object, {verdict}"
    return (f"**Your study** ({_seeds(rows)} seeds, scored on {d['n']} test objects it never "
            f"trained on): `{other}` {named[other]['mean']:.3f} against `{base}` "
            f"{named[base]['mean']:.3f}; object by object {pair}, `{other}` ahead on "
            f"{d['wins']} of {d['n']}: {verdict}.")


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
    """The config of two rows that is ahead beyond chance, or None when the rule cannot tell
    them apart: with ``per_object`` scores (a class study), when the paired 95 % interval over
    the objects excludes 0; otherwise (a recorded study), when the 95 % intervals over seeds
    do not overlap."""
    first, second = rows
    if "per_object" in first and "per_object" in second:
        low, high = paired_difference(rows, first["config"], second["config"])["ci95"]
        if not low > 0 and not high < 0:
            return None
        return first["config"] if low > 0 else second["config"]
    if not is_real_difference(first, second):
        return None
    return first["config"] if first["mean"] > second["mean"] else second["config"]


def class_verdict(rows: Sequence[dict], recorded: Sequence[dict], quick: bool
                  ) -> tuple[str, str]:
    """How a class study's two rows compare with the recorded rows of the same configs:
    ``(verdict, sentence)``, the verdict a predicate for "your class study ...": ``"is a smoke
    test"`` (quick mode), ``"agrees"``, ``"cannot tell"`` (the record separates the configs,
    the class study does not) or ``"disagrees with the record"`` (the class study separates
    them and the record does not, or puts the other one ahead). Who is ahead: :func:`leader`.

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
        return "is a smoke test", "Run the lesson without `E2V_QUICK` for your answer."
    if yours == theirs:
        return "agrees", ("Your class study **agrees** with the record: " + (
            "neither finds a difference beyond chance." if theirs is None
            else f"both put `{theirs}` ahead."))
    if yours is None:
        return "cannot tell", (f"The record puts `{theirs}` ahead; your class study **cannot "
                               "tell** the two apart.")
    return "disagrees with the record", (
        f"Your class study puts `{yours}` ahead, the record " + (
            "finds no difference beyond its seed spread" if theirs is None
            else f"puts `{theirs}` ahead")
        + ": they **disagree**; the record trained longer on other data, so ask what differs.")
