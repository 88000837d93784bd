"""The ``real_objects`` study: can a model trained without poses match the visual hull with
poses on held-out real objects, and what does real training data buy?

Four ways to train the same network with the capstone's best recipe (:data:`BASE`: BCE +
Dice, the per-step schedule with warm-up, the output started at even odds, preset
``tiny_norm``), each scored on the real objects' held-out test split
(``cache/real_objects/data``, built by ``make real-data``):

==============  ==========================================================================
``procedural``  data_small's 676 procedural objects, 30 epochs (the capstone's
                ``bce_dice_30_epochs``; its seed 0 is ``data_small/checkpoints/e2v_tiny.pt``)
``real``        the 562 real training objects only, 30 epochs
``fine_tuned``  the ``procedural`` run of the same seed, then 10 epochs on the real objects
                (the output layer keeps its trained start)
``mixed``       both training sets together, 16 epochs (about the procedural run's steps)
==============  ==========================================================================

``hybrid_mixed`` is ``mixed`` with the hybrid of lesson 15 (preset ``hybrid_early``: the
event frames also lifted through the known orbit, which the real objects' samples share
with data_small's), so the hybrid meets the visual hull on the real test split too.

``fine_tuned_1/8``, ``_1/4`` and ``_1/2`` fine-tune on the first eighth, quarter or half of
each category's real training objects for the same number of steps: the learning curve.
Every run that sees real objects keeps its best epoch by IoU@0.3 on the real validation
split; every run's threshold is picked there. Beside them, once per object
(:func:`score_baselines`): the visual hull with the 120 camera poses known, the real
training objects' mean shape, and the per-category oracle (the mean of the object's own
category). Runs are recorded one per (config, seed) in ``OUT/real_objects.json`` through the
lab's locked writer, with each object's IoU so that any two methods compare object by
object (:func:`paired_with`). Command: ``python -m e2vlib.experiments.real_objects study``.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from e2vlib import metrics, paper
from e2vlib.experiments.protocol import Protocol, first_per_category
from e2vlib.experiments.provenance import cpu_name, git_commit
from e2vlib.experiments.real_objects.samples import DATA_DIR
from e2vlib.experiments.real_study import mesh_hull
from e2vlib.experiments.runner import RUN_KEY, best_threshold, read_results, update_results

CHECKPOINTS = "cache/real_objects/checkpoints"
"""Where each run's best checkpoint is kept (the fine-tuned runs start from these)."""
PROCEDURAL_SEED0 = "data_small/checkpoints/e2v_tiny.pt"
"""The capstone's ``bce_dice_30_epochs`` seed 0: the ``procedural`` run of seed 0."""
BASE = {"loss": "bce_dice", "recipe": "tiny_step_even", "preset": "tiny_norm"}
"""The capstone's best recipe (its ``bce_dice_30_epochs`` without the epochs)."""
QUICK = {"per_category": 1, "frame_size": 32}
"""Quick mode (tests): one object of each category per split, 32 px, one epoch a run."""
QUESTION = ("Trained on procedural objects, on real ones, on procedural then fine-tuned on "
            "real, or on both at once, does a model that sees no camera pose reconstruct "
            "held-out real objects as well as the visual hull with poses, and how does it "
            "grow with the number of real training objects?")
COMMAND = "python -m e2vlib.experiments.real_objects study"


@dataclass(frozen=True)
class RealConfig:
    """One way to train: the training sets (``"procedural"``, ``"real"``), the epochs, the
    run it starts from (``None``: fresh weights), the share of each category's real
    training objects used (its first ones) and the model preset (``None``: :data:`BASE`'s)."""

    train: tuple[str, ...]
    epochs: int
    start: str | None = None
    real_fraction: float = 1.0
    preset: str | None = None


