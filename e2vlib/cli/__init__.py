"""The command line's parts: ``python -m e2vlib`` (:mod:`e2vlib.__main__`) runs them.

Every subcommand is a thin wrapper over library functions: it checks its arguments before
any work starts and before anything is written, then calls the library, and prints what it
made. How a command fails (:class:`UsageError`, exit 2; :class:`CommandError`, exit 1; the
one-line :class:`Parser`; :func:`run`, the loop that turns every error into one line on
stderr) lives below, in :mod:`e2vlib.experiments.errors`, which the lab's own commands
share. The code here is five modules, each with one job:

=============================  =============================================================
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

``checks`` imports no other module of this package; the three command modules import it;
``parser`` imports all four; none imports this ``__init__``. The library modules each
command needs are imported when it runs, so ``--help`` and argument errors stay quick to
answer (torch loads only through the tuples the parser's choices come from). ``figures``
stays in ``e2vlib.__main__``.
"""

