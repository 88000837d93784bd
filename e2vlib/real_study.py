"""The real-mesh study now lives in :mod:`e2vlib.experiments.real_study`; this name stays
importable, and ``python -m e2vlib.real_study`` still runs it."""

import sys

from e2vlib.experiments.real_study import (
    BASELINES,
    COMMAND,
    DEFAULT_CHECKPOINTS,
    QUESTION,
    format_real_table,
    main,
    run_real_study,
    summarize_real,
)

__all__ = ["BASELINES", "COMMAND", "DEFAULT_CHECKPOINTS", "QUESTION", "format_real_table",
           "main", "run_real_study", "summarize_real"]

if __name__ == "__main__":
    sys.exit(main())
