"""The ``pose`` study: what happens to each method when the orbit it trusts is wrong.

The visual hull, event carving and the hybrid all assume the camera flew the known spiral
exactly; E2V never uses the orbit. A real rig is calibrated only so well. Two errors, each
constant over the orbit:

* **angle**: every camera pose turned by the same small rotation about the object's centre
  (a random axis per object, :func:`pose_error`);
* **radius**: the camera circles at ``1 + e`` times the assumed radius.

Turning every camera by R about the centre shows the same images as turning the object by R⁻¹
under the assumed cameras, and an orbit ``1 + e`` times wider the same as the object shrunk by
``1 / (1 + e)`` (the whole scene scaled about the centre); so each test object is moved that
way, then rendered, simulated and carved with the assumed cameras, while its label stays the
object's true shape. Levels: :data:`POSE_LEVELS`. For every test object of data_small and
level, one record (``id``: ``LEVEL/OBJECT``) holds the visual hull's and event carving's scores;
``--checkpoints`` adds learned models scored on the same perturbed event frames. Records are
merged under the results lock, so an interrupted study resumes. Command:
``python -m e2vlib.experiments.pose_study`` (see ``--help``).
"""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from e2vlib import paper
from e2vlib.experiments.orbit_error import pose_error

POSE_LEVELS = {
    "exact": (0.0, 0.0),
    "angle_1deg": (1.0, 0.0),
    "angle_2deg": (2.0, 0.0),
    "angle_5deg": (5.0, 0.0),
    "radius_5pct": (0.0, 0.05),
    "radius_10pct": (0.0, 0.10),
}
"""``{level: (camera angle error in degrees, relative orbit radius error)}``."""

QUESTION = ("The hull, event carving and the hybrid trust the known orbit; E2V does not use it. "
            "When every camera pose is off by a small rotation, or the orbit radius by a few "
            "per cent, how much does each lose, and where does each win?")

COMMAND = "python -m e2vlib.experiments.pose_study"


def perturbed_object(row: Mapping, config, level: str) -> dict:
    """One test object (a manifest ``row``) seen through the orbit error ``level``: ``{"frames":
    uint8 (n, H, W), "label": bool (32, 32, 32), "hull": bool grid, "carved": bool grid,
    "n_events"}``.

    The frames come from the data_small pipeline (:func:`e2vlib.data.mesh_to_sample`, whose
    renderer here moves the object first); the hull from the same rendered video's 120 video
    frames, carved with the assumed cameras; the carving from the simulated events. At level
    ``"exact"`` the frames are data_small's stored frames, bit for bit."""
    from e2vlib import geometry
    from e2vlib.data import mesh_to_sample
    from e2vlib.experiments.geometry_study import hull_from_video
    from e2vlib.scale.render_cache import render_orbit_cached
    from e2vlib.shapes import make_shape

    angle, radius = POSE_LEVELS[level]
    seed = int(row["seed"])
    transform = pose_error(angle, radius, seed)
    video_of = {}

    def moved_renderer(mesh, *args, **kwargs):
        moved = mesh.copy()
        moved.apply_transform(transform)
        video, t_us = render_orbit_cached(moved, *args, **kwargs)
        video_of["video"] = video
        return video, t_us

    sample = mesh_to_sample(make_shape(row["category"], seed), config, seed=seed,
                            renderer=moved_renderer)
    hull = hull_from_video(video_of["video"], config.resolution)
    density = geometry.event_ray_density(sample.events, geometry.orbit_camera_at,
                                         sample.sensor_size[0])
    return {"frames": sample.frames, "label": sample.voxels.astype(bool), "hull": hull,
            "carved": geometry.fill_solid(density), "n_events": len(sample.events)}


def _frames_path(cache: Path, level: str, object_id: str) -> Path:
    """Where :func:`run_pose_study` keeps one perturbed object's frames and label."""
    return cache / level / f"{object_id}.npz"


def first_per_category(rows: Sequence[Mapping], n: int | None) -> list[Mapping]:
    """The first ``n`` rows of each category (all rows when ``n`` is None), in order.

    >>> rows = [{"category": c} for c in "aabab"]
    >>> [r["category"] for r in first_per_category(rows, 1)]
    ['a', 'b']
    """
    if n is None:
        return list(rows)
    kept, counts = [], {}
    for row in rows:
        counts[row["category"]] = counts.get(row["category"], 0) + 1
        if counts[row["category"]] <= n:
            kept.append(row)
    return kept


