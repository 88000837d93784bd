"""Command line: ``python -m e2vlib {make-data,merge-data,train,evaluate,reconstruct,...} ...``.

Each subcommand is a thin wrapper over a library function; ``--help`` on any of them
lists its options. Arguments are checked before any work starts and before anything is
written (output folders and files included). Every error is one line on stderr,
``error: <what is wrong and the fix>``, with exit status 2 for a bad argument and 1 for a
failure; ``--debug`` (anywhere on the command line) shows the traceback instead.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

DATA_PRESETS = {
    # data_small/: 13 categories x 64 objects = 832 samples, 128 px renders, 64 px frames
    "small": {"per_category": 64, "resolution": 128, "frame_size": 64, "seed": 0},
    # the paper's input size: 512 px renders max-pooled to 256 px frames
    "paper": {"per_category": 3057, "resolution": 512, "frame_size": 256, "seed": 0},
}

EXIT_FAILURE = 1
"""Exit status of a command that failed (bad data, unreadable file, ...)."""

EXIT_USAGE = 2
"""Exit status of a bad command line (unknown option, bad value), as argparse uses."""

DEVICES = "auto, cpu, cuda, cuda:N (the N-th GPU), mps"
"""What ``--device`` accepts, for messages."""

PICTURE_TYPES = (".png", ".jpg", ".jpeg", ".pdf", ".svg")
"""Endings ``reconstruct --png`` can write."""


class UsageError(Exception):
    """A bad command-line value; printed as one line, exit status :data:`EXIT_USAGE`."""


class CommandError(Exception):
    """A command that cannot go on; printed as one line, exit status :data:`EXIT_FAILURE`."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (raised as :class:`UsageError`)."""

    def error(self, message: str):  # argparse's hook for every parsing error
        raise UsageError(f"{message} (see {self.prog} --help)")


# --------------------------------------------------------------------------- argument types


def _whole_number(minimum: int):
    """An argparse type: a whole number >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected a whole number >= {minimum}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(
                f"must be a whole number >= {minimum}, got {value}")
        return value

    parse.__name__ = f"whole number >= {minimum}"
    return parse


def _bounded(minimum: int, maximum: int):
    """An argparse type: a whole number from ``minimum`` to ``maximum``."""
    parse_low = _whole_number(minimum)

    def parse(text: str) -> int:
        value = parse_low(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(
                f"must be a whole number from {minimum} to {maximum}, got {value}")
        return value

    parse.__name__ = f"whole number {minimum}..{maximum}"
    return parse


def _positive_number(text: str) -> float:
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


# --------------------------------------------------------------------------- checks


def _check_device(text: str) -> None:
    """Refuse a ``--device`` torch cannot use here, listing the valid ones."""
    import torch

    from e2vlib.train import resolve_device

    if text != "auto":
        try:
            device = torch.device(text)
        except (RuntimeError, ValueError, TypeError):
            raise UsageError(f"--device {text!r} is not a device; use one of {DEVICES}") from None
        if device.type not in ("cpu", "cuda", "mps"):
            raise UsageError(f"--device {text!r} is not supported; use one of {DEVICES}")
        if device.type == "mps" and not torch.backends.mps.is_available():
            raise UsageError("--device mps: this machine has no Apple GPU (MPS); use --device "
                             "cpu or auto")
        if device.type == "cuda" and device.index is not None and torch.cuda.is_available():
            count = torch.cuda.device_count()
            if device.index >= count:
                raise UsageError(f"--device {text}: this machine has {count} GPU(s), "
                                 f"cuda:0 .. cuda:{count - 1}; pick one of those or auto")
    try:
        resolve_device(text)
    except ValueError as err:
        raise UsageError(f"--device {text}: {err}") from None


def _writable_folder(folder: Path, flag: str, target: Path) -> None:
    """Refuse ``folder`` (where ``target`` goes) if it or its nearest existing parent is
    not a writable folder: fail before the work, not after it."""
    existing = folder.absolute()
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise UsageError(f"{flag} {target}: {existing} is a file, not a folder; choose another "
                         f"{flag}")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(f"{flag} {target}: cannot write into {existing} (permission denied "
                         f"or read-only); choose another {flag} or fix the folder's permissions")


def _output_file(text: str, flag: str, example: str) -> Path:
    """Check an output file path (not a folder, in a writable folder) before the work."""
    path = Path(text)
    if path.is_dir():
        raise UsageError(f"{flag} {path} is a directory; give a file name, e.g. "
                         f"{path / example}")
    if text.endswith(("/", os.sep)):
        raise UsageError(f"{flag} {text!r} ends with a folder separator; give a file name, "
                         f"e.g. {path / example}")
    _writable_folder(path.parent, flag, path)
    return path


def _output_folder(text: str, flag: str) -> Path:
    """Check an output folder path (not a file, writable) before the work."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{flag} {path} is a file; give a folder (it is created if missing)")
    _writable_folder(path, flag, path)
    return path


