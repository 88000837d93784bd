"""Scoring on real meshes: how far training on procedural shapes carries to real objects.

The real-mesh test set (:mod:`e2vlib.experiments.real_meshes`, built by ``make-data --real-meshes``)
holds third-party furniture, vehicle and device models of the paper's categories, made into
samples by the data_small protocol. On every object this scores, with
:func:`e2vlib.geometry.score_occupancy` (the learned model's metrics):

* each checkpoint given (``NAME=PATH``; ``tiny`` =
  ``data_small/checkpoints/first_recipe.pt``) on the stored frames, at IoU thresholds 0.2-0.5
  and at the threshold picked on data_small's
  validation split (:func:`e2vlib.experiments.best_threshold`, unless the checkpoint
  records one as ``val_threshold``);
* ``visual_hull``: carved from the silhouettes of the object's 120 grey video frames with
  the camera poses known (as the ``geometry`` study does on data_small's test split);
* ``mean_shape``: data_small's mean training label; ``category_oracle``: the mean training
  label of the object's own category (an oracle that is told the category).

One record per object is written to ``OUT/real_meshes.json`` atomically after each object;
recorded methods are skipped, so an interrupted run resumes and a second checkpoint is added
later by one more ``--checkpoint best=data_small/checkpoints/e2v_tiny.pt``. Per method and
category the file also holds a summary: n, mean IoU@0.3 and its 95 % interval over objects
(Student's t). Command: ``python -m e2vlib.experiments.real_study`` (``--help``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from e2vlib import metrics, paper
from e2vlib.experiments.provenance import cpu_name, git_commit, package_version
from e2vlib.experiments.runner import OBJECT_KEY, read_results, update_results

BASELINES = ("visual_hull", "mean_shape", "category_oracle")
"""The methods scored beside the checkpoints, in table order."""
DEFAULT_CHECKPOINTS = {"tiny": "data_small/checkpoints/first_recipe.pt"}
COMMAND = ("python -m e2vlib.experiments.real_study "
           "--checkpoint tiny=data_small/checkpoints/first_recipe.pt")
"""The recorded command (after the build in
:data:`e2vlib.experiments.real_meshes.BUILD_COMMAND`)."""
QUESTION = ("The learned models train on procedural stand-ins of the 13 categories. On real "
            "third-party models of the same categories (Sweet Home 3D's furniture libraries), "
            "made into samples by the same pipeline, how well do they reconstruct, next to a "
            "visual hull with known poses, the mean shape and the per-category oracle?")


def countable_runs(runs: Sequence[dict], ids: Sequence[str] | None = None
                   ) -> tuple[list[dict], list[str]]:
    """``(runs, left_out)``: the records a summary counts (each object once, its first
    record; of one of the paper's categories; in ``ids`` when given, the objects of the
    dataset scored) and a note for each record left out.

    Examples
    --------
    >>> runs = [{"id": "chair_a", "category": "chair"}, {"id": "chair_a", "category": "chair"},
    ...         {"id": "sofa_b", "category": "sofa"}, {"id": "x_c", "category": "bookshelf"}]
    >>> kept, left_out = countable_runs(runs, ids=["chair_a", "x_c"])
    >>> [r["id"] for r in kept], left_out
    (['chair_a'], ['chair_a (a second record)', 'sofa_b (not in the dataset)', \
"x_c (category 'bookshelf' is not the paper's)"])
    """
    wanted = None if ids is None else set(ids)
    kept, seen, left_out = [], set(), []
    for run in runs:
        sid = run.get("id")
        if sid is not None and sid in seen:  # (records without an id cannot be matched)
            left_out.append(f"{sid} (a second record)")
        elif wanted is not None and sid not in wanted:
            left_out.append(f"{sid} (not in the dataset)")
        elif run.get("category") not in paper.CATEGORIES:
            left_out.append(f"{sid} (category {run.get('category')!r} is not the paper's)")
        else:
            kept.append(run)
        seen.add(sid)
    return kept, left_out


def summarize_real(runs: Sequence[dict], metric: str = "iou@0.3",
                   ids: Sequence[str] | None = None) -> dict:
    """``{method: {"overall": row, "per_category": {category: row}}}`` with rows
    ``{"n", "mean", "ci95"}`` of ``metric`` over the objects holding it, categories in the
    paper's order; only the records :func:`countable_runs` keeps are counted."""
    def row(values: list[float]) -> dict:
        return {"n": len(values), "mean": float(np.mean(values)),
                "ci95": metrics.interval95(values)}

    runs = countable_runs(runs, ids)[0]
    methods = list(dict.fromkeys(m for r in runs for m in r["scores"]))
    out = {}
    for method in methods:
        have = [(r["category"], r["scores"][method][metric]) for r in runs
                if metric in r["scores"].get(method, {})]
        out[method] = {"overall": row([v for _, v in have]), "per_category": {
            c: row([v for k, v in have if k == c])
            for c in paper.CATEGORIES if any(k == c for k, _ in have)}}
    return out