def run_pose_study(out: str | os.PathLike = "experiments/results",
                   data: str | os.PathLike = "data_small",
                   cache: str | os.PathLike = "cache/pose",
                   levels: Sequence[str] = tuple(POSE_LEVELS),
                   limit_per_category: int | None = None, progress: bool = True) -> Path:
    """Score the hull and event carving on every (level, test object) not yet recorded in
    ``OUT/pose.json``, keeping each perturbed object's event frames in ``cache`` for
    :func:`add_checkpoints` (a recorded object whose kept frames are missing is made again,
    its learned scores kept); return the results path."""
    from tqdm.auto import tqdm

    from e2vlib.data import BuildConfig, read_manifest, save_sample
    from e2vlib.experiments.geometry_study import start_object_study
    from e2vlib.experiments.provenance import git_commit
    from e2vlib.experiments.runner import OBJECT_KEY, update_results
    from e2vlib.geometry import score_occupancy

    unknown = [level for level in levels if level not in POSE_LEVELS]
    if unknown:
        raise ValueError(f"unknown pose levels {unknown}; choose from {', '.join(POSE_LEVELS)}")
    data, cache = Path(data), Path(cache)
    config = BuildConfig.from_dict(json.loads((data / "config.json").read_text()))
    rows = first_per_category([r for r in read_manifest(data) if r["split"] == "test"],
                              limit_per_category)
    protocol = {"data": str(data), "levels": {k: list(POSE_LEVELS[k]) for k in POSE_LEVELS},
                "limit_per_category": limit_per_category,
                "hull": f"{paper.N_VIDEO_FRAMES} grey video frames at {config.resolution} px",
                "events_method": "geometry.event_ray_density + fill_solid (defaults)"}
    path = Path(out) / "pose.json"
    results = start_object_study(path, "pose", QUESTION, protocol)
    results["command"] = COMMAND
    recorded = {r["id"]: r for r in results["runs"]}
    # a recorded object whose kept frames are gone (a new machine, a cleared cache) is made
    # again: add_checkpoints needs its frames, and the hull and carving give the same scores
    todo = [(level, r) for level in levels for r in rows
            if f"{level}/{r['id']}" not in recorded
            or not _frames_path(cache, level, r["id"]).exists()]
    commit = git_commit()
    for level, row in tqdm(todo, desc="pose", unit="object", disable=not progress):
        seen = perturbed_object(row, config, level)
        frames_file = _frames_path(cache, level, row["id"])
        frames_file.parent.mkdir(parents=True, exist_ok=True)
        save_sample(frames_file, seen["frames"], seen["label"], n_events=seen["n_events"])
        record_id = f"{level}/{row['id']}"
        old = recorded.get(record_id, {})
        scores = {**old.get("scores", {}),  # the learned models' scores stay
                  "visual_hull": score_occupancy(seen["hull"], seen["label"]),
                  "events_carving": score_occupancy(seen["carved"], seen["label"])}
        results["runs"] = [r for r in results["runs"] if r["id"] != record_id]
        results["runs"].append({"id": record_id, "level": level, "object": row["id"],
                                "category": row["category"], "scores": scores,
                                "commit": commit})
        results = update_results(path, results, OBJECT_KEY)
    return path


def load_level(cache: str | os.PathLike, level: str, ids: Sequence[str]
               ) -> tuple[np.ndarray, np.ndarray]:
    """The kept event frames ``(N, n, H, W)`` uint8 and labels ``(N, 32, 32, 32)`` bool of
    ``ids`` at ``level`` (written by :func:`run_pose_study`; a missing one: rerun it)."""
    from e2vlib.data import load_sample

    pairs = []
    for object_id in ids:
        path = _frames_path(Path(cache), level, object_id)
        if not path.exists():
            raise FileNotFoundError(f"{path} is missing: the perturbed frames are kept in the "
                                    f"cache; rerun `{COMMAND} --levels {level}` to remake them")
        pairs.append(load_sample(path))
    return (np.stack([f for f, _ in pairs]).astype(np.uint8),
            np.stack([v for _, v in pairs]).astype(bool))