def _categories(text: str) -> tuple[str, ...]:
    """``--categories`` as a tuple of known names, refusing empty, unknown and repeated ones."""
    from e2vlib.paper import CATEGORIES

    names = [name.strip() for name in text.split(",") if name.strip()]
    if not names:
        raise UsageError(f"--categories {text!r} names no category; give a comma-separated "
                         f"subset of {','.join(CATEGORIES)} (or leave the option out for all "
                         f"{len(CATEGORIES)})")
    unknown = [name for name in names if name not in CATEGORIES]
    if unknown:
        raise UsageError(f"--categories: unknown {unknown}; choose from {','.join(CATEGORIES)}")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise UsageError(f"--categories names {repeated} more than once; list each once")
    return tuple(names)


def _model_frames_check(model, ckpt: dict, checkpoint: str, data_config: dict | None,
                        input_shape, source: str) -> None:
    """Refuse data whose frames differ from those the checkpoint's model was trained on."""
    from e2vlib.model import check_frames_match, checkpoint_data_config

    check_frames_match(checkpoint_data_config(ckpt), data_config, f"checkpoint {checkpoint}",
                       source)
    if input_shape is not None and tuple(input_shape) != tuple(model.input_shape):
        raise CommandError(
            f"checkpoint {checkpoint} takes frames of shape {tuple(model.input_shape)} "
            f"(n_frames, H, W) but {source} has {tuple(input_shape)}; use data built with "
            "the checkpoint's settings (make-data --frame-size), or a model trained on it")


# --------------------------------------------------------------------------- commands


def _build_config(args: argparse.Namespace):
    """The BuildConfig a ``make-data`` command line asks for (UsageError if invalid)."""
    from e2vlib.data import BuildConfig
    from e2vlib.paper import CATEGORIES

    settings = dict(DATA_PRESETS[args.preset]) if args.preset else {}
    for key in ("per_category", "resolution", "frame_size", "seed", "n_frames", "dt_us",
                "windows", "contrast"):
        value = getattr(args, key)
        if value is not None:
            settings[key] = value
    settings.setdefault("per_category", 32)
    categories = _categories(args.categories) if args.categories is not None else CATEGORIES
    try:  # validates every setting; nothing is written before this
        return BuildConfig(categories=categories, oversample=args.oversample,
                           raw_events_per_category=args.raw_events_per_category,
                           grey_video=args.grey_video, noise=args.noise,
                           splits=tuple(args.splits), anti_aliasing=args.anti_aliasing,
                           **settings)
    except ValueError as err:
        raise UsageError(f"invalid dataset settings: {err}") from None


def _make_data(args: argparse.Namespace) -> int:
    from e2vlib.data import build_dataset, check_build_folder, describe_build, parse_shard

    try:
        shard = parse_shard(args.shard)
    except ValueError as err:
        raise UsageError(f"--shard: {err}") from None
    config = _build_config(args)
    _output_folder(args.out, "--out")
    if args.real_meshes is not None:  # the real-mesh test set (e2vlib.real_meshes)
        from e2vlib.real_meshes import build_real_dataset

        manifest = build_real_dataset(args.out, config, args.real_meshes, workers=args.workers)
        print(f"manifest: {manifest}")
        return 0
    check_build_folder(args.out, config)
    print(describe_build(args.out, config, shard), flush=True)
    manifest = build_dataset(args.out, config, workers=args.workers, shard=shard)
    print(f"manifest: {manifest}")
    return 0


