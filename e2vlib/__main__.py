"""Command line: ``python -m e2vlib {make-data,train,evaluate,reconstruct,figures} ...``.

Each subcommand is a thin wrapper over a library function; ``--help`` on any of them
lists its options.
"""

from __future__ import annotations

import argparse
import sys

DATA_PRESETS = {
    # data_small/: 13 categories x 64 objects = 832 samples, 128 px renders, 64 px frames
    "small": {"per_category": 64, "resolution": 128, "frame_size": 64, "seed": 0},
    # the paper's input size: 512 px renders max-pooled to 256 px frames
    "paper": {"per_category": 3057, "resolution": 512, "frame_size": 256, "seed": 0},
}


def _make_data(args: argparse.Namespace) -> int:
    from e2vlib.data import BuildConfig, build_dataset, parse_shard
    from e2vlib.paper import CATEGORIES

    settings = dict(DATA_PRESETS[args.preset]) if args.preset else {}
    for key in ("per_category", "resolution", "frame_size", "seed"):
        value = getattr(args, key)
        if value is not None:
            settings[key] = value
    settings.setdefault("per_category", 32)
    categories = tuple(args.categories.split(",")) if args.categories else CATEGORIES
    unknown = sorted(set(categories) - set(CATEGORIES))
    if unknown:
        raise SystemExit(f"unknown categories {unknown}; choose from {', '.join(CATEGORIES)}")
    config = BuildConfig(categories=categories, oversample=args.oversample,
                         raw_events_per_category=args.raw_events_per_category, **settings)
    manifest = build_dataset(args.out, config, workers=args.workers,
                             shard=parse_shard(args.shard))
    print(f"manifest: {manifest}")
    return 0