CONFIGS: dict[str, RealConfig] = {
    "procedural": RealConfig(("procedural",), 30),
    "real": RealConfig(("real",), 30),
    "fine_tuned": RealConfig(("real",), 10, start="procedural"),
    "mixed": RealConfig(("procedural", "real"), 16),
    **{f"fine_tuned_1/{k}": RealConfig(("real",), 10 * k, "procedural", 1 / k)
       for k in (8, 4, 2)},
    "hybrid_mixed": RealConfig(("procedural", "real"), 16, preset="hybrid_early"),
}
"""The study's configs by name (the learning curve's keep the full run's steps)."""
MAIN = ("procedural", "real", "fine_tuned", "mixed")
"""The four configs of the headline table, in its order."""
BASELINES = ("visual_hull", "mean_shape", "category_oracle")


def study_protocol(quick: bool = False) -> Protocol:
    """The shared protocol of every run (data_small's frames, :data:`BASE`)."""
    return Protocol().updated({**BASE, **(QUICK if quick else {})})


def real_subset(tensors, fraction: float):
    """The first ``round(n * fraction)`` (at least one) objects of each category of a
    :class:`~e2vlib.inputs.TensorSet`.

    Examples
    --------
    >>> import torch
    >>> from e2vlib.inputs import TensorSet
    >>> t = TensorSet(torch.zeros(6, 1, 2, 2), torch.zeros(6, 32, 32, 32, dtype=torch.bool),
    ...               ["a", "a", "a", "a", "b", "b"], list("012345"))
    >>> real_subset(t, 0.5).ids, real_subset(t, 0.25).ids
    (['0', '1', '4'], ['0', '4'])
    """
    if fraction >= 1:
        return tensors
    counts: dict[str, int] = {}
    for c in tensors.categories:
        counts[c] = counts.get(c, 0) + 1
    wanted = {c: max(1, round(n * fraction)) for c, n in counts.items()}
    return tensors.subset(first_per_category(tensors.categories, wanted))


def join(parts: Sequence):
    """Several TensorSets as one (ids keep their dataset's folder name when they clash)."""
    import torch

    from e2vlib.inputs import TensorSet

    return TensorSet(torch.cat([p.frames for p in parts]), torch.cat([p.voxels for p in parts]),
                     [c for p in parts for c in p.categories],
                     [i for p in parts for i in p.ids], parts[0].config)


def load_sets(real: str | os.PathLike = DATA_DIR, quick: bool = False) -> dict:
    """``{"procedural": {split: TensorSet}, "real": {split: TensorSet}}`` in memory."""
    from e2vlib.experiments.loader import load_split

    if not (Path(real) / "manifest.csv").is_file():
        raise FileNotFoundError(f"{real} holds no real-object dataset; build it with "
                                "`make real-data`")
    protocol = study_protocol(quick)
    roots = {"procedural": protocol, "real": protocol.updated({"data": str(real)})}
    return {name: {split: load_split(p, split) for split in ("train", "val", "test")}
            for name, p in roots.items()}


def checkpoint_path(folder: str | os.PathLike, config: str, seed: int) -> Path:
    """Where a run's best checkpoint is kept (``fine_tuned_1/8`` -> ``fine_tuned_1-8``)."""
    return Path(folder) / f"{config.replace('/', '-')}_seed{int(seed)}.pt"


def start_checkpoint(config: RealConfig, seed: int, checkpoints: str | os.PathLike,
                     quick: bool) -> Path | None:
    """The checkpoint a config starts from (None: fresh weights); the procedural run of
    seed 0 is :data:`PROCEDURAL_SEED0` outside quick mode."""
    if config.start is None:
        return None
    path = checkpoint_path(checkpoints, config.start, seed)
    if not path.exists() and config.start == "procedural" and seed == 0 and not quick:
        return Path(PROCEDURAL_SEED0)
    if not path.exists():
        raise FileNotFoundError(f"{path} is missing: run config {config.start!r} seed {seed} "
                                "first (the study runs it before the configs that start "
                                "from it)")
    return path


