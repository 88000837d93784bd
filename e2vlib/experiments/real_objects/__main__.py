"""The recorded commands that build the real-object catalogue and samples.

    python -m e2vlib.experiments.real_objects download --cache cache/real_objects
    python -m e2vlib.experiments.real_objects extract  --cache cache/real_objects
    python -m e2vlib.experiments.real_objects grids    --cache cache/real_objects
    python -m e2vlib.experiments.real_objects sheets   --cache cache/real_objects
    python -m e2vlib.experiments.real_objects review   --cache cache/real_objects
    python -m e2vlib.experiments.real_objects catalogue --cache cache/real_objects
    python -m e2vlib.experiments.real_objects samples --cache cache/real_objects \
        --out cache/real_objects/data
    python -m e2vlib.experiments.real_objects study --seeds 0 1 2 3 4
    python -m e2vlib.experiments.real_objects ship --out data_small/real_objects

``download`` and ``extract`` fetch and unpack the Debian packages
(:mod:`~e2vlib.experiments.real_objects.sources`); ``grids`` loads every candidate in our
frame (its reviewed rotation and parts, else its source's default) and stores its surface
grid and the parts left out under ``<cache>/grids``; ``sheets`` draws contact sheets of the
candidates no one has looked at yet (``<cache>/sheets``); ``review`` turns the notes typed
while looking (``<cache>/review/*.txt``, one line per sheet cell) into
``<cache>/review.csv``; ``catalogue`` joins the candidates, the review (or, without
``review.csv``, the committed catalogue read back), the duplicates by geometry and the
reviewed Sweet Home 3D rows into ``experiments/real_objects/catalogue.csv`` with its split.
Rerun ``grids`` after the review changes a rotation or the parts to remove. ``samples``
(stage 2, :mod:`~e2vlib.experiments.real_objects.samples`) builds the catalogue's kept rows
into a dataset folder models train on (resumable; ``make real-data`` runs download,
extract and samples); ``download`` and ``extract`` also fetch the Sweet Home 3D packages
its reviewed rows need (:data:`~e2vlib.experiments.real_objects.samples.EXTRA_PACKAGES`),
when apt can. ``study`` runs the ``real_objects`` study on those samples
(:mod:`~e2vlib.experiments.real_objects.study`; resumable, one record per run;
``--table`` prints the recorded table); ``ship`` copies the CC0 / CC-BY rows' samples into
a committed folder with their attribution (:mod:`~e2vlib.experiments.real_objects.ship`).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from e2vlib.experiments.real_objects.build import (
    build_grids,
    build_sheets,
    candidate_key,
    review_from_notes,
    write_catalogue,
)
from e2vlib.experiments.real_objects.samples import DATA_DIR, EXTRA_PACKAGES, build_samples
from e2vlib.experiments.real_objects.sources import (
    PACKAGES,
    download,
    extract,
    find_candidates,
)


def _extras(cache: Path, step) -> None:
    """Download or extract the Sweet Home 3D packages too; a failure only warns (the
    samples step then skips their rows, saying so)."""
    for name in EXTRA_PACKAGES:
        try:
            print(step(cache, [name]))
        except (OSError, subprocess.CalledProcessError) as err:
            print(f"{name}: {err}; its rows will be skipped by the samples step",
                  file=sys.stderr)


def _study(args: argparse.Namespace, argv: list[str]) -> None:
    """Run (or, with ``--table``, print) the ``real_objects`` study."""
    from e2vlib.experiments.real_objects import study

    path = args.results / "real_objects.json"
    if not args.table:
        command = " ".join(["python -m e2vlib.experiments.real_objects", *argv])
        path = study.run_real_objects(args.configs or study.MAIN, args.seeds, args.results,
                                      args.out, quick=args.quick,
                                      load_mesh=study.catalogue_mesh_loader(args.cache),
                                      command=command)
    results = study.read_table(path)  # the one checked reader, and the table's scores
    for key in study.TABLE_KEYS:
        print(study.format_real_objects_table(results, key), end="\n\n")


def build_parser(parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser
                 ) -> argparse.ArgumentParser:
    """The parser of ``python -m e2vlib.experiments.real_objects``; ``parser_class`` makes
    its errors (:class:`e2vlib.experiments.errors.Parser`'s are one line)."""
    parser = parser_class(prog="python -m e2vlib.experiments.real_objects",
                          description=__doc__.split("\n")[0])
    parser.add_argument("step", choices=["download", "extract", "candidates", "grids",
                                         "sheets", "review", "catalogue", "samples",
                                         "study", "ship"])
    parser.add_argument("--cache", type=Path, default=Path("cache/real_objects"))
    parser.add_argument("--only", default=None, help="regex on candidate keys (samples: ids)")
    parser.add_argument("--out", type=Path, default=None,
                        help="samples: the dataset folder (default cache/real_objects/data); "
                        "ship: the folder shipped (default data_small/real_objects)")
    parser.add_argument("--limit", type=int, default=None,
                        help="samples: make at most this many samples this run")
    parser.add_argument("--configs", nargs="+", default=None,
                        help="study: configs to run (default: the four main ones)")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4],
                        help="study: seeds")
    parser.add_argument("--results", type=Path, default=Path("experiments/results"),
                        help="study: folder of real_objects.json")
    parser.add_argument("--quick", action="store_true",
                        help="study: one object per category and split, 32 px, 1 epoch")
    parser.add_argument("--table", action="store_true",
                        help="study: only print the recorded table")
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an error instead of one line")
    return parser