def _train(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    from e2vlib.data import E2VDataset
    from e2vlib.model import build_e2v, load_checkpoint
    from e2vlib.train import fit, init_distributed_from_env

    init_distributed_from_env()
    train_set, val_set = E2VDataset(args.data, "train"), E2VDataset(args.data, "val")
    config_path = Path(args.data) / "config.json"
    metadata = {"data_config": json.loads(config_path.read_text())} if config_path.exists() \
        else {}
    if args.resume:
        model = load_checkpoint(Path(args.out) / "last.pt").train()
    else:
        model = build_e2v(args.preset, seed=args.seed, input_shape=train_set.input_shape)
    overrides = {k: v for k, v in (("lr", args.lr), ("batch_size", args.batch_size))
                 if v is not None}
    history = fit(model, train_set, val_set, args.out, recipe=args.recipe, epochs=args.epochs,
                  device=args.device, seed=args.seed, resume=args.resume, metadata=metadata,
                  **overrides)
    if history:
        best = max(history, key=lambda h: h["val_iou"])
        print(f"best validation IoU@0.3 {best['val_iou']:.3f} at epoch {best['epoch']}; "
              f"checkpoints in {args.out}")
    return 0


def _evaluate(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    from e2vlib.data import E2VDataset
    from e2vlib.files import atomic_path
    from e2vlib.model import load_checkpoint
    from e2vlib.train import evaluate, format_table

    model = load_checkpoint(args.checkpoint)
    data = E2VDataset(args.data, args.split)
    try:
        train = E2VDataset(args.data, "train")
    except ValueError:
        train = None
    result = evaluate(model, data, train_data=train, device=args.device,
                      fscore_points=args.fscore_points)
    print(format_table(result))
    if args.json:
        path = Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {path}")
    return 0


def _reconstruct(args: argparse.Namespace) -> int:
    from pathlib import Path

    import numpy as np
    import torch

    from e2vlib.data import BuildConfig, events_to_model_input, mesh_to_sample
    from e2vlib.files import atomic_path
    from e2vlib.io import load_events
    from e2vlib.model import model_from_checkpoint, read_checkpoint
    from e2vlib.shapes import load_mesh
    from e2vlib.train import predict

    checkpoint = read_checkpoint(args.checkpoint)
    model = model_from_checkpoint(checkpoint, source=f"checkpoint {args.checkpoint}")
    n_frames, frame_size, _ = model.input_shape
    outputs = {}
    # The frames are made exactly as for the data the model was trained on.
    stored = dict(checkpoint.get("data_config") or
                  checkpoint.get("metadata", {}).get("data_config") or {})
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
        frames = events_to_model_input(events, sensor_size, frame_size, n_frames=config.n_frames,
                                       dt_us=config.dt_us, windows=config.windows)
    if frames.shape[0] != n_frames:
        raise SystemExit(f"the model expects {n_frames} frames, the input gives "
                         f"{frames.shape[0]}")
    probabilities = predict(model, torch.from_numpy(frames)[None], args.device)[0].numpy()
    outputs["probabilities"] = probabilities.astype(np.float32)
    outputs["frames"] = frames
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, **outputs)
    print(f"wrote {out}: occupied voxels at 0.3: {int((probabilities >= 0.3).sum())}")
    if "voxels" in outputs:
        from e2vlib.metrics import iou

        print(f"IoU@0.3 against the mesh's own voxels: {iou(probabilities, outputs['voxels']):.3f}")
    if args.png:
        import matplotlib

        matplotlib.use("Agg")
        from e2vlib.viz import plot_reconstruction

        fig = plot_reconstruction(probabilities, outputs.get("voxels"), threshold=0.3)
        fig.savefig(args.png, dpi=120, bbox_inches="tight")
        print(f"wrote {args.png}")
    return 0


def _figures(args: argparse.Namespace) -> int:
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    from e2vlib.viz import render_readme_figures

    checkpoint = args.checkpoint or str(Path(args.data) / "checkpoints" / "tiny.pt")
    try:
        paths = render_readme_figures(args.out, args.data, checkpoint,
                                      categories=tuple(args.categories.split(",")))
    except (FileNotFoundError, ValueError) as err:
        raise SystemExit(f"figures: {err}") from err
    for path in paths.values():
        print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m e2vlib",
        description="E2V: 3D voxel reconstruction from a monocular event camera (lessons' CLI).",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("make-data", help="build a dataset: shapes -> orbit video -> events "
                       "-> frames, plus voxel labels")
    p.add_argument("--out", required=True, help="dataset folder (created; resumable)")
    p.add_argument("--preset", choices=sorted(DATA_PRESETS),
                   help="defaults: 'small' rebuilds data_small/, 'paper' the paper's sizes")
    p.add_argument("--per-category", type=int, help="objects per category (default 32)")
    p.add_argument("--categories", help="comma-separated subset of the 13 categories")
    p.add_argument("--resolution", type=int, help="render/simulation size in px (128)")
    p.add_argument("--frame-size", type=int, help="stored frame size in px (64)")
    p.add_argument("--oversample", type=int,
                   help="video frames rendered per 240 fps frame (default: enough for "
                   "<= 1 px motion per frame)")
    p.add_argument("--raw-events-per-category", type=int, default=1,
                   help="samples per category whose raw events are kept (default 1)")
    p.add_argument("--seed", type=int, help="dataset seed (default 0)")
    p.add_argument("--workers", type=int, default=1, help="parallel processes (default 1)")
    p.add_argument("--shard", default="0/1", help="build only shard i of n, e.g. 2/8")
    p.set_defaults(func=_make_data)

    p = sub.add_parser("train", help="train E2V on a dataset (writes best.pt, last.pt, "
                       "history.json); run under torchrun for several processes/GPUs")
    p.add_argument("--data", required=True, help="dataset folder (e2vlib or SynthEVox3D)")
    p.add_argument("--preset", default="tiny", help="model preset: tiny, tiny2d, paper")
    p.add_argument("--out", required=True, help="output folder for checkpoints")
    p.add_argument("--recipe", default="tiny", help="training recipe: tiny or paper")
    p.add_argument("--epochs", type=int, help="override the recipe's epochs")
    p.add_argument("--lr", type=float, help="override the recipe's learning rate")
    p.add_argument("--batch-size", type=int, help="override the recipe's batch size")
    p.add_argument("--resume", action="store_true", help="continue from OUT/last.pt")
    p.add_argument("--device", default="auto", help="auto (default), cpu, cuda, cuda:1 ...")
    p.add_argument("--seed", type=int, default=0, help="seed for weights and shuffling")
    p.set_defaults(func=_train)

    p = sub.add_parser("evaluate", help="IoU and F-score per category, as in the paper's "
                       "Tables I and II, with mean-shape baselines")
    p.add_argument("--checkpoint", required=True, help="a checkpoint written by train")
    p.add_argument("--data", required=True, help="dataset folder")
    p.add_argument("--split", default="test", choices=("train", "val", "test"))
    p.add_argument("--json", help="write the results as JSON here")
    p.add_argument("--device", default="auto")
    p.add_argument("--fscore-points", type=int, default=8192,
                   help="surface points per grid for the F-score (default 8192)")
    p.set_defaults(func=_evaluate)

    p = sub.add_parser("reconstruct", help="reconstruct one object from a mesh (through the "
                       "dataset pipeline) or from an event file")
    p.add_argument("--checkpoint", required=True)
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--mesh", help="OBJ/PLY/STL/OFF/GLB file: rendered, simulated, framed")
    source.add_argument("--events", help="event file (.npz, .txt, .h5, .aedat4)")
    p.add_argument("--out", required=True, help="output .npz (probabilities, frames, voxels)")
    p.add_argument("--png", help="also save a picture of the reconstruction here")
    p.add_argument("--device", default="auto")
    p.add_argument("--seed", type=int, default=0, help="simulator seed (mesh input)")
    p.set_defaults(func=_reconstruct)
    p = sub.add_parser("figures", help="render the README's pictures (events in space-time, "
                       "event frames, ground truth beside reconstruction)")
    p.add_argument("--out", default="docs/figures", help="output folder (docs/figures)")
    p.add_argument("--data", default="data_small", help="dataset with raw events (data_small)")
    p.add_argument("--checkpoint", help="trained model (default DATA/checkpoints/tiny.pt)")
    p.add_argument("--categories", default="airplane,car,chair,lamp,table",
                   help="columns of the reconstruction picture (comma-separated)")
    p.set_defaults(func=_figures)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