def score_on_test(model, test, val) -> dict:
    """A model's scores on a real test split: ``metrics`` (IoU@0.3, F-scores, the threshold
    picked on ``val`` and IoU there, per category at both) and ``per_object`` (each test
    object's IoU@0.3 and IoU at the picked threshold, in the split's order)."""
    from e2vlib.train import predict

    threshold = best_threshold(predict(model, val.frames, "cpu"), val.voxels)
    probabilities = predict(model, test.frames, "cpu").numpy()
    result = metrics.score_split(probabilities, test.voxels.numpy(), test.categories)
    at_val = np.atleast_1d(metrics.iou(probabilities, test.voxels.numpy(), threshold=threshold))
    table = metrics.score_table({"iou@val_threshold": at_val}, test.categories)
    scores = {k: float(v) for k, v in result["overall"].items()}
    scores.update({"val_threshold": threshold, "iou@val_threshold": float(at_val.mean()),
                   "per_category_iou@0.3": {c: float(v["iou@0.3"])
                                            for c, v in result["per_category"].items()},
                   "per_category_iou@val_threshold": {
                       c: float(v["iou@val_threshold"]) for c, v in table["per_category"].items()}})
    per_object = {"iou@0.3": [round(float(v), 5) for v in result["scores"]["iou@0.3"]],
                  "iou@val_threshold": [round(float(v), 5) for v in at_val]}
    return {"metrics": scores, "per_object": per_object}


def run_config(name: str, seed: int, sets: dict, checkpoints: str | os.PathLike = CHECKPOINTS,
               quick: bool = False, progress: bool = False) -> dict:
    """Train config ``name`` with ``seed`` on ``sets`` (:func:`load_sets`), keep its best
    checkpoint, and return its record (scores on the real test split, and IoU@0.3 on
    data_small's test split as ``procedural:iou@0.3``)."""
    import torch

    from e2vlib.metrics import iou
    from e2vlib.model import build_e2v, count_parameters, load_checkpoint
    from e2vlib.scale.training import fit_at_scale
    from e2vlib.train import predict

    config = CONFIGS[name]
    protocol = study_protocol(quick)
    torch.set_num_threads(protocol.threads)
    real = sets["real"]
    parts = [real_subset(real["train"], config.real_fraction) if part == "real"
             else sets[part]["train"] for part in config.train]
    train = join(parts) if len(parts) > 1 else parts[0]
    val = real["val"] if "real" in config.train else sets["procedural"]["val"]
    start = start_checkpoint(config, seed, checkpoints, quick)
    started = time.perf_counter()
    kept = checkpoint_path(checkpoints, name, seed)
    if name == "procedural" and seed == 0 and not quick:
        best, seconds = load_checkpoint(PROCEDURAL_SEED0), None  # trained by the capstone
    else:
        if start is None:
            model = build_e2v(config.preset or protocol.preset, seed=seed,
                              input_shape=tuple(train.frames.shape[-3:]))
        else:
            model = load_checkpoint(start)
        extra = {"output_prior": False, "output_prior_p": None} if start is not None else {}
        with tempfile.TemporaryDirectory() as tmp:
            fit_at_scale(model, train, val, tmp, recipe=protocol.recipe,
                         epochs=1 if quick else config.epochs, device="cpu", seed=seed,
                         loss=protocol.loss, progress=progress, **extra)
            seconds = round(time.perf_counter() - started, 1)
            best = load_checkpoint(Path(tmp) / "best.pt")
            kept.parent.mkdir(parents=True, exist_ok=True)
            from e2vlib.files import atomic_path

            with atomic_path(kept) as partial:
                shutil.copyfile(Path(tmp) / "best.pt", partial)
    record = score_on_test(best, real["test"], real["val"])
    procedural = sets["procedural"]["test"]
    record["metrics"]["procedural:iou@0.3"] = float(np.mean(iou(
        predict(best, procedural.frames, "cpu"), procedural.voxels, threshold=0.3)))
    return {"config": name, "params": {**asdict(config), "train": list(config.train)},
            "seed": int(seed), **record,
            "n_train": len(train.ids), "epochs": 1 if quick else config.epochs,
            "start": None if start is None else str(start),
            "checkpoint": str(PROCEDURAL_SEED0 if seconds is None else kept),
            "n_parameters": count_parameters(best), "train_seconds": seconds,
            "cpu": cpu_name(), "torch": torch.__version__, "commit": git_commit()}


