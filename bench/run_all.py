"""Run every benchmark in bench/ and rewrite bench/RESULTS.md: `make bench`.

Each script replaces its own section; run one alone with `python bench/bench_<name>.py`.
"""

from __future__ import annotations

import runpy
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCRIPTS = ["bench_frames.py", "bench_simulate.py", "bench_dataset.py", "bench_model.py",
           "bench_training.py", "bench_recipe.py", "bench_final_recipe.py",
           "bench_notebooks.py", "bench_tests.py", "bench_lifting.py"]

if __name__ == "__main__":
    only = sys.argv[1:]
    for name in SCRIPTS:
        if only and not any(o in name for o in only):
            continue
        start = time.perf_counter()
        print(f"== {name}", flush=True)
        runpy.run_path(str(HERE / name), run_name="__main__")
        print(f"== {name} done in {time.perf_counter() - start:.0f} s", flush=True)
