"""Fill the caches a first test run would otherwise fill: `make venv` runs this once.

The first `make test` after an install paid for work that every later run finds on disk:
matplotlib's font cache, numba's compiled frame kernels (``cache=True``, in
``e2vlib/scale/__pycache__``) and the library's bytecode. Run: ``python tools/warm_caches.py``.
"""

from __future__ import annotations

import compileall
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def warm() -> dict[str, float]:
    """Fill each cache; return the seconds each took."""
    seconds = {}
    started = time.perf_counter()
    compileall.compile_dir(REPO / "e2vlib", quiet=1)
    seconds["bytecode"] = time.perf_counter() - started

    started = time.perf_counter()
    import matplotlib.font_manager  # noqa: F401  (builds the font cache on first import)

    seconds["matplotlib fonts"] = time.perf_counter() - started

    started = time.perf_counter()
    from e2vlib.events import make_events
    from e2vlib.scale.frames_numba import accumulate_fast

    events = make_events([0, 1], [0, 1], [0, 10], [1, -1])
    for mode in ("binary", "count", "polarity"):
        for windows in ("fixed", "paper"):
            accumulate_fast(events, (2, 2), 5, mode=mode, windows=windows)
    seconds["numba kernels"] = time.perf_counter() - started
    return seconds


if __name__ == "__main__":
    for name, spent in warm().items():
        print(f"{name}: {spent:.1f} s")