def score_baselines(sets: dict, load_mesh: Callable[[str], object],
                    progress: bool = False) -> dict:
    """``{method: {"per_object": {"iou@0.3": [...], "iou@val_threshold": [...]},
    "val_threshold"}}`` of the visual hull (``load_mesh(id)`` gives each test object's mesh),
    the real training objects' mean shape and the per-category oracle, on the real test
    split; the mean shapes' threshold is picked on the real validation split."""
    from tqdm.auto import tqdm

    from e2vlib.train import category_mean_shapes

    real = sets["real"]
    test, val, train = real["test"], real["val"], real["train"]
    labels = test.voxels.numpy().astype(bool)
    mean = train.voxels.float().mean(0).numpy()
    oracle = {c: v.numpy() for c, v in category_mean_shapes(train).items()}
    grids = {"mean_shape": lambda c: mean, "category_oracle": lambda c: oracle[c]}
    out = {}
    for method, grid in grids.items():
        val_p = np.stack([grid(c) for c in val.categories])
        threshold = best_threshold(val_p, val.voxels.numpy())
        test_p = np.stack([grid(c) for c in test.categories])
        out[method] = {"val_threshold": threshold, "per_object": {
            "iou@0.3": [round(float(v), 5) for v in metrics.iou(test_p, labels, 0.3)],
            "iou@val_threshold": [round(float(v), 5)
                                  for v in metrics.iou(test_p, labels, threshold)]}}
    hull = []
    for sid in tqdm(test.ids, desc="visual hull", unit="object", disable=not progress):
        hull.append(mesh_hull(load_mesh(sid)))
    values = [round(float(v), 5) for v in metrics.iou(np.stack(hull), labels, 0.5)]
    out["visual_hull"] = {"val_threshold": None,
                          "per_object": {"iou@0.3": values, "iou@val_threshold": values}}
    return out


def catalogue_mesh_loader(cache: str | os.PathLike = "cache/real_objects"
                          ) -> Callable[[str], object]:
    """``load_mesh(id)``: a catalogue row's model in our frame, as its sample was made. The
    catalogue and the Sweet Home 3D libraries are read at the first call only (a study whose
    baselines are recorded never calls it)."""
    from functools import cache as once

    from e2vlib.experiments.real_objects.catalogue import read_catalogue
    from e2vlib.experiments.real_objects.samples import load_row_mesh, sh3d_entries

    @once
    def catalogue() -> tuple[dict, dict]:
        rows = {row.id: row for row in read_catalogue()}
        return rows, sh3d_entries(cache, list(rows.values()))[0]

    def load_mesh(sid: str):
        rows, sh3d = catalogue()
        return load_row_mesh(cache, rows[sid], sh3d)

    return load_mesh


