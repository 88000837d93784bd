"""Old home of :mod:`e2vlib.data.checks` (a dataset folder is untrusted input); its names
live there now.

Kept so that ``from e2vlib.dataset_checks import read_config`` keeps working.
"""

from e2vlib.data.checks import (
    MANIFEST_REQUIRED,
    MAX_CONFIG_BYTES,
    MAX_FRAMES_PER_SAMPLE,
    MAX_ID_LENGTH,
    MAX_MANIFEST_BYTES,
    SPLITS,
    WINDOWS,
    DatasetError,
    check_id,
    inside,
    npz_problem,
    read_config,
    read_manifest_rows,
    rebuild_hint,
)

__all__ = [
    "MANIFEST_REQUIRED",
    "MAX_CONFIG_BYTES",
    "MAX_FRAMES_PER_SAMPLE",
    "MAX_ID_LENGTH",
    "MAX_MANIFEST_BYTES",
    "SPLITS",
    "WINDOWS",
    "DatasetError",
    "check_id",
    "inside",
    "npz_problem",
    "read_config",
    "read_manifest_rows",
    "rebuild_hint",
]
