"""The dataset commands: ``make-data`` (with its presets), ``merge-data``, ``verify-data``.

Introduced in notebooks/04_building_the_dataset.ipynb.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from e2vlib.cli.checks import output_folder, parse_categories, real_meshes_flags_check
from e2vlib.experiments.errors import CommandError, UsageError

DATA_PRESETS = {
    # data_small/: 13 categories x 64 objects = 832 samples, 128 px renders, 64 px frames
    "small": {"per_category": 64, "resolution": 128, "frame_size": 64, "seed": 0},
    # the paper's input size: 512 px renders max-pooled to 256 px frames
    "paper": {"per_category": 3057, "resolution": 512, "frame_size": 256, "seed": 0},
}
"""``make-data --preset``: settings a preset gives, each overridden by its own flag."""


def build_config(args: argparse.Namespace):
    """The BuildConfig a ``make-data`` command line asks for (UsageError if invalid).

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> config = build_config(parse(["make-data", "--out", "d", "--preset", "small",
    ...                              "--categories", "chair,table", "--noise", "low"]))
    >>> config.categories, config.per_category, config.resolution, config.frame_size, config.noise
    (('chair', 'table'), 64, 128, 64, 'low')
    >>> build_config(parse(["make-data", "--out", "d", "--resolution", "32", "--frame-size", "64"]))
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: invalid dataset settings: frame_size 64 must divide \
resolution 32
    """
    from e2vlib.data import BuildConfig
    from e2vlib.paper import CATEGORIES

    settings = dict(DATA_PRESETS[args.preset]) if args.preset else {}
    for key in ("per_category", "resolution", "frame_size", "seed", "n_frames", "dt_us",
                "windows", "contrast"):
        value = getattr(args, key)
        if value is not None:
            settings[key] = value
    settings.setdefault("per_category", 32)
    categories = parse_categories(args.categories) if args.categories is not None else CATEGORIES
    try:  # validates every setting; nothing is written before this
        return BuildConfig(categories=categories, oversample=args.oversample,
                           raw_events_per_category=args.raw_events_per_category,
                           grey_video=args.grey_video, noise=args.noise,
                           splits=tuple(args.splits), anti_aliasing=args.anti_aliasing,
                           **settings)
    except ValueError as err:
        raise UsageError(f"invalid dataset settings: {err}") from None


def run_make_data(args: argparse.Namespace) -> int:
    """``make-data``: build a dataset (or the real-mesh test set) after printing its plan.

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> run_make_data(parse(["make-data", "--out", "d", "--shard", "3/2"]))  # before any work
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: --shard: shard '3/2': need 0 <= i < n
    """
    from e2vlib.data import build_dataset, check_build_folder, describe_build, parse_shard

    if args.real_meshes is not None:  # flags a real-mesh build cannot honour, before all
        real_meshes_flags_check(args)
    try:
        shard = parse_shard(args.shard)
    except ValueError as err:
        raise UsageError(f"--shard: {err}") from None
    config = build_config(args)
    output_folder(args.out, "--out")
    if args.real_meshes is not None:  # the real-mesh test set (e2vlib.experiments.real_meshes)
        from e2vlib.experiments.real_meshes import build_real_dataset

        manifest = build_real_dataset(args.out, config, args.real_meshes, workers=args.workers)
        print(f"manifest: {manifest}")
        return 0
    check_build_folder(args.out, config)
    print(describe_build(args.out, config, shard), flush=True)
    from e2vlib.scale.render_cache import render_orbit_cached

    manifest = build_dataset(args.out, config, workers=args.workers, shard=shard,
                             renderer=render_orbit_cached)
    print(f"manifest: {manifest}")
    return 0


def run_merge_data(args: argparse.Namespace) -> int:
    """``merge-data``: join the folders of a sharded build, or verify a shared one in place.

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> run_merge_data(parse(["merge-data", "--out", str(folder / "all"), str(folder / "s0")]))
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: shard folder .../s0: no such folder; give the --out \
folders of \
the make-data --shard runs
    """
    from e2vlib.scale.shards import merge_datasets

    out = output_folder(args.out, "--out")
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


def run_verify_data(args: argparse.Namespace) -> int:
    """``verify-data``: check every sample; list each bad one and exit 1 if any.

    Examples
    --------
    >>> from e2vlib.cli.parser import build_parser
    >>> parse = build_parser(figures=print).parse_args
    >>> run_verify_data(parse(["verify-data", "--data", "no_such_dataset"]))
    Traceback (most recent call last):
    ...
    FileNotFoundError: dataset folder no_such_dataset does not exist
    """
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
