"""The default tiny recipe from scratch: wall time to train and what it reaches.

Trains ``build_e2v("tiny", seed=0)`` on data_small with ``fit``'s defaults (the ``tiny``
recipe) in a temporary folder, then evaluates ``best.pt`` on the test split against the
mean-shape baselines. Takes about 10-15 minutes on 2 idle cores; run it on an idle machine
(other processes slow torch's threads down a lot). Run: ``python bench/bench_recipe.py``;
writes the "Tiny recipe from scratch" section.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, write_section  # noqa: E402

from e2vlib.data import E2VDataset  # noqa: E402
from e2vlib.model import build_e2v, load_checkpoint  # noqa: E402
from e2vlib.train import RECIPES, bf16_is_fast, evaluate, fit  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "data_small"


FAST = {"channels_last": True}
"""The fastest ``fit`` option on 2 CPU cores in bench_training's table (bf16 autocast on top
of it was slower there)."""


def train_once(train, val, test, **options) -> tuple[list[dict], float, dict]:
    """History, wall minutes and test results of the tiny recipe from seed 0."""
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        history = fit(build_e2v("tiny", seed=0), train, val, out, progress=False, **options)
        minutes = (time.perf_counter() - start) / 60
        result = evaluate(load_checkpoint(Path(out) / "best.pt"), test, train_data=train,
                          fscore_points=2048, progress=False)
    return history, minutes, result


def fast_line(train, val, test, minutes: float, ours: float) -> str:
    """The same recipe with :data:`FAST`, against the default run."""
    if FAST.get("precision") == "bf16" and not bf16_is_fast("cpu"):
        return "- fast options: skipped, this CPU has no native bfloat16."
    history, fast_minutes, result = train_once(train, val, test, **FAST)
    fast = result["overall"]["iou@0.3"]
    return (f"- **with `fit(..., {', '.join(f'{k}={v!r}' for k, v in FAST.items())})`** "
            f"(CLI: `train --channels-last`): **{fast_minutes:.1f} min**, "
            f"{minutes / fast_minutes:.2f}x faster; test IoU@0.3 {fast:.3f} ({fast - ours:+.3f} "
            f"against fp32; one seed each, and 12-epoch runs of one config spread by a "
            f"standard deviation of 0.02-0.04 across seeds).")


def main() -> str:
    train, val, test = (E2VDataset(DATA, s) for s in ("train", "val", "test"))
    history, minutes, result = train_once(train, val, test)
    best = max(history, key=lambda h: h["val_iou"])
    first_past = next((h for h in history if h["val_iou"] >= 0.25), None)
    ours = result["overall"]["iou@0.3"]
    mean = result["baseline_mean_shape"]["iou@0.3"]
    oracle = result["baseline_category_mean"]["iou@0.3"]
    epoch_s = [round(h["seconds"]) for h in history]
    body = f"""Command: `python bench/bench_recipe.py`. Machine: {machine()}.

`fit` with its defaults (recipe `tiny`: {RECIPES['tiny']}) on data_small's {len(train)}
training samples, from `build_e2v("tiny", seed=0)`:

- **{minutes:.1f} min** wall time for {len(history)} epochs (validation and checkpoint writing
  included); seconds per epoch: {epoch_s}.
- best validation IoU@0.3 {best['val_iou']:.3f} (epoch {best['epoch']}); validation IoU@0.3 first
  reached 0.25 at epoch {first_past['epoch'] if first_past else 'never'}.
- test IoU@0.3 of `best.pt`: **{ours:.3f}**, against {mean:.3f} for the mean shape
  ({ours - mean:+.3f}; target +0.10) and {oracle:.3f} for the per-category mean oracle
  ({ours - oracle:+.3f}); the paper reports 0.346 on its own dataset.
{fast_line(train, val, test, minutes, ours)}
"""
    write_section("Tiny recipe from scratch", body)
    return body


if __name__ == "__main__":
    print(main())
