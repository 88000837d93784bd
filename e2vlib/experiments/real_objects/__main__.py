"""The recorded commands that build the real-object catalogue (issue #38, stage 1).

    python -m e2vlib.experiments.real_objects download --cache cache/real_objects
    python -m e2vlib.experiments.real_objects extract  --cache cache/real_objects
    python -m e2vlib.experiments.real_objects grids    --cache cache/real_objects
    python -m e2vlib.experiments.real_objects sheets   --cache cache/real_objects
    python -m e2vlib.experiments.real_objects catalogue --cache cache/real_objects

``download`` and ``extract`` fetch and unpack the Debian packages
(:mod:`~e2vlib.experiments.real_objects.sources`); ``grids`` loads every candidate in our
frame (its reviewed rotation, else its source's default) and stores its surface grid and
the parts left out under ``<cache>/grids``; ``sheets`` draws the contact sheets to look at
(``<cache>/sheets``); ``catalogue`` joins the candidates, the review
(``<cache>/review.csv``: key, category, rotation, keep, note, written by the person who
looked), the duplicates and the reviewed Sweet Home 3D rows into
``experiments/real_objects/catalogue.csv`` with its split.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from e2vlib.experiments.real_objects.build import (
    build_grids,
    build_sheets,
    candidate_key,
    write_catalogue,
)
from e2vlib.experiments.real_objects.sources import download, extract, find_candidates


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m e2vlib.experiments.real_objects",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("step", choices=["download", "extract", "candidates", "grids",
                                         "sheets", "catalogue"])
    parser.add_argument("--cache", type=Path, default=Path("cache/real_objects"))
    parser.add_argument("--only", default=None, help="regex on candidate keys")
    args = parser.parse_args(argv)
    start = time.monotonic()
    if args.step == "download":
        print(download(args.cache))
    elif args.step == "extract":
        print(extract(args.cache))
    elif args.step == "candidates":
        for c in find_candidates(args.cache):
            print(candidate_key(c), c.category, c.source, c.path, c.licence, sep=",")
    elif args.step == "grids":
        build_grids(args.cache, args.only)
    elif args.step == "sheets":
        build_sheets(args.cache, only=args.only)
    elif args.step == "catalogue":
        write_catalogue(args.cache)
    print(f"{args.step}: {time.monotonic() - start:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
