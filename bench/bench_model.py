"""The E2V model on CPU: forward and forward+backward time per sample.

- the ``tiny`` and ``tiny2d`` presets at their data_small input (100 x 64 x 64), batch 8;
- the ``paper`` preset (3D ResNet-152, 149.8 M parameters) on a reduced input of
  20 x 128 x 128 (its reshape bridge then gives C = 1 hidden channel), batch 1, to check
  that the full-depth network runs end to end on a CPU and what a step costs.

Inputs are random binary frames with 5 % ones (about data_small's density). Threads:
``torch.set_num_threads(2)``, the 2-core laptop the lessons target. Run:
``python bench/bench_model.py`` (about a minute on an idle machine); writes the "Model" section of
bench/RESULTS.md.
"""

from __future__ import annotations

import os
import sys
import time

import torch

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent))
from common import machine, spread, timeit, write_section  # noqa: E402

from e2vlib.model import activation_bytes, build_e2v, count_parameters  # noqa: E402

THREADS = 2
CASES = [
    # preset, overrides, batch, repeats
    ("tiny", {}, 8, 7),
    ("tiny2d", {}, 8, 3),
    ("paper", {"input_shape": (20, 128, 128)}, 1, 2),
]


def bench_case(preset: str, overrides: dict, batch: int, repeat: int) -> dict:
    model = build_e2v(preset, seed=0, **overrides)
    gen = torch.Generator().manual_seed(0)
    x = (torch.rand(batch, *model.input_shape, generator=gen) < 0.05).float()
    y = (torch.rand(batch, 32, 32, 32, generator=gen) < 0.1).float()
    loss_fn = torch.nn.BCEWithLogitsLoss()

    outputs = []

    def forward() -> None:
        with torch.no_grad():
            outputs.append(model(x))

    def forward_backward() -> None:
        model.zero_grad(set_to_none=True)
        loss_fn(model(x), y).backward()

    model.eval()
    fwd = timeit(forward, repeat=repeat)
    model.train()
    fwd_bwd = timeit(forward_backward, repeat=repeat)
    out = outputs[-1]
    assert out.shape == (batch, 32, 32, 32) and torch.isfinite(out).all()
    return {"model": model, "batch": batch, "fwd": fwd, "fwd_bwd": fwd_bwd}


def main() -> str:
    torch.set_num_threads(THREADS)
    load_start = os.getloadavg()[0]
    started = time.perf_counter()
    lines = [
        "| preset | input (D, H, W) | parameters | batch | forward per sample | "
        "forward+backward per sample | activations saved per sample |",
        "|---|---|---|---|---|---|---|",
    ]
    for preset, overrides, batch, repeat in CASES:
        r = bench_case(preset, overrides, batch, repeat)
        model = r["model"]
        per = 1000.0 / batch
        act = activation_bytes(model) / 2**20
        lines.append(
            f"| {preset} | {model.input_shape} | {count_parameters(model):,} | {batch} | "
            f"{spread(r['fwd'], per, 'ms')} | {spread(r['fwd_bwd'], per, 'ms')} | "
            f"{act:.1f} MiB |"
        )
        print(lines[-1], flush=True)
    elapsed = time.perf_counter() - started
    with torch.device("meta"):
        paper_act = activation_bytes(build_e2v("paper")) / 2**30
    body = "\n".join([
        f"Machine: {machine()}; torch threads: {THREADS}.",
        "Command: `.venv/bin/python bench/bench_model.py` (times per sample: median "
        "(min-max, n runs) of whole-batch calls after one warm-up, divided by the batch "
        "size; input: random binary frames with 5 % ones; forward in eval mode without "
        "gradients, forward+backward in train mode with BCE loss, no optimizer step).",
        "",
        *lines,
        "",
        "The paper preset runs on a reduced input (20 x 128 x 128: its reshape bridge then "
        "has C = 1 hidden channel instead of 16, so the decoder's first and last layers are "
        "a little smaller than the 149,806,449-parameter original); at the paper's "
        f"100 x 256 x 256 a training step keeps {paper_act:.2f} GiB of activations per "
        "sample (`e2vlib.model.activation_bytes`, measured on the meta device). "
        "Activations: tensors autograd saves for the backward pass, weights excluded.",
        "",
        f"Total run time {elapsed:.0f} s. Load average (1 min) at the start: "
        f"{load_start:.1f}, at the end: {os.getloadavg()[0]:.1f} (other jobs share the "
        "2 cores when it exceeds about 1).",
    ])
    write_section("Model", body)
    return body


if __name__ == "__main__":
    print(main())
