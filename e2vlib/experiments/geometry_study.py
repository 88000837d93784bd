"""The ``geometry`` study: reconstruction without learning, beside the learned model.

For every test object of data_small (known camera poses, no training) it scores

* ``visual_hull``: carved from the silhouettes of the grey orbit video (the 120 video
  frames at the paper's 240 fps), the reference for silhouette-based methods;
* ``events_carving``: events only, from the object's raw events in the events cache
  (:data:`e2vlib.experiments.EVENTS_CACHE`), with :func:`e2vlib.geometry.event_ray_density`
  and :func:`e2vlib.geometry.fill_solid`;
* ``learned``: the shipped ``data_small/checkpoints/first_recipe.pt`` on the stored frames;
* ``mean_shape``: the mean training label, the baseline of lessons 06-07;
* more checkpoints by name (``--checkpoint best=data_small/checkpoints/e2v_tiny.pt``), each also
  at its validation-picked threshold, and ``category_oracle`` (the mean training label of the
  object's own category) with them: added to the recorded objects without carving again;

all with :func:`e2vlib.geometry.score_occupancy` (the learned model's metrics). One record
per object, appended to ``OUT/geometry.json`` atomically; recorded objects are skipped, so
an interrupted study resumes. Command: ``python -m e2vlib experiment geometry``.
"""

from __future__ import annotations

import json
import os
import time
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from e2vlib import metrics, paper
from e2vlib.experiments.provenance import REPO, git_commit
from e2vlib.experiments.runner import (
    OBJECT_KEY,
    add_command,
    check_results_path,
    read_results,
    update_results,
)
from e2vlib.experiments.summary import unique_runs

METHODS = ("visual_hull", "events_carving", "learned", "mean_shape")
"""The rows of the study, in table order (added checkpoints and ``category_oracle`` follow)."""

QUESTION = ("The paper compares E2V with image-based methods only across papers (Table III). "
            "With known camera poses and no learning, how far do silhouettes (a visual hull of "
            "the grey video) and events alone (carving from event outlines) get on the same "
            "test objects, next to the learned model and the mean shape?")


def hull_from_video(video: np.ndarray, resolution: int) -> np.ndarray:
    """The visual hull ``(32, 32, 32)`` of a rendered orbit ``video`` (``oversample`` x 119 + 1
    frames): the silhouettes of its 120 video frames (every ``oversample``-th rendered frame)
    carved with the orbit's known cameras at ``resolution`` px."""
    from e2vlib import geometry
    from e2vlib.render import orbit_cameras

    step = (len(video) - 1) // (paper.N_VIDEO_FRAMES - 1)
    silhouettes = geometry.silhouettes_from_video(video[::step])
    return geometry.visual_hull(silhouettes, orbit_cameras(paper.N_VIDEO_FRAMES), resolution)


def start_object_study(path: Path, study: str, question: str, protocol: dict) -> dict:
    """The object study recorded at ``path`` (a new one when missing), refused when it was
    made under another ``protocol``; shared by the geometry and pose studies."""
    check_results_path(path)
    results = read_results(path) or {"study": study, "question": question,
                                     "protocol": protocol, "runs": []}
    if results["protocol"] != protocol:
        raise ValueError(f"{path} holds runs of another protocol ({results['protocol']}); "
                         f"use another --out folder to run this one ({protocol})")
    return results


def _object_record(item: dict, config, data: Path, events_root: Path, learned: np.ndarray,
                   mean_shape: np.ndarray, n_points: int) -> dict:
    """Scores of every method on one test object (``item``: a manifest row)."""
    from e2vlib import geometry
    from e2vlib.data import load_sample
    from e2vlib.io import load_events
    from e2vlib.render import render_orbit
    from e2vlib.shapes import make_shape, normalize_mesh

    _, label = load_sample(data / "samples" / f"{item['id']}.npz")
    label = label.astype(bool)
    mesh = normalize_mesh(make_shape(item["category"], int(item["seed"])))
    started = time.perf_counter()
    video, _ = render_orbit(mesh, n_video_frames=paper.N_VIDEO_FRAMES, fps=paper.VIDEO_FPS,
                            resolution=config.resolution, oversample=config.oversample)
    # rendered oversample * 119 + 1 frames: every oversample-th is one of the 120 video frames
    hull = hull_from_video(video, config.resolution)
    hull_seconds = time.perf_counter() - started
    events_path = events_root / "events" / f"{item['id']}.npz"
    if not events_path.exists():
        raise FileNotFoundError(f"{events_path} is missing: the events cache must hold the raw "
                                "events of every sample; rebuild it with the command in "
                                "e2vlib.experiments.EVENTS_COMMAND")
    events, sensor_size = load_events(events_path)
    started = time.perf_counter()
    density = geometry.event_ray_density(events, geometry.orbit_camera_at, sensor_size[0])
    carved = geometry.fill_solid(density)
    events_seconds = time.perf_counter() - started
    scores = {
        "visual_hull": geometry.score_occupancy(hull, label, n_points),
        "events_carving": geometry.score_occupancy(carved, label, n_points),
        "learned": geometry.score_occupancy(learned, label, n_points),
        "mean_shape": geometry.score_occupancy(mean_shape, label, n_points),
    }
    return {"id": item["id"], "category": item["category"], "scores": scores,
            "seconds": {"visual_hull": round(hull_seconds, 2),
                        "events_carving": round(events_seconds, 2)},
            "n_events": int(len(events))}


