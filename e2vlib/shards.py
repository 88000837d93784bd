"""Old home of :mod:`e2vlib.data.shards` (joining sharded builds); its names live there now.

Kept so that ``from e2vlib.shards import merge_datasets`` keeps working.
"""

from e2vlib.data.shards import MergeError, MergeReport, merge_datasets

__all__ = ["MergeError", "MergeReport", "merge_datasets"]
