"""Fill the caches a first test run would otherwise fill: `make venv` runs this once.

The first `make test` after an install paid for work that every later run finds on disk:
matplotlib's font cache, numba's compiled frame kernels (``cache=True``, in
``e2vlib/scale/__pycache__``), the library's bytecode and the quick-mode mini datasets that
lessons 09-15 build (kept by ``e2vlib.experiments.build_cache``, named by the library's source,
so an edited library builds afresh). Run: ``python tools/warm_caches.py``.
"""

from __future__ import annotations

import compileall
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LESSON_BUILDS = {"clean": {}, "grey video": {"grey_video": True}, "noise": {"noise": "medium"}}
"""The options of each distinct ``build_mini_dataset`` call of lessons 09-15 (quick mode)."""


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

    started = time.perf_counter()
    from e2vlib.experiments.build_cache import cache_root
    from e2vlib.experiments.classroom import build_mini_dataset

    if cache_root() is not None:
        try:
            with tempfile.TemporaryDirectory() as tmp:
                for name, options in LESSON_BUILDS.items():
                    build_mini_dataset(Path(tmp) / name, quick=True, progress=False, **options)
        except Exception as error:  # a speed-up only: make test will say what is wrong
            print(f"the lessons' quick datasets were not built ahead ({error})", file=sys.stderr)
    seconds["lessons' quick datasets"] = time.perf_counter() - started
    return seconds


if __name__ == "__main__":
    for name, spent in warm().items():
        print(f"{name}: {spent:.1f} s")