def _merge_data(args: argparse.Namespace) -> int:
    from e2vlib.shards import merge_datasets

    out = _output_folder(args.out, "--out")
    for folder in args.shards:
        path = Path(folder)
        if not path.is_dir():
            raise UsageError(f"shard folder {path}: no such folder; give the --out folders "
                             "of the make-data --shard runs")
    if not args.shards and not (out / "config.json").is_file():
        raise UsageError(f"--out {out} holds no dataset to verify; list the shard folders to "
                         "merge after --out, or point --out at a shared shard folder")
    report = merge_datasets(out, args.shards, link=not args.copy)
    if report.sources:
        print(f"merged {report.n_samples} samples from {len(report.sources)} folder(s) into "
              f"{out}: {report.linked} files hard-linked, {report.copied} copied, "
              f"{report.kept} already there")
    else:
        print(f"verified {out}: all {report.n_samples} planned samples present and readable")
    print(f"manifest: {report.manifest}")
    return 0


def _verify_data(args: argparse.Namespace) -> int:
    from e2vlib.data import build_command, verify_dataset

    checked, problems, unhashed = verify_dataset(args.data)
    for problem in problems:
        print(f"bad: {problem}")
    if problems:
        raise CommandError(f"{len(problems)} of {checked} samples of {args.data} are bad (listed "
                           "above); delete those files and rebuild them with "
                           f"{build_command(args.data)} (resumable), then rerun verify-data")
    if unhashed:
        print(f"checked {args.data}: all {checked} samples load as config.json says; the "
              f"manifest records no sha256 for {unhashed} of them (an older build), so their "
              f"contents could not be checked: record them with {build_command(args.data)}")
    else:
        print(f"verified {args.data}: all {checked} samples load as config.json says and "
              "match the manifest's sha256")
    return 0


def _resume_checks(last: Path, ckpt: dict, preset: str | None) -> None:
    """Refuse to resume from a weights-only checkpoint or with another ``--preset``."""
    from dataclasses import fields, replace

    from e2vlib.model import PRESETS, E2VConfig
    from e2vlib.train import RESUME_KEYS

    missing = [key for key in RESUME_KEYS if key not in ckpt]
    if missing:
        raise CommandError(
            f"cannot resume from {last}: it holds the weights only (no {', '.join(missing)}; "
            "a slimmed checkpoint such as data_small/checkpoints/tiny.pt). Start a new run "
            f"from its weights with --init {last} and another --out, or train from scratch "
            "without --resume")
    if preset is None:
        return
    stored = E2VConfig.from_dict(dict(ckpt["config"]))
    wanted = replace(PRESETS[preset], input_shape=stored.input_shape)
    if wanted != stored:
        names = [name for name, config in PRESETS.items()
                 if replace(config, input_shape=stored.input_shape) == stored]
        held = f"preset {names[0]}" if names else "a model of no preset"
        differ = [f.name for f in fields(stored)
                  if getattr(stored, f.name) != getattr(wanted, f.name)]
        raise CommandError(
            f"--preset {preset} differs from the model in {last}, which holds {held} "
            f"(different {', '.join(differ)}); resume without --preset (the model comes "
            f"from last.pt), or train --preset {preset} into another --out folder")


