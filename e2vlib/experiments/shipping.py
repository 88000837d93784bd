"""Ship one recorded run's model: a kept checkpoint made into a small file a lesson loads.

A study run with ``--keep-checkpoints DIR`` keeps each run's best model; its record names
the file. :func:`ship_checkpoint` turns one of them into a checkpoint for students: the
weights (digest checked on read and written anew), the data settings it was trained on, the
threshold picked on the validation split (``val_threshold``, which
:mod:`e2vlib.experiments.real_study` and the geometry study then use) and where it came from
(``provenance``: study, config, seed, the command, the record's test scores, CPU and
commit). Optimizer and random-generator states are left out.

Command line: ``python -m e2vlib.experiments.shipping STUDY CONFIG SEED OUT``.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Sequence
from pathlib import Path

from e2vlib.experiments.reports import load_results, runs_of

KEPT_KEYS = ("recipe", "loss", "history", "epoch", "best_iou", "seed")
"""Training facts of the kept checkpoint carried into the shipped one."""


def ship_checkpoint(study: str, config: str, seed: int, out: str | os.PathLike,
                    results_root: str | os.PathLike | None = None) -> Path:
    """Write the kept checkpoint of run (``study``, ``config``, ``seed``) to ``out``.

    Raises ValueError when the run is not recorded or kept no checkpoint (naming the command
    that keeps one), and :class:`e2vlib.model.CheckpointError` when the kept file's weights
    do not match their digest.
    """
    import torch

    from e2vlib.model import load_checkpoint, save_checkpoint
    from e2vlib.model.checkpoint import checkpoint_data_config

    results = load_results(study, results_root)
    run = next((r for r in runs_of(results, config) if r["seed"] == int(seed)), None)
    if run is None:
        raise ValueError(f"{study}/{config} seed {seed} is not recorded; run `python -m "
                         f"e2vlib experiment {study} --configs {config} --seeds {seed} "
                         "--keep-checkpoints cache/checkpoints`")
    kept = run.get("checkpoint")
    if kept is None or not Path(kept).is_file():
        raise ValueError(f"{study}/{config} seed {seed} kept no checkpoint ({kept or 'none'}"
                         "); train it again with --keep-checkpoints DIR (and --no-reuse)")
    model = load_checkpoint(kept)  # checks the weights against their digest
    state = torch.load(kept, map_location="cpu", weights_only=True)
    metrics = run["metrics"]
    provenance = {
        "study": study, "config": config, "seed": int(seed), "params": run["params"],
        "command": (f"python -m e2vlib experiment {study} --configs {config} --seeds {seed} "
                    "--keep-checkpoints cache/checkpoints"),
        "test_iou@0.3": metrics["iou@0.3"], "test_iou@val_threshold":
            metrics["iou@val_threshold"], "train_seconds": run["train_seconds"],
        "cpu": run["cpu"], "torch": run["torch"], "commit": run["commit"],
    }
    extra = {k: state[k] for k in KEPT_KEYS if k in state}
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    return save_checkpoint(out, model, data_config=checkpoint_data_config(state),
                           val_threshold=float(metrics["val_threshold"]),
                           provenance=provenance, **extra)


def build_parser(parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser
                 ) -> argparse.ArgumentParser:
    """The parser of ``python -m e2vlib.experiments.shipping`` (its ``func`` ships the
    checkpoint); ``parser_class`` makes its errors (the command line's is one line)."""
    parser = parser_class(prog="python -m e2vlib.experiments.shipping",
                          description=__doc__.split("\n\n")[0])
    parser.add_argument("study")
    parser.add_argument("config")
    parser.add_argument("seed", type=int)
    parser.add_argument("out", help="the checkpoint to write (.pt)")
    parser.set_defaults(func=lambda args: print(
        f"wrote {ship_checkpoint(args.study, args.config, args.seed, args.out)}"))
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m e2vlib.experiments.shipping STUDY CONFIG SEED OUT``; errors are one line
    on stderr (exit status 1; 2 for a bad command line), as the command line's
    (:func:`e2vlib.experiments.errors.run`; ``--debug`` shows the traceback)."""
    from e2vlib.experiments import errors  # the command line's error wrapper
    return errors.run(lambda: build_parser(errors.Parser),
                      None if argv is None else list(argv))


if __name__ == "__main__":
    raise SystemExit(main())