def mesh_hull(mesh, resolution: int = 128, anti_aliasing: str = "ssaa") -> np.ndarray:
    """Visual hull (bool ``(32, 32, 32)``) of ``mesh`` carved from its 120 grey orbit frames
    at ``resolution`` px with the camera poses known.

    The video is rendered at the paper's 240 fps without the events' oversampling: its 120
    frames are the ones the geometry study keeps of the oversampled video (every
    ``oversample``-th frame sits at the same camera), at a third of the rendering.
    """
    from e2vlib import geometry
    from e2vlib.render import orbit_cameras, render_orbit

    video, _ = render_orbit(mesh, n_video_frames=paper.N_VIDEO_FRAMES, fps=paper.VIDEO_FPS,
                            resolution=resolution, oversample=1, anti_aliasing=anti_aliasing)
    silhouettes = geometry.silhouettes_from_video(video)
    return geometry.visual_hull(silhouettes, orbit_cameras(paper.N_VIDEO_FRAMES), resolution)


def checkpoint_predictions(path: str, frames, val) -> tuple[np.ndarray, float, str]:
    """``(probabilities (N, 32, 32, 32), threshold, how the threshold was chosen)`` of the
    checkpoint at ``path`` on ``frames``; the threshold is the checkpoint's ``val_threshold``
    or, if it records none, the one picked on ``val`` (a preloaded split)."""
    import torch

    from e2vlib.experiments.runner import best_threshold
    from e2vlib.model import load_checkpoint
    from e2vlib.train import predict

    model = load_checkpoint(path)
    state = torch.load(path, map_location="cpu", weights_only=True)
    recorded = state.get("val_threshold") if isinstance(state, dict) else None
    if recorded is not None:
        threshold, how = float(recorded), "recorded in the checkpoint (val_threshold)"
    else:
        threshold = best_threshold(predict(model, val.frames, "cpu"), val.voxels)
        how = ("picked on data_small's validation split (experiments.best_threshold; the "
               "checkpoint records none)")
    return predict(model, frames, "cpu").numpy(), threshold, how