def run_real_objects(configs: Sequence[str] = MAIN, seeds: Sequence[int] = (0, 1, 2, 3, 4),
                     out: str | os.PathLike = "experiments/results",
                     real: str | os.PathLike = DATA_DIR,
                     checkpoints: str | os.PathLike = CHECKPOINTS, quick: bool = False,
                     baselines: bool = True, load_mesh: Callable | None = None,
                     command: str = COMMAND, progress: bool = True) -> Path:
    """Run every (config, seed) not yet recorded in ``OUT/real_objects.json``, seed by seed
    (so each finished seed holds every config), after the baselines when ``baselines`` and
    they are not recorded yet; return the file's path. Quick mode keeps its checkpoints in
    ``checkpoints/quick``, apart from the full runs'."""
    unknown = [c for c in configs if c not in CONFIGS]
    if unknown:
        raise ValueError(f"unknown configs {unknown}; the study has {', '.join(CONFIGS)}")
    path = Path(out) / "real_objects.json"
    checkpoints = Path(checkpoints) / "quick" if quick else Path(checkpoints)
    sets = load_sets(real, quick)
    test_ids = list(sets["real"]["test"].ids)
    protocol = {**study_protocol(quick).to_dict(), "real_data": str(real),
                "quick_epochs": 1 if quick else None}
    results = read_results(path) or {"study": "real_objects", "question": QUESTION,
                                     "protocol": protocol, "runs": []}
    if results.get("protocol") != protocol:
        raise ValueError(f"{path} holds runs of another protocol ({results.get('protocol')}); "
                         "use another --out folder")
    if results.get("test_ids", test_ids) != test_ids:
        raise ValueError(f"{path} scored other test objects than {real} holds now; move it "
                         "away to start the study afresh")
    from e2vlib.data.checks import read_config

    manifest = read_config(real).get("source", {})
    results.update(test_ids=test_ids, test_categories=list(sets["real"]["test"].categories),
                   configs={n: {**asdict(c), "train": list(c.train)} for n, c in CONFIGS.items()},
                   catalogue_sha256=manifest.get("catalogue_sha256"))
    results.setdefault("commands", [])
    if command not in results["commands"]:
        results["commands"].append(command)
    if baselines and "baselines" not in results:
        started = time.perf_counter()
        results["baselines"] = score_baselines(sets, load_mesh or catalogue_mesh_loader(),
                                               progress)
        results["baselines_seconds"] = round(time.perf_counter() - started, 1)
        results = update_results(path, results, RUN_KEY)
    for seed in seeds:
        for name in configs:
            now = read_results(path) or results
            if any(r["config"] == name and r["seed"] == int(seed) for r in now["runs"]):
                continue
            record = run_config(name, int(seed), sets, checkpoints, quick, progress)
            results["runs"].append(record)
            results = update_results(path, results, RUN_KEY)
            if progress:
                m = record["metrics"]
                print(f"real_objects/{name} seed {seed}: real test IoU@0.3 {m['iou@0.3']:.3f}, "
                      f"at {m['val_threshold']:.2f} {m['iou@val_threshold']:.3f} "
                      f"({record['train_seconds']} s)", flush=True)
    if not configs or not seeds:
        update_results(path, results, RUN_KEY)
    return path


def per_object(results: dict, method: str, key: str = "iou@val_threshold") -> np.ndarray:
    """Each test object's IoU under ``method``: a baseline's, or a config's mean over its
    recorded seeds."""
    if method in results.get("baselines", {}):
        return np.asarray(results["baselines"][method]["per_object"][key])
    runs = [r["per_object"][key] for r in results["runs"] if r["config"] == method]
    if not runs:
        raise ValueError(f"no runs of {method!r} are recorded")
    return np.mean(np.asarray(runs), axis=0)


def paired_with(results: dict, method: str, other: str = "visual_hull",
                key: str = "iou@val_threshold") -> dict:
    """``method`` minus ``other`` object by object: ``{"n", "mean", "ci95", "wins"}`` (wins:
    objects where ``method`` scores higher).

    Examples
    --------
    >>> r = {"baselines": {"visual_hull": {"per_object": {"iou@0.3": [0.5, 0.5, 0.5]}}},
    ...      "runs": [{"config": "a", "per_object": {"iou@0.3": [0.6, 0.4, 0.7]}},
    ...               {"config": "a", "per_object": {"iou@0.3": [0.8, 0.4, 0.7]}}]}
    >>> d = paired_with(r, "a", key="iou@0.3")
    >>> d["n"], round(d["mean"], 3), d["wins"]     # objects: +0.2, -0.1, +0.2
    (3, 0.1, 2)
    """
    diff = per_object(results, method, key) - per_object(results, other, key)
    return {"n": int(diff.size), "mean": float(diff.mean()),
            "ci95": metrics.interval95(diff.tolist()), "wins": int((diff > 0).sum())}


