"""Command line: ``python -m e2vlib {make-data,train,evaluate,reconstruct} ...``.

Each subcommand is a thin wrapper over a library function; ``--help`` on any of them
lists its options.
"""

from __future__ import annotations

import argparse
import sys

DATA_PRESETS = {
    # data_small/: 13 categories x 32 objects, 128 px renders, 64 px frames
    "small": {"per_category": 32, "resolution": 128, "frame_size": 64, "seed": 0},
    # the paper's input size: 512 px renders max-pooled to 256 px frames
    "paper": {"per_category": 3057, "resolution": 512, "frame_size": 256, "seed": 0},
}


def _make_data(args: argparse.Namespace) -> int:
    from e2vlib.data import BuildConfig, build_dataset, parse_shard
    from e2vlib.shapes import CATEGORIES

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
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