def run_real_study(out: str | os.PathLike = "experiments/results",
                   data: str | os.PathLike = "cache/real_meshes",
                   train_data: str | os.PathLike = "data_small",
                   checkpoints: Mapping[str, str] | None = None,
                   catalogue: str | os.PathLike | None = None,
                   folder: str | os.PathLike | None = None, n_points: int = 8192,
                   command: str = COMMAND, progress: bool = True) -> Path:
    """Score every method on every object of ``data`` not yet scored; return the file.

    ``checkpoints``: ``{name: path}`` (default :data:`DEFAULT_CHECKPOINTS`); a name already in
    the file with another path is refused. ``catalogue`` and ``folder`` (the ``.sh3f``
    libraries; defaults: those ``data`` was built from) give the meshes for the visual hull.
    """
    import torch
    from tqdm.auto import tqdm

    from e2vlib.data import BuildConfig, E2VDataset
    from e2vlib.experiments.real_meshes import (
        FURNITURE_DIR,
        MAPPING_CSV,
        load_entry_mesh,
        read_mapping,
        resolve,
    )
    from e2vlib.geometry import score_occupancy
    from e2vlib.inputs import preload
    from e2vlib.metrics import iou
    from e2vlib.train import category_mean_shapes

    checkpoints = dict(checkpoints or DEFAULT_CHECKPOINTS)
    clash = sorted(set(checkpoints) & set(BASELINES))
    if clash:
        raise ValueError(f"checkpoint names {clash} are baseline names; choose others")
    data, train_data = Path(data), Path(train_data)
    if not (data / "manifest.csv").is_file():
        from e2vlib.experiments.real_meshes import BUILD_COMMAND
        raise FileNotFoundError(f"{data} holds no real-mesh dataset; build it first: "
                                f"{BUILD_COMMAND}")
    from e2vlib.data.checks import read_config

    stored = read_config(data)  # a regular, bounded, checked file
    settings = {k: v for k, v in stored.items() if k not in ("categories", "source")}
    config = BuildConfig.from_dict({**settings, "categories": list(paper.CATEGORIES),
                                    "per_category": 1})
    dataset = E2VDataset(data, "test")
    test = preload(dataset, progress=False)
    path = Path(out) / "real_meshes.json"
    protocol = {"data": str(data), "train_data": str(train_data),
                "frames": {k: settings[k] for k in ("resolution", "frame_size", "oversample",
                                                    "contrast", "n_frames", "dt_us",
                                                    "windows")},
                "silhouettes": f"{paper.N_VIDEO_FRAMES} grey video frames at "
                               f"{config.resolution} px, poses known",
                "n_points": n_points}
    results = (read_results(path, "real_meshes")
               or {"study": "real_meshes", "question": QUESTION, "protocol": protocol,
                   "checkpoints": {}, "runs": []})
    if results.get("protocol") != protocol:
        raise ValueError(f"{path} holds runs of another protocol ({results.get('protocol')}); "
                         f"use another --out folder for this one ({protocol})")
    if not isinstance(results.setdefault("checkpoints", {}), dict):
        raise ValueError(f"{path}: checkpoints is not a mapping of names to checkpoints; "
                         "correct it or use another --out folder")
    for name, ckpt in checkpoints.items():
        known = results["checkpoints"].get(name)
        if known is not None and known["path"] != str(ckpt):
            raise ValueError(f"{path} already scores a checkpoint named {name!r} from "
                             f"{known['path']}; give {ckpt} another name")
    from e2vlib.experiments.real_meshes import BUILD_COMMAND
    results.setdefault("commands", [])
    if command not in results["commands"]:
        results["commands"].append(command)
    results.update(command=command, build_command=BUILD_COMMAND, cpu=cpu_name(),
                   packages={name: package_version(name)
                             for name in ("sweethome3d-furniture", "crrcsim-data")},
                   source=stored.get("source"), torch=torch.__version__,
                   missing_categories=[c for c in paper.CATEGORIES
                                       if c not in stored.get("categories", ())])
    runs, rescored, changed = _current_runs(results, test.ids, dataset.digests)
    methods = [*checkpoints, *BASELINES]
    todo = [i for i, sid in enumerate(test.ids)
            if any(m not in runs.get(sid, {}).get("scores", {}) for m in methods)]
    if todo:
        train = preload(E2VDataset(train_data, "train"), progress=False)
        val = preload(E2VDataset(train_data, "val"), progress=False)
        mean_shape = train.voxels.float().mean(0).numpy()
        oracle = {c: v.numpy() for c, v in category_mean_shapes(train).items()}
        learned = {}
        for name, ckpt in checkpoints.items():
            probabilities, threshold, how = checkpoint_predictions(ckpt, test.frames, val)
            learned[name] = (probabilities, threshold)
            results["checkpoints"][name] = {"path": str(ckpt), "val_threshold": threshold,
                                            "val_threshold_from": how}
        source = stored.get("source", {})
        meshes = {m.id: (m, e) for m, e in resolve(
            read_mapping(catalogue or source.get("catalogue", MAPPING_CSV)),
            folder or source.get("folder", FURNITURE_DIR))}
    commit = git_commit()
    for i in tqdm(todo, desc="real meshes", unit="object", disable=not progress):
        sid, category = test.ids[i], test.categories[i]
        label = test.voxels[i].numpy().astype(bool)
        record = runs.setdefault(sid, {"id": sid, "category": category, "scores": {},
                                       "seconds": {}})
        record["sample_sha256"] = dataset.digests.get(sid)
        scores = record["scores"]
        for name, (probabilities, threshold) in learned.items():
            if name not in scores:
                s = score_occupancy(probabilities[i], label, n_points)
                s["val_threshold"] = threshold
                s["iou@val_threshold"] = float(iou(probabilities[i], label, threshold))
                scores[name] = s
        if "visual_hull" not in scores:
            if sid not in meshes:
                raise ValueError(f"{sid} is not in the catalogue; give the --catalogue "
                                 f"{data} was built from")
            mapped, entry = meshes[sid]
            started = time.perf_counter()
            hull = mesh_hull(load_entry_mesh(entry, folder or source.get("folder",
                                                                         FURNITURE_DIR),
                                             pose=mapped.pose),
                             config.resolution, config.anti_aliasing)
            record["seconds"]["visual_hull"] = round(time.perf_counter() - started, 2)
            scores["visual_hull"] = score_occupancy(hull, label, n_points)
        if "mean_shape" not in scores:
            scores["mean_shape"] = score_occupancy(mean_shape, label, n_points)
        if "category_oracle" not in scores:
            scores["category_oracle"] = score_occupancy(oracle[category], label, n_points)
        record["commit"] = commit
        _write_results(path, results, runs, test.ids, rescored)
    if changed and not todo:
        _write_results(path, results, runs, test.ids, rescored)
    return path


