"""Lifting event frames through the known orbit (lesson 15), and what it adds to training.

On one thread: making the lifting table once (``geometry.lifting_table``, 100 frames of
64 x 64 px onto the 32^3 grid), lifting one stack with the numpy function the lesson reads
(``geometry.lift_frames``) and with the model's torch module (``model.lifting.Lifting``, a
batch of 8), and a training step (forward, loss, backward, AdamW step; batch 8) of E2V's
``tiny_norm`` beside ``hybrid_early`` and ``lifted_unet``, on the torch threads a study uses
(2). Frames: data_small's first 8 test samples. Run: ``python bench/bench_lifting.py`` on a
quiet machine; writes the "Lifting" section of bench/RESULTS.md.
"""

from __future__ import annotations

import sys
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, spread, timeit, write_section  # noqa: E402

from e2vlib import geometry, paper  # noqa: E402
from e2vlib.data import E2VDataset  # noqa: E402
from e2vlib.losses import bce_dice  # noqa: E402
from e2vlib.model import build_e2v  # noqa: E402
from e2vlib.model.lifting import Lifting  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BATCH = 8


def main() -> str:
    data = E2VDataset(ROOT / "data_small", "test")
    frames = torch.stack([data[i]["frames"] for i in range(BATCH)])  # (8, 100, 64, 64)
    voxels = torch.stack([data[i]["voxels"] for i in range(BATCH)])
    n, size = paper.N_EVENT_FRAMES, frames.shape[-1]
    torch.set_num_threads(1)
    table_time = timeit(lambda: geometry.lifting_table(n, paper.DT_US, size), repeat=3)
    table = geometry.lifting_table(n, paper.DT_US, size)
    one = frames[0].numpy().astype(bool)
    numpy_time = timeit(lambda: geometry.lift_frames(one, table), repeat=20)
    module = Lifting(n, size, paper.DT_US)
    with torch.no_grad():
        torch_time = timeit(lambda: module(frames), repeat=10)
    rows = [f"| make the lifting table (once per orbit) | {spread(table_time, 1e3, 'ms')} |",
            f"| `geometry.lift_frames`, one stack | {spread(numpy_time, 1e3, 'ms')} |",
            f"| `Lifting` (torch), a batch of {BATCH} | {spread(torch_time, 1e3, 'ms')} "
            f"({torch_time['median'] / BATCH * 1e3:.1f} ms a stack) |"]
    torch.set_num_threads(2)
    steps = []
    for preset in ("tiny_norm", "hybrid_early", "lifted_unet"):
        model = build_e2v(preset, seed=0)
        optimizer = torch.optim.AdamW(model.parameters(), lr=2e-3)

        def step(model=model, optimizer=optimizer):
            optimizer.zero_grad()
            bce_dice(model(frames), voxels).backward()
            optimizer.step()

        steps.append((preset, timeit(step, repeat=5)))
    base = steps[0][1]["median"]
    rows += [f"| training step, `{preset}`, batch {BATCH}, 2 threads | {spread(t)} "
             f"({t['median'] / base:.2f}x `tiny_norm`) |" for preset, t in steps]
    body = "\n".join([
        "Command: `python bench/bench_lifting.py`.",
        f"Machine: {machine()}.",
        "",
        "The look-ups on one thread; the training steps on the 2 threads a study uses.",
        "",
        "| what | time (median, range, runs) |",
        "| --- | --- |",
        *rows,
    ])
    write_section("Lifting", body)
    return body


if __name__ == "__main__":
    print(main())