def run_geometry_study(out: str | os.PathLike = "experiments/results",
                       data: str | os.PathLike = "data_small",
                       events: str | os.PathLike = "cache/events_small",
                       limit_per_category: int | None = None, n_points: int = 8192,
                       progress: bool = True,
                       checkpoints: Mapping[str, str] | None = None) -> Path:
    """Score every method on every test object not yet in ``OUT/geometry.json``; return it.

    ``limit_per_category`` keeps only the first objects of each category (quick checks).
    ``checkpoints`` (``{name: path}``) adds learned models scored on the recorded objects
    (see :func:`add_checkpoints`).
    """
    import torch
    from tqdm.auto import tqdm

    from e2vlib.data import BuildConfig, E2VDataset, read_manifest
    from e2vlib.inputs import preload
    from e2vlib.model import load_checkpoint
    from e2vlib.train import predict

    data, events = Path(data), Path(events)
    config = BuildConfig.from_dict(json.loads((data / "config.json").read_text()))
    test = E2VDataset(data, "test")
    chosen = list(range(len(test)))
    if limit_per_category is not None:
        chosen = [i for c, idx in test.category_indices().items()
                  for i in idx[:limit_per_category]]
    protocol = {"data": str(data), "events": str(events),
                "checkpoint": str(data / "checkpoints" / "first_recipe.pt"),
                "silhouettes": f"{paper.N_VIDEO_FRAMES} grey video frames at "
                               f"{config.resolution} px",
                "events_method": "geometry.event_ray_density + fill_solid (defaults)",
                "n_points": n_points, "limit_per_category": limit_per_category}
    path = Path(out) / "geometry.json"
    results = start_object_study(path, "geometry", QUESTION, protocol)
    results["command"] = "python -m e2vlib experiment geometry"
    done = {r["id"] for r in results["runs"]}
    todo = [i for i in chosen if test.ids[i] not in done]
    if todo:
        model = load_checkpoint(protocol["checkpoint"])
        frames = torch.stack([test[i]["frames"] for i in todo])
        learned = predict(model, frames, "cpu").numpy()
        train = preload(E2VDataset(data, "train"))
        mean_shape = train.voxels.float().mean(0).numpy()
    rows = {r["id"]: r for r in read_manifest(data)}
    commit = git_commit()  # one `git` call per study, not per object
    for k, i in enumerate(tqdm(todo, desc="geometry", unit="object", disable=not progress)):
        record = _object_record(rows[test.ids[i]], config, data, events, learned[k],
                                mean_shape, n_points)
        results["runs"].append({**record, "commit": commit})
        results = update_results(path, results, OBJECT_KEY)  # merged with other writers'
    if checkpoints:
        add_checkpoints(path, checkpoints, data, n_points)
    return path