def _train(args: argparse.Namespace) -> int:
    from e2vlib.data import E2VDataset
    from e2vlib.dataset_checks import read_config
    from e2vlib.model import PRESETS, build_e2v, model_from_checkpoint, read_checkpoint
    from e2vlib.paper import IOU_THRESHOLD
    from e2vlib.train import RECIPES, fit, get_recipe, init_distributed_from_env

    if args.recipe not in RECIPES:
        raise UsageError(f"--recipe {args.recipe!r} is not a training recipe; choose one of "
                         f"{', '.join(sorted(RECIPES))}")
    if args.preset is not None and args.preset not in PRESETS:
        raise UsageError(f"--preset {args.preset!r} is not a model preset; choose one of "
                         f"{', '.join(sorted(PRESETS))}")
    if args.init and (args.resume or args.preset):
        raise UsageError("--init starts a new run from a checkpoint's model and weights; "
                         "leave out --resume and --preset with it")
    overrides = {k: v for k, v in (("lr", args.lr), ("batch_size", args.batch_size),
                                   ("epochs", args.epochs)) if v is not None}
    try:
        recipe = get_recipe(args.recipe, **overrides)
    except ValueError as err:
        raise UsageError(str(err)) from None
    _check_device(args.device)
    out = _output_folder(args.out, "--out")
    data_root = Path(args.data).resolve()
    if out.resolve().is_relative_to(data_root):
        raise UsageError(f"--out {out} is inside the dataset folder {args.data}; checkpoints "
                         "there would mix with the data (and be read as part of it): choose "
                         "an --out outside it")
    init = None
    if args.init:
        init = Path(args.init)
        if not init.is_file():
            raise UsageError(f"--init {init}: no such checkpoint file")
    last = out / "last.pt"
    if args.resume and not last.is_file():
        raise UsageError(f"--resume: {last} does not exist, so there is nothing to resume; "
                         "leave out --resume to start a new run")

    init_distributed_from_env()
    train_set, val_set = E2VDataset(args.data, "train"), E2VDataset(args.data, "val")
    config_path = Path(args.data) / "config.json"
    metadata = {"data_config": read_config(args.data)} if config_path.exists() else {}
    if args.resume:
        ckpt = read_checkpoint(last)
        _resume_checks(last, ckpt, args.preset)
        done = int(ckpt["epoch"]) + 1
        if done >= recipe.epochs:
            print(f"nothing to do: {last} already holds {done} epochs of the {recipe.epochs} "
                  "asked for; pass a larger --epochs to train further")
            return 0
        model = model_from_checkpoint(ckpt, source=f"checkpoint {last}").train()
        del ckpt
    elif init is not None:
        ckpt = read_checkpoint(init)
        model = model_from_checkpoint(ckpt, source=f"checkpoint {init}").train()
        _model_frames_check(model, ckpt, str(init), train_set.config, train_set.input_shape,
                            f"dataset {args.data}")
        del ckpt
    else:
        model = build_e2v(args.preset or "tiny", seed=args.seed,
                          input_shape=train_set.input_shape)
    history = fit(model, train_set, val_set, out, recipe=recipe, device=args.device,
                  seed=args.seed, resume=args.resume, metadata=metadata, loss=args.loss,
                  precision=args.precision, channels_last=args.channels_last)
    if history:
        best = max(history, key=lambda h: h["val_iou"])
        print(f"best validation IoU@{IOU_THRESHOLD} {best['val_iou']:.3f} at epoch "
              f"{best['epoch']}; "
              f"checkpoints in {out}")
    return 0


def _evaluate(args: argparse.Namespace) -> int:
    import json

    from e2vlib.data import E2VDataset
    from e2vlib.files import atomic_path
    from e2vlib.model import model_from_checkpoint, read_checkpoint
    from e2vlib.train import evaluate, format_table

    json_path = _output_file(args.json, "--json", "results.json") if args.json else None
    _check_device(args.device)
    ckpt = read_checkpoint(args.checkpoint)
    model = model_from_checkpoint(ckpt, source=f"checkpoint {args.checkpoint}")
    data = E2VDataset(args.data, args.split)
    _model_frames_check(model, ckpt, args.checkpoint, data.config, data.input_shape,
                        f"dataset {args.data}")
    del ckpt
    try:
        train = E2VDataset(args.data, "train")
    except ValueError:
        train = None
    result = evaluate(model, data, train_data=train, device=args.device,
                      fscore_points=args.fscore_points)
    print(format_table(result))
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(json_path) as tmp:
            tmp.write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {json_path}")
    return 0