def _current_runs(results: dict, ids: Sequence[str], digests: Mapping[str, str]
                  ) -> tuple[dict[str, dict], set[str], bool]:
    """``({id: record}, rescored ids, changed)``: the records of the objects in the dataset
    now (``ids``), each once; records of objects it no longer holds move to
    ``results["dropped_runs"]``, and a record of a sample made again since (its
    ``sample_sha256`` differs from the manifest's, ``digests``) loses its scores, so it is
    scored anew."""
    wanted, runs, dropped = set(ids), {}, []
    for record in results["runs"]:
        sid = record.get("id")
        if sid in wanted and sid not in runs:
            runs[sid] = record
        else:
            dropped.append(record)
    stale = [sid for sid, r in runs.items() if r.get("sample_sha256") is not None
             and r["sample_sha256"] != digests.get(sid)]
    for sid in stale:
        runs[sid]["scores"], runs[sid]["seconds"] = {}, {}
    if dropped:
        results.setdefault("dropped_runs", []).extend(dropped)
    return runs, set(stale), bool(dropped or stale)


def _write_results(path: Path, results: dict, runs: dict[str, dict], ids: Sequence[str],
                   rescored: set[str] = frozenset()) -> None:
    """Write ``results`` with ``runs`` through the lab's one locked writer
    (:func:`~e2vlib.experiments.runner.update_results`): scores another process wrote
    meanwhile are merged in by object; then only the dataset's objects are kept, in its
    order, with their summary. A ``rescored`` object (its sample was made again) keeps our
    record whole, so no score of its old sample comes back from disk."""
    results["runs"] = [runs[sid] for sid in ids if sid in runs]

    def finish(merged: dict) -> None:
        by_id = {record["id"]: record for record in merged["runs"]}
        by_id.update({sid: runs[sid] for sid in rescored if sid in runs})
        merged["runs"] = [by_id[sid] for sid in ids if sid in by_id]
        merged["summary"] = summarize_real(merged["runs"], ids=ids)

    written = update_results(path, results, OBJECT_KEY, finish)
    runs.update({record["id"]: record for record in written["runs"]})


