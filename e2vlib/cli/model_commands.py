"""The model commands: ``train`` (with what resuming checks), ``evaluate``, ``reconstruct``.

Introduced in notebooks/06_training.ipynb and notebooks/07_evaluation.ipynb.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from e2vlib.cli.checks import (
    PICTURE_TYPES,
    check_device,
    model_frames_check,
    output_file,
    output_folder,
    separate_paths,
)
from e2vlib.experiments.errors import CommandError, UsageError


def resume_checks(last: Path, ckpt: dict, preset: str | None) -> None:
    """Refuse to resume from a weights-only checkpoint or with another ``--preset``.

    Examples
    --------
    >>> from e2vlib.model import PRESETS
    >>> from e2vlib.scale.training import RESUME_KEYS
    >>> last = Path("run/last.pt")
    >>> resume_checks(last, {"config": PRESETS["tiny"].to_dict()}, None)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.CommandError: cannot resume from run/last.pt: it holds the \
weights only \
(no optimizer, epoch, best_iou, history, torch_rng; ...
    >>> full = {"config": PRESETS["tiny"].to_dict(), **dict.fromkeys(RESUME_KEYS)}
    >>> resume_checks(last, full, "tiny")  # the model's own preset: no answer
    >>> resume_checks(last, full, "tiny2d")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.CommandError: --preset tiny2d differs from the model in \
run/last.pt, which \
holds preset tiny (different encoder); ...
    """
    from dataclasses import replace

    from e2vlib.model import PRESETS, E2VConfig
    from e2vlib.scale.training import resume_problems

    missing, _ = resume_problems(ckpt)
    if missing:
        raise CommandError(
            f"cannot resume from {last}: it holds the weights only (no {', '.join(missing)}; "
            "a slimmed checkpoint such as data_small/checkpoints/first_recipe.pt). Start a new run "
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
        _, differ = resume_problems(ckpt, wanted)
        raise CommandError(
            f"--preset {preset} differs from the model in {last}, which holds {held} "
            f"(different {', '.join(differ)}); resume without --preset (the model comes "
            f"from last.pt), or train --preset {preset} into another --out folder")


def run_train(args: argparse.Namespace) -> int:
    """``train``: check everything before the work, then
    :func:`e2vlib.scale.training.fit_at_scale` (``fit`` with ``--resume``, ``--precision``,
    ``--channels-last`` and torchrun).

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> run_train(parse(["train", "--data", "d", "--out", "r", "--recipe", "bogus"]))
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --recipe 'bogus' is not a training recipe; choose one \
of ...
    """
    from e2vlib.data import E2VDataset
    from e2vlib.data.checks import read_config
    from e2vlib.model import PRESETS, build_e2v, load_checkpoint, read_checkpoint
    from e2vlib.paper import IOU_THRESHOLD
    from e2vlib.scale.training import fit_at_scale, init_distributed_from_env
    from e2vlib.train import RECIPES, get_recipe

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
    check_device(args.device)
    out = output_folder(args.out, "--out")
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
        resume_checks(last, ckpt, args.preset)
        model = load_checkpoint(ckpt, source=f"checkpoint {last}").train()  # checked
        done = int(ckpt["epoch"]) + 1
        if done >= recipe.epochs:
            print(f"nothing to do: {last} already holds {done} epochs of the {recipe.epochs} "
                  "asked for; pass a larger --epochs to train further")
            return 0
        del ckpt
    elif init is not None:
        ckpt = read_checkpoint(init)
        model = load_checkpoint(ckpt, source=f"checkpoint {init}").train()
        model_frames_check(model, ckpt, str(init), train_set.config, train_set.input_shape,
                           f"dataset {args.data}")
        del ckpt
    else:
        model = build_e2v(args.preset or "tiny", seed=args.seed,
                          input_shape=train_set.input_shape)
    history = fit_at_scale(model, train_set, val_set, out, recipe=recipe, device=args.device,
                           seed=args.seed, resume=args.resume, metadata=metadata,
                           loss=args.loss, precision=args.precision,
                           channels_last=args.channels_last)
    if history:
        best = max(history, key=lambda h: h["val_iou"])
        print(f"best validation IoU@{IOU_THRESHOLD} {best['val_iou']:.3f} at epoch "
              f"{best['epoch']}; "
              f"checkpoints in {out}")
    return 0


def run_evaluate(args: argparse.Namespace) -> int:
    """``evaluate``: the paper's tables for a checkpoint on a split (and ``--json``).

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> import tempfile
    >>> folder = tempfile.mkdtemp()
    >>> run_evaluate(parse(["evaluate", "--checkpoint", "none.pt", "--data", "d", "--json",
    ...                     folder]))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --json ... is a directory; give a file name, e.g. \
.../results.json
    """
    import json

    from e2vlib.data import E2VDataset
    from e2vlib.files import atomic_path
    from e2vlib.metrics import format_category_table
    from e2vlib.model import load_checkpoint, read_checkpoint
    from e2vlib.train import evaluate

    json_path = output_file(args.json, "--json", "results.json") if args.json else None
    separate_paths({"--json": json_path}, {"--checkpoint": args.checkpoint})
    check_device(args.device)
    ckpt = read_checkpoint(args.checkpoint)
    model = load_checkpoint(ckpt, source=f"checkpoint {args.checkpoint}")
    data = E2VDataset(args.data, args.split)
    model_frames_check(model, ckpt, args.checkpoint, data.config, data.input_shape,
                       f"dataset {args.data}")
    del ckpt
    try:
        train = E2VDataset(args.data, "train")
    except ValueError:
        train = None
    result = evaluate(model, data, train_data=train, device=args.device,
                      fscore_points=args.fscore_points)
    print(format_category_table(result))
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(json_path) as tmp:
            tmp.write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {json_path}")
    return 0


def run_reconstruct(args: argparse.Namespace) -> int:
    """``reconstruct``: :func:`e2vlib.experiments.reconstruct.reconstruct`, written to ``--out``.

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> run_reconstruct(parse(["reconstruct", "--checkpoint", "none.pt", "--events", "e.h5",
    ...                        "--out", "r.npz", "--png", "r.gif"]))
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --png r.gif: unknown picture type '.gif'; end the \
name with one \
of .png, .jpg, .jpeg, .pdf, .svg
    """
    import numpy as np

    from e2vlib.experiments.reconstruct import InputError, reconstruct
    from e2vlib.files import atomic_path
    from e2vlib.paper import IOU_THRESHOLD

    out = output_file(args.out, "--out", "reconstruction.npz")
    png = output_file(args.png, "--png", "reconstruction.png") if args.png else None
    separate_paths({"--out": out, "--png": png}, {"--checkpoint": args.checkpoint,
                                                  "--mesh": args.mesh, "--events": args.events})
    for flag, path in (("--out", out), ("--png", png)):
        if path is not None and path.exists() and not args.overwrite:
            raise UsageError(f"{flag} {path} exists; pass --overwrite to replace it, or "
                             f"choose another {flag}")
    if png is not None and png.suffix.lower() not in PICTURE_TYPES:
        raise UsageError(f"--png {png}: unknown picture type {png.suffix!r}; end the name "
                         f"with one of {', '.join(PICTURE_TYPES)}")
    check_device(args.device)
    source = Path(args.mesh or args.events)
    if not source.is_file():
        flag = "--mesh" if args.mesh else "--events"
        raise UsageError(f"{flag} {source}: no such file")
    try:  # the frames are made exactly as for the data the model was trained on
        result = reconstruct(args.checkpoint, mesh=args.mesh, events=args.events,
                             device=args.device, seed=args.seed)
    except InputError as err:
        raise CommandError(f"--events {source}: {err.reason}; nothing was written") from None
    except FloatingPointError:
        raise CommandError(f"the model's output holds NaN/inf for this input; nothing was "
                           f"written. Check checkpoint {args.checkpoint} (retrain, or use "
                           "best.pt)") from None
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, **result.arrays())
    print(f"wrote {out}: occupied voxels at {IOU_THRESHOLD}: {result.occupied()}")
    if result.voxels is not None:
        print(f"IoU@{IOU_THRESHOLD} against the mesh's own voxels: {result.iou():.3f}")
    if png is not None:
        import matplotlib

        matplotlib.use("Agg")
        from e2vlib.viz import plot_reconstruction

        fig = plot_reconstruction(result.probabilities, result.voxels, threshold=IOU_THRESHOLD)
        png.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(png) as tmp:
            fig.savefig(tmp, dpi=120, bbox_inches="tight", format=png.suffix.lower()[1:])
        print(f"wrote {png}")
    return 0
