"""How a command fails: one line on stderr, exit status 2 for a bad argument, 1 for a
failure, and the loop that runs a command line (:func:`run`); ``--debug`` shows the
traceback instead.

``python -m e2vlib`` (:mod:`e2vlib.cli`) and the lab's own commands
(``python -m e2vlib.experiments.real_study``, ``.shipping``, ``.real_objects``) fail through
it alike. It imports nothing of e2vlib, so it sits in the lab and both may import it.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

EXIT_FAILURE = 1
"""Exit status of a command that failed (bad data, unreadable file, ...)."""

EXIT_USAGE = 2
"""Exit status of a bad command line (unknown option, bad value), as argparse uses."""


class UsageError(Exception):
    """A bad command-line value; printed as one line, exit status :data:`EXIT_USAGE`.

    Examples
    --------
    >>> one_line(UsageError("--out x is a file; give a folder"))
    '--out x is a file; give a folder'
    """


class CommandError(Exception):
    """A command that cannot go on; printed as one line, exit status :data:`EXIT_FAILURE`.

    Examples
    --------
    >>> one_line(CommandError("3 of 9 samples are bad"))
    '3 of 9 samples are bad'
    """


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (raised as :class:`UsageError`).

    Examples
    --------
    >>> parser = Parser(prog="demo")
    >>> _ = parser.add_argument("--n", type=int)
    >>> parser.parse_args(["--n", "x"])
    Traceback (most recent call last):
    ...
    e2vlib.experiments.errors.UsageError: argument --n: invalid int value: 'x' (see demo --help)
    """

    def error(self, message: str):  # argparse's hook for every parsing error
        raise UsageError(f"{message} (see {self.prog} --help)")


def one_line(err: BaseException) -> str:
    """An exception as one line: its message, with the type when it is unexpected.

    Examples
    --------
    >>> one_line(ValueError("bad\\n  value"))
    'bad value'
    >>> one_line(KeyError("optimizer"))
    "KeyError: 'optimizer' (unexpected; rerun with --debug for the traceback)"
    """
    message = " ".join(str(err).split())
    if isinstance(err, KeyError) and len(err.args) == 1:
        message = repr(err.args[0])
    expected = isinstance(err, (UsageError, CommandError, ValueError, OSError))
    if (expected or getattr(err, "expected", False)) and message:  # e.g. a worker's refusal
        if isinstance(err, PermissionError):
            message += "; choose a location you can write to, or fix its permissions"
        return message
    return (f"{type(err).__name__}: {message or 'no message'} (unexpected; rerun with --debug "
            "for the traceback)")


def run(build_parser: Callable[[], argparse.ArgumentParser], argv: list[str] | None = None
        ) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``) with ``build_parser()``, run the command
    and return the exit status (0 success, 1 failure, 2 bad usage, 130 interrupted); an
    error is printed as one line ``error: ...`` on stderr.

    ``--debug`` anywhere in ``argv`` lets exceptions propagate with their traceback.

    Examples
    --------
    >>> def build():
    ...     parser = Parser(prog="demo")
    ...     _ = parser.add_argument("--n", type=int, required=True)
    ...     parser.set_defaults(func=lambda args: print(args.n * 2))
    ...     return parser
    >>> run(build, ["--n", "21"])
    42
    0
    >>> import contextlib, io
    >>> with contextlib.redirect_stderr(io.StringIO()) as err:
    ...     status = run(build, [])
    >>> status, err.getvalue()
    (2, 'error: the following arguments are required: --n (see demo --help)\\n')
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    status, message = 0, None
    try:
        args = build_parser().parse_args(argv)
        return int(args.func(args) or 0)
    except SystemExit as exc:  # --help (0), or code that exits with a message
        if exc.code is None or isinstance(exc.code, int):
            return int(exc.code or 0)
        if debug:
            raise
        status, message = EXIT_FAILURE, " ".join(str(exc.code).split())
    except KeyboardInterrupt:
        if debug:
            raise
        status, message = 130, "interrupted"
    except Exception as err:
        if debug:
            raise
        status = EXIT_USAGE if isinstance(err, UsageError) else EXIT_FAILURE
        message = one_line(err)
    print(f"error: {message}", file=sys.stderr)
    return status