def format_real_table(results: dict | str | os.PathLike, metric: str = "iou@0.3") -> str:
    """The per-category table of a real-mesh results file: n and, per method, the mean of
    ``metric`` with its 95 % interval over objects."""
    source = "the results"
    if not isinstance(results, dict):
        path = source = Path(results)
        results = read_results(path, "real_meshes")  # the one checked reader
        if results is None:
            raise FileNotFoundError(f"no real-mesh results at {path}; record them with "
                                    f"`{COMMAND} --out {path.parent}`")
    summary = summarize_real(results["runs"], metric)
    left_out = countable_runs(results["runs"])[1]
    methods = list(summary)
    if not methods:
        raise ValueError(f"{source} holds no object scored on {metric}; record some with "
                         f"`{COMMAND}`")
    width = 22  # room for a negative lower bound: "0.261 [-0.022, 0.543]"
    header = f"{'category':<11} {'n':>3} " + " ".join(f"{m:>{width}}" for m in methods)
    lines = [header, "-" * len(header)]

    def cell(row):
        lo, hi = row["ci95"]
        if row["n"] < 2:  # no spread to estimate from a single object
            return f"{row['mean']:.3f} (1 object)".rjust(width)
        return f"{row['mean']:.3f} [{lo:.3f}, {hi:.3f}]".rjust(width)

    first = summary[methods[0]]["per_category"]
    for c in first:
        lines.append(f"{c:<11} {first[c]['n']:>3} "
                     + " ".join(cell(summary[m]["per_category"][c]) for m in methods))
    lines.append("-" * len(header))
    lines.append(f"{'overall':<11} {summary[methods[0]]['overall']['n']:>3} "
                 + " ".join(cell(summary[m]["overall"]) for m in methods))
    if left_out:
        lines.append(f"left out: {', '.join(left_out)}")
    return "\n".join(lines)


def build_parser(parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser
                 ) -> argparse.ArgumentParser:
    """The parser of ``python -m e2vlib.experiments.real_study`` (its ``func``:
    :func:`run_command`); ``parser_class`` makes its errors (the command line's is one
    line)."""
    parser = parser_class(prog="python -m e2vlib.experiments.real_study",
                          description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default="cache/real_meshes",
                        help="the real-mesh dataset (make-data --real-meshes)")
    parser.add_argument("--train-data", default="data_small",
                        help="dataset of the baselines' train and the threshold's val split")
    parser.add_argument("--checkpoint", action="append", metavar="NAME=PATH",
                        type=_name_and_path, help="a model to score (repeatable; default "
                        "tiny=data_small/checkpoints/first_recipe.pt)")
    parser.add_argument("--out", default="experiments/results",
                        help="folder of real_meshes.json")
    parser.add_argument("--table", action="store_true",
                        help="only print the table of the recorded file")
    parser.set_defaults(func=run_command)
    return parser


def _name_and_path(item: str) -> tuple[str, str]:
    """``--checkpoint NAME=PATH`` as ``(NAME, PATH)``."""
    name, sep, path = item.partition("=")
    if not sep or not name or not path:
        raise argparse.ArgumentTypeError(f"must look like NAME=PATH, got {item!r}")
    return name, path


def run_command(args: argparse.Namespace) -> int:
    """Run a parsed ``real_study`` command line: print the table (``--table``), or score and
    then print it."""
    if args.table:
        print(format_real_table(Path(args.out) / "real_meshes.json"))
        return 0
    checkpoints = dict(args.checkpoint or DEFAULT_CHECKPOINTS.items())
    command = " ".join(["python -m e2vlib.experiments.real_study", *args.argv])
    path = run_real_study(args.out, args.data, args.train_data, checkpoints,
                          command=command)
    print(format_real_table(path))
    print(f"results: {path}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m e2vlib.experiments.real_study``: score the real-mesh test set (resumable).

    Errors are one line on stderr (exit status 1; 2 for a bad command line), as the
    command line's (:func:`e2vlib.experiments.errors.run`; ``--debug`` shows the traceback).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    from e2vlib.experiments import errors  # the command line's error wrapper

    def build() -> argparse.ArgumentParser:
        parser = build_parser(errors.Parser)
        parser.set_defaults(argv=[a for a in argv if a != "--debug"])
        return parser

    return errors.run(build, argv)


if __name__ == "__main__":
    raise SystemExit(main())