def _reconstruct(args: argparse.Namespace) -> int:
    import numpy as np
    import torch

    from e2vlib.data import BuildConfig, events_to_model_input, mesh_to_sample
    from e2vlib.files import atomic_path
    from e2vlib.io import load_events
    from e2vlib.model import checkpoint_data_config, model_from_checkpoint, read_checkpoint
    from e2vlib.paper import IOU_THRESHOLD
    from e2vlib.shapes import load_mesh
    from e2vlib.train import predict

    out = _output_file(args.out, "--out", "reconstruction.npz")
    png = _output_file(args.png, "--png", "reconstruction.png") if args.png else None
    for flag, path in (("--out", out), ("--png", png)):
        if path is not None and path.exists() and not args.overwrite:
            raise UsageError(f"{flag} {path} exists; pass --overwrite to replace it, or "
                             f"choose another {flag}")
    if png is not None and png.suffix.lower() not in PICTURE_TYPES:
        raise UsageError(f"--png {png}: unknown picture type {png.suffix!r}; end the name "
                         f"with one of {', '.join(PICTURE_TYPES)}")
    _check_device(args.device)
    source = Path(args.mesh or args.events)
    if not source.is_file():
        flag = "--mesh" if args.mesh else "--events"
        raise UsageError(f"{flag} {source}: no such file")
    checkpoint = read_checkpoint(args.checkpoint)
    model = model_from_checkpoint(checkpoint, source=f"checkpoint {args.checkpoint}")
    n_frames, frame_size, _ = model.input_shape
    outputs = {}
    # The frames are made exactly as for the data the model was trained on.
    stored = dict(checkpoint_data_config(checkpoint) or {})
    made = (stored.get("n_frames") or n_frames, stored.get("frame_size") or frame_size)
    if made != (n_frames, frame_size):
        raise CommandError(
            f"checkpoint {args.checkpoint} is inconsistent: its model takes {n_frames} frames "
            f"of {frame_size} px but the data config stored with it makes {made[0]} frames of "
            f"{made[1]} px; re-create the checkpoint (train, or slim_checkpoint)")
    stored.setdefault("frame_size", frame_size)
    stored.setdefault("resolution", 2 * frame_size)
    stored.setdefault("n_frames", n_frames)
    stored["categories"] = list(stored.get("categories") or [])  # not used for one mesh
    known = {k: v for k, v in stored.items() if k in BuildConfig.__dataclass_fields__}
    known["categories"] = known["categories"] or ["chair"]
    known["per_category"] = 1
    config = BuildConfig.from_dict(known)
    if args.mesh:
        sample = mesh_to_sample(load_mesh(args.mesh), config, seed=args.seed)
        frames, outputs["voxels"] = sample.frames, sample.voxels
    else:
        events, sensor_size = load_events(args.events)
        try:
            frames = events_to_model_input(events, sensor_size, frame_size,
                                           n_frames=config.n_frames, dt_us=config.dt_us,
                                           windows=config.windows)
        except ValueError as err:
            raise CommandError(f"--events {source}: {err}; nothing was written") from None
    if tuple(frames.shape) != tuple(model.input_shape):
        raise CommandError(f"the model expects frames of shape {tuple(model.input_shape)}, "
                           f"the input gives {tuple(frames.shape)}")
    probabilities = predict(model, torch.from_numpy(frames)[None], args.device)[0].numpy()
    if not np.all(np.isfinite(probabilities)):
        raise CommandError(f"the model's output holds NaN/inf for this input; nothing was "
                           f"written. Check checkpoint {args.checkpoint} (retrain, or use "
                           "best.pt)")
    outputs["probabilities"] = probabilities.astype(np.float32)
    outputs["frames"] = frames
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, **outputs)
    occupied = int((probabilities >= IOU_THRESHOLD).sum())
    print(f"wrote {out}: occupied voxels at {IOU_THRESHOLD}: {occupied}")
    if "voxels" in outputs:
        from e2vlib.metrics import iou

        print(f"IoU@{IOU_THRESHOLD} against the mesh's own voxels: "
              f"{iou(probabilities, outputs['voxels']):.3f}")
    if png is not None:
        import matplotlib

        matplotlib.use("Agg")
        from e2vlib.viz import plot_reconstruction

        fig = plot_reconstruction(probabilities, outputs.get("voxels"), threshold=IOU_THRESHOLD)
        png.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(png) as tmp:
            fig.savefig(tmp, dpi=120, bbox_inches="tight", format=png.suffix.lower()[1:])
        print(f"wrote {png}")
    return 0


def _figures(args: argparse.Namespace) -> int:
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    from e2vlib.figures import render_readme_figures

    checkpoint = args.checkpoint or str(Path(args.data) / "checkpoints" / "tiny.pt")
    try:
        paths = render_readme_figures(args.out, args.data, checkpoint,
                                      categories=tuple(args.categories.split(",")))
    except (FileNotFoundError, ValueError) as err:
        raise SystemExit(f"figures: {err}") from err
    for path in paths.values():
        print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")
    return 0


