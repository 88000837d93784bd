"""The command line's parts: ``python -m e2vlib`` (:mod:`e2vlib.__main__`) runs them.

Every subcommand is a thin wrapper over library functions: it checks its arguments before
any work starts and before anything is written, then calls the library, and prints what it
made. The code lives in six modules, each with one job:

=============================  =============================================================
``cli.errors``                 how a command fails: :class:`UsageError` (exit 2),
                               :class:`CommandError` (exit 1), :func:`one_line`, the
                               one-line :class:`Parser`, and :func:`run`, the loop that
                               parses, runs and turns every error into one line on stderr
``cli.checks``                 values checked before the work: argparse types
                               (:func:`whole_number`, :func:`bounded`,
                               :func:`positive_number`), :func:`check_device`, output
                               paths (:func:`output_file`, :func:`output_folder`),
                               :func:`parse_categories`, :func:`model_frames_check`
``cli.data_commands``          ``make-data`` (:data:`DATA_PRESETS`, :func:`build_config`),
                               ``merge-data``, ``verify-data``
``cli.model_commands``         ``train`` (and what resuming checks, :func:`resume_checks`),
                               ``evaluate``, ``reconstruct`` (:func:`e2vlib.experiments.reconstruct
                               .reconstruct` does the work)
``cli.study_commands``         ``experiment`` (training studies and the geometry study)
``cli.parser``                 :func:`build_parser`: every subcommand, its flags, help and
                               choices (from the library's own tuples)
=============================  =============================================================

``errors`` imports no other module of this package; ``checks`` imports ``errors``; the
three command modules import those two; ``parser`` imports all five; none imports this
``__init__``. The library modules each command needs are imported when it runs, so
``--help`` and argument errors stay quick to answer (torch loads only through the tuples
the parser's choices come from). ``figures`` stays in ``e2vlib.__main__``.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "errors": ["EXIT_FAILURE", "EXIT_USAGE", "CommandError", "Parser", "run", "UsageError"],
    },
)