def summarize_real_objects(results: dict, key: str = "iou@val_threshold") -> dict:
    """Per config and baseline: ``{"n_seeds", "mean", "ci95", "per_category"}``. A config's
    mean and interval are over its seeds (each seed's mean over the test objects); a
    baseline has one value (its mean over objects, interval over objects); per category:
    the mean over seeds and objects."""
    categories = results["test_categories"]
    out = {}
    for name in dict.fromkeys(r["config"] for r in results["runs"]):
        runs = [r for r in results["runs"] if r["config"] == name]
        seeds = [float(np.mean(r["per_object"][key])) for r in runs]
        out[name] = {"n_seeds": len(runs), "mean": float(np.mean(seeds)),
                     "ci95": metrics.interval95(seeds)}
    for name, base in results.get("baselines", {}).items():
        values = base["per_object"][key]
        out[name] = {"n_seeds": None, "mean": float(np.mean(values)),
                     "ci95": metrics.interval95(values)}
    for name in out:
        values = per_object(results, name, key)
        out[name]["per_category"] = {
            c: float(np.mean([v for v, k in zip(values, categories, strict=True) if k == c]))
            for c in paper.CATEGORIES if c in categories}
    return out


TABLE_KEYS = ("iou@0.3", "iou@val_threshold")
"""The per-object scores the recorded table shows."""


def _per_object_problem(scores: object, n: int, where: str) -> str | None:
    """What is wrong with a record's ``per_object`` scores (None: nothing): each of
    :data:`TABLE_KEYS` a list of ``n`` finite fractions."""
    if not isinstance(scores, dict):
        return f"{where}.per_object is not a mapping of scores to lists"
    for key in TABLE_KEYS:
        values = scores.get(key)
        if not isinstance(values, list) or len(values) != n:
            return (f"{where}.per_object.{key} is not a list of {n} scores (one per test "
                    "object)")
        bad = next((v for v in values if isinstance(v, bool)
                    or not isinstance(v, (int, float)) or not 0 <= v <= 1), None)
        if bad is not None:
            return f"{where}.per_object.{key} holds {bad!r}, not a score in [0, 1]"
    return None


def read_table(path: str | os.PathLike) -> dict:
    """The recorded ``real_objects`` study at ``path`` as :func:`format_real_objects_table`
    reads it: through the one checked reader (:func:`~e2vlib.experiments.runner.read_results`:
    regular file, size bound, strict JSON, every record), then each record's and
    baseline's per-object scores (:data:`TABLE_KEYS`: one finite fraction per test object).
    Raises ValueError (FileNotFoundError when missing) naming the file and the fix."""
    path = Path(path)
    results = read_results(path, "real_objects")
    if results is None:
        raise FileNotFoundError(f"no recorded real_objects study at {path}; run `{COMMAND}`")
    categories = results.get("test_categories")
    if not isinstance(categories, list) or not categories or any(
            c not in paper.CATEGORIES for c in categories):
        raise ValueError(f"{path}: test_categories is not a list of the paper's categories; "
                         f"restore the file from git or rerun `{COMMAND}`")
    baselines = results.get("baselines", {})
    if not isinstance(baselines, dict):
        raise ValueError(f"{path}: baselines is not a mapping of names to scores; restore "
                         f"the file from git or rerun `{COMMAND}`")
    places = [(f"run {i} ({r['config']} seed {r['seed']})", r)
              for i, r in enumerate(results["runs"], 1)]
    places += [(f"baselines.{name}", base) for name, base in baselines.items()]
    for where, record in places:
        problem = (_per_object_problem(record.get("per_object"), len(categories), where)
                   if isinstance(record, dict) else f"{where} is not a record")
        if problem:
            raise ValueError(f"{path}: {problem}; restore the file from git or rerun "
                             f"`{COMMAND}`")
    if not results["runs"] and not baselines:
        raise ValueError(f"{path} holds no run and no baseline; run `{COMMAND}`")
    return results


