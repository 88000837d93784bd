"""Command line: ``python -m e2vlib {make-data,merge-data,train,evaluate,reconstruct,...} ...``.

Each subcommand is a thin wrapper over a library function; ``--help`` on any of them
lists its options. Arguments are checked before any work starts and before anything is
written (output folders and files included). Every error is one line on stderr,
``error: <what is wrong and the fix>``, with exit status 2 for a bad argument and 1 for a
failure; ``--debug`` (anywhere on the command line) shows the traceback instead.

The subcommands live in :mod:`e2vlib.cli` (the parser, the checks, the commands); this
module runs them and holds ``figures``, since the README's pictures are the top layer that
only the command line imports. It exports :func:`main` and :func:`build_parser`; the parts'
names are imported from :mod:`e2vlib.cli`'s modules.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from e2vlib.cli import parser
from e2vlib.experiments.errors import run


def _figures(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    from e2vlib.experiments.figures import render_readme_figures

    checkpoint = args.checkpoint or str(Path(args.data) / "checkpoints" / "e2v_tiny.pt")
    try:
        paths = render_readme_figures(args.out, args.data, checkpoint,
                                      categories=tuple(args.categories.split(",")))
    except (FileNotFoundError, ValueError) as err:
        raise SystemExit(f"figures: {err}") from err
    for path in paths.values():
        print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The parser of every subcommand (:func:`e2vlib.cli.parser.build_parser`).

    Examples
    --------
    >>> args = build_parser().parse_args(["reconstruct", "--checkpoint", "best.pt",
    ...                                  "--mesh", "chair.obj", "--out", "r.npz"])
    >>> args.command, args.device, args.seed, args.overwrite
    ('reconstruct', 'auto', 0, False)
    """
    return parser.build_parser(figures=_figures)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit status (0 success, 1 failure, 2 bad usage).

    ``--debug`` anywhere in ``argv`` lets exceptions propagate with their traceback.

    Examples
    --------
    >>> import contextlib, io
    >>> with contextlib.redirect_stderr(io.StringIO()) as err:
    ...     status = main(["train", "--data", "d", "--out", "r", "--epochs", "0"])
    >>> status, err.getvalue()
    (2, 'error: argument --epochs: must be a whole number >= 1, got 0 (see python -m e2vlib \
train --help)\\n')
    """
    return run(build_parser, argv)


__all__ = ["build_parser", "main"]

if __name__ == "__main__":
    sys.exit(main())