def add_checkpoints(path: str | os.PathLike, checkpoints: Mapping[str, str | os.PathLike],
                    cache: str | os.PathLike = "cache/pose", progress: bool = True) -> Path:
    """Score each learned model (``{name: checkpoint path}``, e.g. ``{"hybrid_early/seed0":
    ...}``) on every recorded (level, object)'s perturbed frames at IoU@0.3 and add it to those
    records' scores (a name already scored is skipped). The command that scored them joins the
    results' ``commands``."""
    import torch

    from e2vlib.experiments.runner import OBJECT_KEY, add_command, read_results, update_results
    from e2vlib.metrics import iou
    from e2vlib.model import load_checkpoint
    from e2vlib.train import predict

    path = Path(path)
    results = read_results(path)
    if results is None:
        raise FileNotFoundError(f"no pose study at {path}; run `{COMMAND}` first")
    for name, checkpoint in checkpoints.items():
        model = None
        for level in dict.fromkeys(r["level"] for r in results["runs"]):
            records = [r for r in results["runs"] if r["level"] == level
                       and name not in r["scores"]]
            if not records:
                continue
            model = model or load_checkpoint(checkpoint)
            frames, labels = load_level(cache, level, [r["object"] for r in records])
            probabilities = predict(model, torch.from_numpy(frames), "cpu").numpy()
            values = iou(probabilities, labels, threshold=0.3)
            for record, value in zip(records, values, strict=True):
                record["scores"][name] = {"iou@0.3": float(value)}
            results = update_results(path, results, OBJECT_KEY)
            if progress:
                print(f"{name} at {level}: IoU@0.3 {float(np.mean(values)):.3f} "
                      f"({len(values)} objects)")
    if add_command(results, f"{COMMAND} " + " ".join(  # where each learned score came from
            f"--checkpoint {name}={checkpoint}" for name, checkpoint in checkpoints.items())):
        update_results(path, results, OBJECT_KEY)
    return path


def level_table(results: Mapping) -> dict[str, dict[str, float]]:
    """``{method: {level: mean IoU@0.3}}`` over the objects scored at each level; a learned
    config's seeds (``config/seedK``) are averaged object by object first, as ``config``."""
    table: dict[str, dict[str, list[float]]] = {}
    for record in results["runs"]:
        seeds: dict[str, list[float]] = {}
        for name, scores in record["scores"].items():
            seeds.setdefault(name.split("/")[0], []).append(scores["iou@0.3"])
        for method, values in seeds.items():
            table.setdefault(method, {}).setdefault(record["level"], []).append(
                float(np.mean(values)))
    return {m: {level: float(np.mean(v)) for level, v in by.items()} for m, by in table.items()}


def level_objects(results: Mapping, method: str, level: str) -> dict[str, float]:
    """``{object id: IoU@0.3}`` of ``method`` at ``level``, a learned config's seeds
    (``config/seedK``) averaged per object, ready for
    :func:`e2vlib.experiments.hybrid_study.paired`.

    >>> runs = [{"level": "exact", "object": "x", "scores": {
    ...     "a/seed0": {"iou@0.3": 0.5}, "a/seed1": {"iou@0.3": 0.7}, "hull": {"iou@0.3": 0.4}}}]
    >>> level_objects({"runs": runs}, "a", "exact"), level_objects({"runs": runs}, "hull", "exact")
    ({'x': 0.6}, {'x': 0.4})
    """
    out = {}
    for record in results["runs"]:
        if record["level"] != level:
            continue
        values = [s["iou@0.3"] for name, s in record["scores"].items()
                  if name.split("/")[0] == method]
        if values:
            out[record["object"]] = float(np.mean(values))
    return out


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``python -m e2vlib.experiments.pose_study``."""
    parser = argparse.ArgumentParser(prog=COMMAND, description=QUESTION)
    parser.add_argument("--out", default="experiments/results", help="folder of pose.json")
    parser.add_argument("--data", default="data_small")
    parser.add_argument("--cache", default="cache/pose",
                        help="where the perturbed event frames are kept (git-ignored)")
    parser.add_argument("--levels", nargs="+", default=list(POSE_LEVELS),
                        choices=list(POSE_LEVELS))
    parser.add_argument("--limit-per-category", type=int, default=None)
    parser.add_argument("--checkpoint", action="append", default=[], metavar="NAME=PATH",
                        help="score a learned model too, e.g. hybrid_early/seed0=PATH")
    parser.set_defaults(func=run_command)
    return parser


def run_command(args: argparse.Namespace) -> int:
    """Carve every level, then score the named checkpoints; print the level table."""
    named = {}
    for item in args.checkpoint:
        name, sep, checkpoint = item.partition("=")
        if not sep or not name or not checkpoint:
            from e2vlib.experiments.errors import UsageError

            raise UsageError(f"--checkpoint must look like NAME=PATH, got {item!r}")
        named[name] = checkpoint
    path = run_pose_study(args.out, args.data, args.cache, args.levels,
                          args.limit_per_category)
    if named:
        add_checkpoints(path, named, args.cache)
    from e2vlib.experiments.runner import read_results

    for method, by_level in level_table(read_results(path)).items():
        print(f"{method:16s} " + "  ".join(f"{k} {v:.3f}" for k, v in by_level.items()))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    from e2vlib.experiments import errors

    return errors.run(build_parser, None if argv is None else list(argv))


if __name__ == "__main__":
    raise SystemExit(main())