def format_real_objects_table(results: dict, key: str = "iou@val_threshold") -> str:
    """The headline table: per method, the mean IoU with its 95 % interval, the paired
    difference with the visual hull, and the per-category means."""
    summary = summarize_real_objects(results, key)
    categories = list(next(iter(summary.values()))["per_category"]) if summary else []
    hull = "visual_hull" in results.get("baselines", {})
    lines = [f"{'method':<18} {'seeds':>5} {key:>24} {'minus hull (wins)':>32}  "
             + " ".join(f"{c[:5]:>5}" for c in categories)]
    for name, row in summary.items():
        lo, hi = row["ci95"]
        diff = ""
        if hull and name != "visual_hull":
            d = paired_with(results, name, key=key)
            diff = (f"{d['mean']:+.3f} [{d['ci95'][0]:+.3f}, {d['ci95'][1]:+.3f}] "
                    f"({d['wins']}/{d['n']})")
        seeds = "-" if row["n_seeds"] is None else str(row["n_seeds"])
        lines.append(f"{name:<18} {seeds:>5} {row['mean']:>7.3f} [{lo:.3f}, {hi:.3f}]  "
                     f"{diff:>32}  " + " ".join(f"{row['per_category'][c]:>5.2f}"
                                                for c in categories))
    return "\n".join(lines)


CURVE = ("fine_tuned_1/8", "fine_tuned_1/4", "fine_tuned_1/2", "fine_tuned")
"""The learning curve's configs, fewest real training objects first."""
FIGURE_ORDER = ("procedural", "real", "fine_tuned", "mixed", "visual_hull",
                "category_oracle", "mean_shape")


def plot_real_objects(results: dict, key: str = "iou@val_threshold"):
    """One figure of a recorded study: left, every method's mean IoU on the real test
    objects with its 95 % interval (over seeds for a trained config, one dot per seed;
    over objects for a baseline); right, the learning curve (fine-tuned IoU against the
    number of real training objects, 0 = the procedural model) with the hull's level.
    Returns the figure."""
    import matplotlib.pyplot as plt

    summary = summarize_real_objects(results, key)
    names = [n for n in FIGURE_ORDER if n in summary]
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.6), layout="constrained",
                                      gridspec_kw={"width_ratios": [1.4, 1]})
    for x, name in enumerate(names):
        row = summary[name]
        lo, hi = row["ci95"]
        trained = row["n_seeds"] is not None
        color = "C0" if trained else "0.55"
        left.bar(x, row["mean"], color=color, alpha=0.35 if trained else 0.25)
        if lo == lo:  # NaN with one seed: no interval
            left.errorbar(x, row["mean"], yerr=[[row["mean"] - lo], [hi - row["mean"]]],
                          color="black", capsize=4, lw=1)
        if trained:
            seeds = [float(np.mean(r["per_object"][key])) for r in results["runs"]
                     if r["config"] == name]
            left.plot([x] * len(seeds), seeds, "o", color=color, ms=4)
        left.text(x, 0.02, f"{row['mean']:.2f}", ha="center", fontsize=8)
    left.set_xticks(range(len(names)), [n.replace("_", "\n") for n in names], fontsize=8)
    left.set_ylabel(f"real test {key}")
    left.set_ylim(0, 1)
    left.set_title(f"{len(results['test_ids'])} held-out real objects (blue: networks, a dot "
                   "per seed; grey: baselines, the hull sees the poses)", fontsize=9)
    hull = summary.get("visual_hull", {}).get("mean")
    points = []
    if "procedural" in summary:
        points.append((0, summary["procedural"]))
    for name in CURVE:
        if name in summary:
            n = next(r["n_train"] for r in results["runs"] if r["config"] == name)
            points.append((n, summary[name]))
    if points:
        xs = [p[0] for p in points]
        ys = np.array([p[1]["mean"] for p in points])
        bounds = np.array([p[1]["ci95"] for p in points], dtype=float)
        bounds = np.where(np.isnan(bounds), ys[:, None], bounds)  # one seed: no interval
        right.errorbar(xs, ys, yerr=[ys - bounds[:, 0], bounds[:, 1] - ys], fmt="o-", color="C0",
                       capsize=4, label="procedural, then fine-tuned")
    if hull is not None:
        right.axhline(hull, ls="--", color="0.4", label="visual hull with poses")
    right.set_xlabel("real training objects")
    right.set_ylabel(key)
    right.set_ylim(0, 1)
    right.legend(loc="lower right", fontsize=8)
    right.set_title("what more real objects buy", fontsize=9)
    return fig
