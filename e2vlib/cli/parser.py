"""The command line's parser: every subcommand, its flags and their help.

The choices come from the library's own tuples (:data:`e2vlib.data.SPLITS`,
:data:`e2vlib.frames.WINDOWS`, :data:`e2vlib.noise.NOISE_LEVELS`,
:data:`e2vlib.render.ANTI_ALIASING`, :data:`e2vlib.losses.LOSSES`,
:data:`e2vlib.scale.options.PRECISIONS`; the model presets and training recipes named in the help
from :data:`e2vlib.model.PRESETS` and :data:`e2vlib.train.RECIPES`), so a new choice in the
library is one on the command line too. Each subcommand runs a function of
:mod:`~e2vlib.cli.data_commands`, :mod:`~e2vlib.cli.model_commands` or
:mod:`~e2vlib.cli.study_commands`; ``figures`` runs the function given to
:func:`build_parser` (the README's pictures are the top layer, imported by
``e2vlib.__main__`` alone).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable

from e2vlib.cli.checks import DEVICES, bounded, positive_number, whole_number
from e2vlib.cli.data_commands import DATA_PRESETS, run_make_data, run_merge_data, run_verify_data
from e2vlib.cli.model_commands import run_evaluate, run_reconstruct, run_train
from e2vlib.cli.study_commands import run_experiment
from e2vlib.experiments.errors import Parser


def default_first(names: Iterable[str], default: str) -> str:
    """``names`` as text for a help line, starting at ``default`` (marked so) and going
    round in their own order.

    Examples
    --------
    >>> default_first(["paper", "tiny", "tiny2d", "tiny_gru"], "tiny")
    'tiny (default), tiny2d, tiny_gru, paper'
    """
    names = list(names)
    start = names.index(default)
    rest = names[start + 1:] + names[:start]
    return ", ".join([f"{default} (default)", *rest])


def build_parser(figures: Callable[[argparse.Namespace], int]) -> argparse.ArgumentParser:
    """The parser of ``python -m e2vlib``; ``figures`` runs the ``figures`` subcommand.

    Examples
    --------
    >>> args = build_parser(figures=print).parse_args(
    ...     ["evaluate", "--checkpoint", "best.pt", "--data", "data_small"])
    >>> args.split, args.fscore_points, args.func.__name__
    ('test', 8192, 'run_evaluate')
    """
    from e2vlib.data import SPLITS
    from e2vlib.frames import WINDOWS
    from e2vlib.losses import LOSSES
    from e2vlib.metrics import MAX_SURFACE_POINTS
    from e2vlib.model import PRESETS
    from e2vlib.noise import NOISE_LEVELS
    from e2vlib.render import ANTI_ALIASING  # numpy only; pyvista loads when rendering
    from e2vlib.scale.options import PRECISIONS
    from e2vlib.train import RECIPES

    parser = Parser(
        prog="python -m e2vlib",
        description="E2V: 3D voxel reconstruction from a monocular event camera (lessons' CLI). "
                    "Errors are one line on stderr (exit 2: bad arguments, 1: failures).",
    )
    parser.add_argument("--debug", action="store_true",
                        help="show the full traceback of an error (may also follow the "
                        "subcommand)")
    sub = parser.add_subparsers(dest="command", required=True)
    count, positive = whole_number(0), whole_number(1)

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
    p.add_argument("--windows", choices=WINDOWS,
                   help="frame grouping: fixed clock windows (default) or the paper's Eq. 5")
    p.add_argument("--contrast", type=positive_number,
                   help="the simulator's contrast threshold C (default 0.2)")
    p.add_argument("--grey-video", action="store_true",
                   help="also store each sample's grey video at the event frames' times "
                   "(OUT/grey/<id>.npz, uint8 frames of --frame-size px)")
    p.add_argument("--noise", choices=tuple(NOISE_LEVELS), default="clean",
                   help="sensor noise of the simulated events (e2vlib.noise.NOISE_LEVELS; "
                   "default clean, as data_small)")
    p.add_argument("--splits", nargs="+", choices=SPLITS, default=list(SPLITS),
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
    p.set_defaults(func=run_make_data)

    p = sub.add_parser("merge-data", help="merge the folders of make-data --shard runs into "
                       "one dataset and check it is complete (with no SHARD_DIR: verify --out "
                       "in place)")
    p.add_argument("shards", nargs="*", metavar="SHARD_DIR",
                   help="folders built by make-data --shard i/n (same settings)")
    p.add_argument("--out", required=True, help="merged dataset folder (created); alone, the "
                   "shared folder all shards were built into, verified in place")
    p.add_argument("--copy", action="store_true", help="copy files (default: hard-link them "
                   "when on the same filesystem, else copy)")
    p.set_defaults(func=run_merge_data)

    p = sub.add_parser("verify-data", help="check every sample of a dataset: it loads as "
                       "config.json says and matches the manifest's sha256; lists each bad one")
    p.add_argument("--data", required=True, help="dataset folder")
    p.set_defaults(func=run_verify_data)

    p = sub.add_parser("train", help="train E2V on a dataset (writes best.pt, last.pt, "
                       "history.json); run under torchrun for several processes/GPUs")
    p.add_argument("--data", required=True, help="dataset folder (e2vlib or SynthEVox3D)")
    p.add_argument("--preset", help=f"model preset: {default_first(PRESETS, 'tiny')}")
    p.add_argument("--out", required=True, help="output folder for checkpoints")
    p.add_argument("--recipe", default="tiny",
                   help=f"training recipe: {default_first(RECIPES, 'tiny')}")
    p.add_argument("--epochs", type=positive, help="override the recipe's epochs")
    p.add_argument("--lr", type=positive_number, help="override the recipe's learning rate")
    p.add_argument("--batch-size", type=positive, help="override the recipe's batch size")
    p.add_argument("--resume", action="store_true", help="continue from OUT/last.pt")
    p.add_argument("--init", metavar="CHECKPOINT",
                   help="start a new run from this checkpoint's model and weights (e.g. the "
                   "slim data_small/checkpoints/first_recipe.pt), with a fresh optimizer")
    p.add_argument("--device", default="auto", help=f"one of {DEVICES} (default auto)")
    p.add_argument("--seed", type=count, default=0, help="seed for weights and shuffling")
    p.add_argument("--loss", default="bce", choices=tuple(LOSSES),
                   help="training loss (default bce, the paper's; see lesson 10)")
    p.add_argument("--precision", default="fp32", choices=PRECISIONS,
                   help="bf16: the forward pass in bfloat16 autocast, on CPUs with AVX-512 "
                   "BF16/AMX and recent GPUs (faster; bench/RESULTS.md)")
    p.add_argument("--channels-last", action="store_true",
                   help="channels-last convolution weights (faster on CPU through oneDNN)")
    p.set_defaults(func=run_train)

    p = sub.add_parser("evaluate", help="IoU and F-score per category, as in the paper's "
                       "Tables I and II, with mean-shape baselines")
    p.add_argument("--checkpoint", required=True, help="a checkpoint written by train")
    p.add_argument("--data", required=True, help="dataset folder")
    p.add_argument("--split", default="test", choices=SPLITS)
    p.add_argument("--json", help="write the results as JSON here")
    p.add_argument("--device", default="auto", help=f"one of {DEVICES} (default auto)")
    p.add_argument("--fscore-points", type=bounded(1, MAX_SURFACE_POINTS), default=8192,
                   help="surface points per grid for the F-score (default 8192, at most "
                   f"{MAX_SURFACE_POINTS})")
    p.set_defaults(func=run_evaluate)

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
    p.set_defaults(func=run_reconstruct)
    p = sub.add_parser("figures", help="render the README's pictures (events in space-time, "
                       "event frames, ground truth beside reconstruction)")
    p.add_argument("--out", default="docs/figures", help="output folder (docs/figures)")
    p.add_argument("--data", default="data_small", help="dataset with raw events (data_small)")
    p.add_argument("--checkpoint", help="trained model (default DATA/checkpoints/e2v_tiny.pt)")
    p.add_argument("--categories", default="airplane,car,chair,lamp,table",
                   help="columns of the reconstruction picture (comma-separated)")
    p.set_defaults(func=figures)

    from e2vlib.experiments.studies import STUDIES

    p = sub.add_parser("experiment", help="run a study (" + ", ".join(STUDIES) + "): train "
                       "and evaluate each config and seed, one record per run")
    p.add_argument("study", help=", ".join(STUDIES) + ", or geometry (no training: visual "
                   "hull and event carving beside the learned model)")
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
    p.add_argument("--checkpoint", action="append", metavar="NAME=PATH",
                   help="geometry only: one more learned model to score on the recorded "
                        "objects (repeatable), beside first_recipe.pt")
    p.add_argument("--keep-checkpoints", metavar="DIR",
                   help="keep each trained run's best checkpoint as DIR/STUDY/CONFIG_seedN.pt "
                        "(default: thrown away)")
    p.set_defaults(func=run_experiment)
    return parser