def run_step(args: argparse.Namespace, argv: list[str]) -> int:
    """Run one parsed step (``argv``: its command line, recorded by ``study``); prints what
    it did and the seconds it took; returns the exit status (0)."""
    data = Path(DATA_DIR)
    if args.out is None and args.step != "ship":
        args.out = data
    start = time.monotonic()
    if args.step == "download":
        print(download(args.cache, list(PACKAGES)))
        _extras(args.cache, download)
    elif args.step == "extract":
        print(extract(args.cache, list(PACKAGES)))
        _extras(args.cache, extract)
    elif args.step == "candidates":
        for c in find_candidates(args.cache):
            print(candidate_key(c), c.category, c.source, c.path, c.licence, sep=",")
    elif args.step == "grids":
        build_grids(args.cache, args.only)
    elif args.step == "sheets":
        build_sheets(args.cache, only=args.only)
    elif args.step == "review":
        print(f"{review_from_notes(args.cache)} review rows in {args.cache / 'review.csv'}")
    elif args.step == "catalogue":
        write_catalogue(args.cache)
    elif args.step == "samples":
        build_samples(args.cache, args.out, only=args.only, limit=args.limit)
    elif args.step == "ship":
        from e2vlib.experiments.errors import UsageError
        from e2vlib.experiments.real_objects.ship import SHIP_DIR, check_ship_out, ship_samples

        out = args.out or Path(SHIP_DIR)
        try:  # a bad --out is a bad command line (exit status 2)
            check_ship_out(data, out)
        except (ValueError, OSError) as err:
            raise UsageError(str(err)) from None
        print(ship_samples(data, out))
    elif args.step == "study":
        _study(args, argv)
    print(f"{args.step}: {time.monotonic() - start:.0f} s", file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run one recorded step (``argv``: the command line after the module name, default
    ``sys.argv[1:]``); returns the exit status. Errors are one line on stderr naming the
    file (exit status 1; 2 for a bad command line), as ``python -m e2vlib``'s
    (:func:`e2vlib.experiments.errors.run`); ``--debug`` shows the traceback."""
    from e2vlib.experiments import errors

    argv = list(sys.argv[1:] if argv is None else argv)
    recorded = [a for a in argv if a != "--debug"]

    def build() -> argparse.ArgumentParser:
        parser = build_parser(errors.Parser)
        parser.set_defaults(func=lambda args: run_step(args, recorded))
        return parser

    return errors.run(build, argv)


if __name__ == "__main__":
    sys.exit(main())
