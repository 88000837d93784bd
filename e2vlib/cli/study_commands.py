"""The study command: ``experiment STUDY`` (training studies, and the geometry study).

Each run appends one record to ``OUT/STUDY.json`` (:mod:`e2vlib.experiments`); lessons 09 to
12 read those records.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from e2vlib.cli.checks import check_device, output_folder
from e2vlib.experiments.errors import UsageError


def run_experiment(args: argparse.Namespace) -> int:
    """``experiment STUDY``: run (or finish) a study and print its summary.

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> run_experiment(parse(["experiment", "bogus"]))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: unknown study 'bogus'; choose one of representation, \
time, ...
    """
    from e2vlib.experiments import DEFAULT_OUT, STUDIES, run_study, summarize
    from e2vlib.experiments.summary import format_study_table

    if args.study == "geometry":
        return run_geometry_study(args)
    if args.checkpoint:
        raise UsageError("--checkpoint is for the geometry study; a training study keeps its "
                         "models with --keep-checkpoints DIR")
    if args.study not in STUDIES:
        raise UsageError(f"unknown study {args.study!r}; choose one of {', '.join(STUDIES)}")
    unknown = [c for c in args.configs or () if c not in STUDIES[args.study].configs]
    if unknown:
        raise UsageError(f"study {args.study!r} has no configs {unknown}; it has "
                         f"{', '.join(STUDIES[args.study].configs)}")
    check_device(args.device)
    out = args.out or (DEFAULT_OUT.parent / "results-quick" if args.quick else DEFAULT_OUT)
    output_folder(str(out), "--out")
    path = run_study(args.study, args.configs, args.seeds, out, device=args.device,
                     quick=args.quick, reuse=not args.no_reuse,
                     checkpoints=args.keep_checkpoints)
    print(f"{path}:")
    print(format_study_table(summarize(path)))
    return 0


def run_geometry_study(args: argparse.Namespace) -> int:
    """``experiment geometry``: score the geometry baselines, no training.

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> run_geometry_study(parse(["experiment", "geometry", "--quick"]))
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: the geometry study has no configs and no quick mode (no \
training); run `python -m e2vlib experiment geometry`
    """
    from e2vlib.experiments import DEFAULT_OUT
    from e2vlib.experiments.geometry_study import run_geometry_study, summarize_geometry

    if args.configs or args.quick:
        raise UsageError("the geometry study has no configs and no quick mode (no training); "
                         "run `python -m e2vlib experiment geometry`")
    checkpoints = {}
    for item in args.checkpoint or ():
        name, sep, ckpt = item.partition("=")
        if not sep or not name or not ckpt:
            raise UsageError(f"--checkpoint must look like NAME=PATH, got {item!r}")
        if not Path(ckpt).is_file():
            raise UsageError(f"--checkpoint {item}: no file {ckpt}")
        checkpoints[name] = ckpt
    out = args.out or DEFAULT_OUT
    output_folder(str(out), "--out")
    path = run_geometry_study(out, checkpoints=checkpoints)
    print(f"{path}:")
    for row in summarize_geometry(path):
        low, high = row["ci95"]
        print(f"  {row['method']:15s} IoU@0.3 {row['mean']:.3f} ({low:.3f}-{high:.3f}, "
              f"{row['n']} objects)")
    return 0