def _experiment(args: argparse.Namespace) -> int:
    from e2vlib.experiments import DEFAULT_OUT, STUDIES, format_summary, run_study, summarize

    if args.study == "geometry":
        return _geometry_study(args)
    if args.study not in STUDIES:
        raise UsageError(f"unknown study {args.study!r}; choose one of {', '.join(STUDIES)}")
    unknown = [c for c in args.configs or () if c not in STUDIES[args.study].configs]
    if unknown:
        raise UsageError(f"study {args.study!r} has no configs {unknown}; it has "
                         f"{', '.join(STUDIES[args.study].configs)}")
    _check_device(args.device)
    out = args.out or (DEFAULT_OUT.parent / "results-quick" if args.quick else DEFAULT_OUT)
    _output_folder(str(out), "--out")
    path = run_study(args.study, args.configs, args.seeds, out, device=args.device,
                     quick=args.quick, reuse=not args.no_reuse)
    print(f"{path}:")
    print(format_summary(summarize(path)))
    return 0


def _geometry_study(args: argparse.Namespace) -> int:
    from e2vlib.experiments import DEFAULT_OUT
    from e2vlib.geometry_study import run_geometry_study, summarize_geometry

    if args.configs or args.quick:
        raise UsageError("the geometry study has no configs and no quick mode (no training); "
                         "run `python -m e2vlib experiment geometry`")
    out = args.out or DEFAULT_OUT
    _output_folder(str(out), "--out")
    path = run_geometry_study(out)
    print(f"{path}:")
    for row in summarize_geometry(path):
        low, high = row["ci95"]
        print(f"  {row['method']:15s} IoU@0.3 {row['mean']:.3f} ({low:.3f}-{high:.3f}, "
              f"{row['n']} objects)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from e2vlib.metrics import MAX_SURFACE_POINTS
    from e2vlib.render import ANTI_ALIASING  # numpy only; pyvista loads when rendering

    parser = _Parser(
        prog="python -m e2vlib",
        description="E2V: 3D voxel reconstruction from a monocular event camera (lessons' CLI). "
                    "Errors are one line on stderr (exit 2: bad arguments, 1: failures).",
    )
    parser.add_argument("--debug", action="store_true",
                        help="show the full traceback of an error (may also follow the "
                        "subcommand)")
    sub = parser.add_subparsers(dest="command", required=True)
    count, positive = _whole_number(0), _whole_number(1)

    p = sub.add_parser("make-data", help="build a dataset: shapes -> orbit video -> events "
                       "-> frames, plus voxel labels")
    p.add_argument("--out", required=True, help="dataset folder (created; resumable)")
    p.add_argument("--preset", choices=sorted(DATA_PRESETS),
                   help="defaults: 'small' rebuilds data_small/, 'paper' the paper's sizes")
    p.add_argument("--per-category", type=positive, help="objects per category (default 32)")
    p.add_argument("--categories", help="comma-separated subset of the 13 categories")
    p.add_argument("--resolution", type=positive, help="render/simulation size in px (128)")
    p.add_argument("--frame-size", type=positive, help="stored frame size in px (64)")
    p.add_argument("--oversample", type=positive,
                   help="video frames rendered per 240 fps frame (default: enough for "
                   "<= 1 px motion per frame)")
    p.add_argument("--raw-events-per-category", type=count, default=1,
                   help="samples per category whose raw events are kept (default 1)")
    p.add_argument("--seed", type=count, help="dataset seed (default 0)")
    p.add_argument("--n-frames", type=positive, help="event frames per sample (default 100)")
    p.add_argument("--dt-us", type=positive, help="frame length in microseconds (5000)")
    p.add_argument("--windows", choices=("fixed", "paper"),
                   help="frame grouping: fixed clock windows (default) or the paper's Eq. 5")
    p.add_argument("--contrast", type=_positive_number,
                   help="the simulator's contrast threshold C (default 0.2)")
    p.add_argument("--grey-video", action="store_true",
                   help="also store each sample's grey video at the event frames' times "
                   "(OUT/grey/<id>.npz, uint8 frames of --frame-size px)")
    p.add_argument("--noise", choices=("clean", "low", "medium", "high"), default="clean",
                   help="sensor noise of the simulated events (e2vlib.simulate.NOISE_LEVELS; "
                   "default clean, as data_small)")
    p.add_argument("--splits", nargs="+", choices=("train", "val", "test"),
                   default=["train", "val", "test"],
                   help="build only these splits (same objects and splits as the full build)")
    p.add_argument("--anti-aliasing", choices=ANTI_ALIASING, default="ssaa",
                   help="the renderer's edge smoothing (default ssaa, as data_small; 'none' "
                   "renders 4-7x faster and changes the events at moving edges)")
    p.add_argument("--workers", type=positive, default=1, help="parallel processes (default 1)")
    p.add_argument("--shard", default="0/1", help="build only shard i of n, e.g. 2/8 "
                   "(join shard folders with merge-data)")
    p.add_argument("--real-meshes", metavar="CATALOGUE",
                   help="build the real-mesh test set of this reviewed catalogue (e.g. "
                   "data_small/real/catalogue.csv; needs apt-get install "
                   "sweethome3d-furniture) instead of procedural shapes")
    p.set_defaults(func=_make_data)

    p = sub.add_parser("merge-data", help="merge the folders of make-data --shard runs into "
                       "one dataset and check it is complete (with no SHARD_DIR: verify --out "
                       "in place)")
    p.add_argument("shards", nargs="*", metavar="SHARD_DIR",
                   help="folders built by make-data --shard i/n (same settings)")
    p.add_argument("--out", required=True, help="merged dataset folder (created); alone, the "
                   "shared folder all shards were built into, verified in place")
    p.add_argument("--copy", action="store_true", help="copy files (default: hard-link them "
                   "when on the same filesystem, else copy)")
    p.set_defaults(func=_merge_data)

    p = sub.add_parser("verify-data", help="check every sample of a dataset: it loads as "
                       "config.json says and matches the manifest's sha256; lists each bad one")
    p.add_argument("--data", required=True, help="dataset folder")
    p.set_defaults(func=_verify_data)

    p = sub.add_parser("train", help="train E2V on a dataset (writes best.pt, last.pt, "
                       "history.json); run under torchrun for several processes/GPUs")
    p.add_argument("--data", required=True, help="dataset folder (e2vlib or SynthEVox3D)")
    p.add_argument("--preset", help="model preset: tiny (default), tiny2d, tiny_gru, paper")
    p.add_argument("--out", required=True, help="output folder for checkpoints")
    p.add_argument("--recipe", default="tiny", help="training recipe: tiny or paper")
    p.add_argument("--epochs", type=positive, help="override the recipe's epochs")
    p.add_argument("--lr", type=_positive_number, help="override the recipe's learning rate")
    p.add_argument("--batch-size", type=positive, help="override the recipe's batch size")
    p.add_argument("--resume", action="store_true", help="continue from OUT/last.pt")
    p.add_argument("--init", metavar="CHECKPOINT",
                   help="start a new run from this checkpoint's model and weights (e.g. the "
                   "slim data_small/checkpoints/tiny.pt), with a fresh optimizer")
    p.add_argument("--device", default="auto", help=f"one of {DEVICES} (default auto)")
    p.add_argument("--seed", type=count, default=0, help="seed for weights and shuffling")
    p.add_argument("--loss", default="bce", choices=("bce", "focal", "bce_dice"),
                   help="training loss (default bce, the paper's; see lesson 10)")
    p.add_argument("--precision", default="fp32", choices=("fp32", "bf16"),
                   help="bf16: the forward pass in bfloat16 autocast, on CPUs with AVX-512 "
                   "BF16/AMX and recent GPUs (faster; bench/RESULTS.md)")
    p.add_argument("--channels-last", action="store_true",
                   help="channels-last convolution weights (faster on CPU through oneDNN)")
    p.set_defaults(func=_train)

    p = sub.add_parser("evaluate", help="IoU and F-score per category, as in the paper's "
                       "Tables I and II, with mean-shape baselines")
    p.add_argument("--checkpoint", required=True, help="a checkpoint written by train")
    p.add_argument("--data", required=True, help="dataset folder")
    p.add_argument("--split", default="test", choices=("train", "val", "test"))
    p.add_argument("--json", help="write the results as JSON here")
    p.add_argument("--device", default="auto", help=f"one of {DEVICES} (default auto)")
    p.add_argument("--fscore-points", type=_bounded(1, MAX_SURFACE_POINTS), default=8192,
                   help="surface points per grid for the F-score (default 8192, at most "
                   f"{MAX_SURFACE_POINTS})")
    p.set_defaults(func=_evaluate)

    p = sub.add_parser("reconstruct", help="reconstruct one object from a mesh (through the "
                       "dataset pipeline) or from an event file")
    p.add_argument("--checkpoint", required=True)
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--mesh", help="OBJ/PLY/STL/OFF/GLB file: rendered, simulated, framed")
    source.add_argument("--events", help="event file (.npz, .txt, .h5, .aedat4)")
    p.add_argument("--out", required=True, help="output .npz (probabilities, frames, voxels)")
    p.add_argument("--png", help="also save a picture of the reconstruction here")
    p.add_argument("--device", default="auto", help=f"one of {DEVICES} (default auto)")
    p.add_argument("--seed", type=count, default=0, help="simulator seed (mesh input)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace --out (and --png) if they exist (default: refuse)")
    p.set_defaults(func=_reconstruct)
    p = sub.add_parser("figures", help="render the README's pictures (events in space-time, "
                       "event frames, ground truth beside reconstruction)")
    p.add_argument("--out", default="docs/figures", help="output folder (docs/figures)")
    p.add_argument("--data", default="data_small", help="dataset with raw events (data_small)")
    p.add_argument("--checkpoint", help="trained model (default DATA/checkpoints/tiny.pt)")
    p.add_argument("--categories", default="airplane,car,chair,lamp,table",
                   help="columns of the reconstruction picture (comma-separated)")
    p.set_defaults(func=_figures)

    p = sub.add_parser("experiment", help="run a study (representation, time, encoder, loss): "
                       "train and evaluate each config and seed, one record per run")
    p.add_argument("study", help="representation, time, encoder, loss, or geometry (no "
                   "training: visual hull and event carving beside the learned model)")
    p.add_argument("--configs", nargs="+", help="only these configs of the study")
    p.add_argument("--seeds", nargs="+", type=count, default=[0, 1, 2],
                   help="seeds (default 0 1 2)")
    p.add_argument("--out", help="results folder (default experiments/results, or "
                   "experiments/results-quick with --quick)")
    p.add_argument("--device", default="auto", help=f"one of {DEVICES} (default auto)")
    p.add_argument("--quick", action="store_true",
                   help="a tiny protocol for checks: 2 samples per category, 1 epoch, 32 px")
    p.add_argument("--no-reuse", action="store_true",
                   help="train every run, even one whose full protocol and seed another "
                        "study in --out already recorded (default: copy that record)")
    p.set_defaults(func=_experiment)
    return parser


def _one_line(err: BaseException) -> str:
    """An exception as one line: its message, with the type when it is unexpected."""
    message = " ".join(str(err).split())
    if isinstance(err, KeyError) and len(err.args) == 1:
        message = repr(err.args[0])
    if isinstance(err, (UsageError, CommandError, ValueError, OSError)) and message:
        if isinstance(err, PermissionError):
            message += "; choose a location you can write to, or fix its permissions"
        return message
    return (f"{type(err).__name__}: {message or 'no message'} (unexpected; rerun with --debug "
            "for the traceback)")


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit status (0 success, 1 failure, 2 bad usage).

    ``--debug`` anywhere in ``argv`` lets exceptions propagate with their traceback.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    status, message = 0, None
    try:
        args = build_parser().parse_args(argv)
        return int(args.func(args) or 0)
    except SystemExit as exc:  # --help (0), or code that exits with a message
        if exc.code is None or isinstance(exc.code, int):
            return int(exc.code or 0)
        if debug:
            raise
        status, message = EXIT_FAILURE, " ".join(str(exc.code).split())
    except KeyboardInterrupt:
        if debug:
            raise
        status, message = 130, "interrupted"
    except Exception as err:
        if debug:
            raise
        status = EXIT_USAGE if isinstance(err, UsageError) else EXIT_FAILURE
        message = _one_line(err)
    print(f"error: {message}", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