def add_checkpoints(path: str | os.PathLike, checkpoints: Mapping[str, str],
                    data: str | os.PathLike = "data_small", n_points: int = 8192) -> Path:
    """Score each checkpoint (``{name: path}``) and the per-category oracle on every object
    recorded in ``path`` (a geometry results file) that lacks them; return ``path``.

    A checkpoint is scored like ``learned`` plus ``iou@val_threshold`` at its threshold
    (recorded in the checkpoint, or picked on the validation split); the file notes each
    one's path, weights digest and threshold under ``"checkpoints"``. A name that is a
    method of the study, or already recorded from another path, is refused.
    """
    import torch

    from e2vlib.data import E2VDataset
    from e2vlib.experiments.real_study import checkpoint_predictions
    from e2vlib.geometry import score_occupancy
    from e2vlib.inputs import preload
    from e2vlib.metrics import iou
    from e2vlib.model import DIGEST_KEY
    from e2vlib.train import category_mean_shapes

    path, data = Path(path), Path(data)
    results = read_results(path)
    if results is None:
        raise FileNotFoundError(f"{path} does not exist; run `python -m e2vlib experiment "
                                "geometry` first")
    clash = sorted(set(checkpoints) & {*METHODS, "category_oracle"})
    if clash:
        raise ValueError(f"checkpoint names {clash} are method names; choose others")
    known = results.setdefault("checkpoints", {})
    for name, ckpt in checkpoints.items():
        if name in known and known[name]["path"] != str(ckpt):
            raise ValueError(f"{path} already scores a checkpoint named {name!r} from "
                             f"{known[name]['path']}; give {ckpt} another name")
    methods = [*checkpoints, "category_oracle"]
    todo = [r for r in results["runs"] if any(m not in r["scores"] for m in methods)]
    if not todo:
        return path
    test = E2VDataset(data, "test")
    index = {sid: i for i, sid in enumerate(test.ids)}
    missing = [r["id"] for r in todo if r["id"] not in index]
    if missing:
        raise ValueError(f"{path} records objects that {data}'s test split lacks "
                         f"({missing[:3]}...); give the --data it was made from")
    items = [test[index[r["id"]]] for r in todo]  # each sample read once
    frames = torch.stack([item["frames"] for item in items])
    labels = [item["voxels"].numpy().astype(bool) for item in items]
    val = preload(E2VDataset(data, "val"), progress=False)
    oracle = {c: v.numpy() for c, v in
              category_mean_shapes(preload(E2VDataset(data, "train"), progress=False)).items()}
    for name, ckpt in checkpoints.items():
        probabilities, threshold, how = checkpoint_predictions(ckpt, frames, val)
        digest = torch.load(ckpt, map_location="cpu", weights_only=True).get(DIGEST_KEY)
        known[name] = {"path": str(ckpt), DIGEST_KEY: digest, "val_threshold": threshold,
                       "val_threshold_from": how}
        for record, label, p in zip(todo, labels, probabilities, strict=True):
            if name not in record["scores"]:
                scores = score_occupancy(p, label, n_points)
                scores["val_threshold"] = threshold
                scores["iou@val_threshold"] = float(iou(p, label, threshold))
                record["scores"][name] = scores
    for record, label in zip(todo, labels, strict=True):
        if "category_oracle" not in record["scores"]:
            record["scores"]["category_oracle"] = score_occupancy(oracle[record["category"]],
                                                                  label, n_points)
    add_command(results, "python -m e2vlib experiment geometry " + " ".join(
        f"--checkpoint {name}={ckpt}" for name, ckpt in checkpoints.items()))
    update_results(path, results, OBJECT_KEY)  # another --checkpoint run's scores are kept
    return path


def countable_objects(results: dict, data: str | os.PathLike | None = None,
                      source: str = "the geometry results") -> list[dict]:
    """The records a summary counts: each object once (its first record) and, when the
    manifest of ``data`` (default: the study's ``protocol["data"]``, from the repository
    root if not found here) can be read, only the objects of its test split. Warns naming
    the records left out."""
    from e2vlib.data import read_manifest

    runs = unique_runs(results["runs"], lambda r: r["id"], source)
    named = data or results.get("protocol", {}).get("data", "data_small")
    folder = Path(named)
    if not folder.is_absolute() and not folder.exists():
        folder = REPO / folder
    if not (folder / "manifest.csv").is_file():
        return runs  # the data is not here: the objects cannot be checked
    test = {row["id"] for row in read_manifest(folder) if row["split"] == "test"}
    unknown = [r["id"] for r in runs if r["id"] not in test]
    if unknown:
        warnings.warn(f"{source}: ignored {len(unknown)} record(s) that are not a test object "
                      f"of {named}: {', '.join(unknown)} (remove "
                      "them, or give the data the study was made from)", stacklevel=3)
    return [r for r in runs if r["id"] in test]


def summarize_geometry(results: dict | str | os.PathLike, metric: str = "iou@0.3",
                       data: str | os.PathLike | None = None) -> list[dict]:
    """Per method: mean of ``metric`` over objects, its 95 % interval (t over objects), n.

    Each test object counts once; copies and objects not in the test split of ``data``
    (default: the study's) are left out with a warning (:func:`countable_objects`).
    """
    source = "the geometry results"
    if not isinstance(results, dict):
        source, results = str(results), read_results(results)
    runs = countable_objects(results, data, source)
    rows = []
    extra = [*results.get("checkpoints", {}), "category_oracle"]
    for method in [*METHODS, *extra]:
        if method in extra and not all(method in r["scores"] for r in runs):
            continue  # not added (yet)
        values = np.array([r["scores"][method][metric] for r in runs])
        if len(values) == 0:
            continue
        rows.append({"method": method, "n": len(values), "mean": float(values.mean()),
                     "ci95": metrics.interval95(values)})
    return rows
