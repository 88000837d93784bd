"""The geometry study now lives in :mod:`e2vlib.experiments.geometry_study`; this name stays
importable (``from e2vlib.geometry_study import run_geometry_study``)."""

from e2vlib.experiments.geometry_study import (
    METHODS,
    QUESTION,
    add_checkpoints,
    run_geometry_study,
    summarize_geometry,
)

__all__ = ["METHODS", "QUESTION", "add_checkpoints", "run_geometry_study", "summarize_geometry"]
