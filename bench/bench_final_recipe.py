"""Speed of the final recipe (lesson 13): the capstone's best 30-epoch config on 2 cores.

1. The recorded runs of the capstone's ``bce_dice_30_epochs`` config
   (``experiments/results/capstone.json``): training minutes per run (30 epochs, validation
   included) and the CPU they ran on.
2. One training step of the final recipe's model (preset ``tiny_norm``, BCE + Dice, batch 16,
   data_small's frames) with each of ``fit_at_scale``'s speed options, and the 30-epoch time each
   would give, scaled from the recorded fp32 runs by the step-time ratio.
3. A ``torch.profiler`` profile of the fp32 step: each kind of operator's share of the CPU
   time, and the operators that take the most.

Run it on an idle machine: ``python bench/bench_final_recipe.py``; writes the "Final recipe"
section of bench/RESULTS.md.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_training import SPEED_OPTIONS, training_rate, training_step  # noqa: E402
from common import machine, spread, write_section  # noqa: E402

from e2vlib.scale.training import bf16_is_fast  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CONFIG = "bce_dice_30_epochs"
TARGET_MINUTES = 15
PROFILED_STEPS = 4
OPERATOR_KINDS = {  # kind -> substrings of aten operator names, first match wins
    "convolution backward": ("convolution_backward",),
    "convolution forward": ("convolution", "conv3d", "conv_transpose"),
    "batch norm": ("batch_norm",),
    "pooling": ("pool",),
    "optimizer (AdamW)": ("_foreach", "addcdiv", "addcmul", "lerp", "sqrt"),
    "linear (bridge)": ("addmm", "aten::mm", "linear"),
    "memory (copies, fills)": ("copy_", "fill_", "zero_", "empty", "clone", "cat"),
}


def operator_kind(name: str) -> str:
    """The kind of an aten operator name (:data:`OPERATOR_KINDS`), else "element-wise and
    other"."""
    for kind, parts in OPERATOR_KINDS.items():
        if any(part in name for part in parts):
            return kind
    return "element-wise and other"


def profile_step(**options) -> tuple[dict[str, float], list[tuple[str, float]]]:
    """Profile :data:`PROFILED_STEPS` training steps: (share of self CPU time per operator
    kind, and the 6 operators with the most self CPU time with their shares)."""
    from torch.profiler import ProfilerActivity, profile

    step = training_step(**options)
    step()
    step()  # warm up: first-call allocations and kernel choices
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for _ in range(PROFILED_STEPS):
            step()
    events = [e for e in prof.key_averages() if e.key.startswith("aten::")]
    total = sum(e.self_cpu_time_total for e in events)
    kinds: dict[str, float] = {}
    for e in events:
        kind = operator_kind(e.key)
        kinds[kind] = kinds.get(kind, 0.0) + e.self_cpu_time_total / total
    top = sorted(events, key=lambda e: e.self_cpu_time_total, reverse=True)[:6]
    return (dict(sorted(kinds.items(), key=lambda kv: -kv[1])),
            [(e.key, e.self_cpu_time_total / total) for e in top])


TIMED_STEPS = 20  # six steps left the fp32 median within a 2.4x spread


def main() -> str:
    results = json.loads((ROOT / "experiments" / "results" / "capstone.json").read_text())
    runs = [r for r in results["runs"] if r["config"] == CONFIG]
    if not runs:
        raise SystemExit(f"no recorded {CONFIG} run in experiments/results/capstone.json")
    minutes = np.array([r["train_seconds"] / 60 for r in runs])
    cpus = sorted({r["cpu"] for r in runs})
    params = {**results["protocol"], **runs[0]["params"]}
    lines = [f"Command: `python bench/bench_final_recipe.py`. Machine: {machine()}, torch "
             f"threads {torch.get_num_threads()}.", "",
             f"The final recipe is the capstone's `{CONFIG}` config: preset "
             f"`{params['preset']}`, recipe `{params['recipe']}`, loss `{params['loss']}`, "
             f"{params['epochs']} epochs on data_small's 676 training samples at "
             f"{params['frame_size']} px.", "",
             f"- **Recorded runs** ({len(runs)} seeds, `python -m e2vlib experiment capstone "
             f"--configs {CONFIG}`, on {', '.join(cpus)}): **{minutes.mean():.1f} min** of "
             f"training per run ({minutes.min():.1f}-{minutes.max():.1f}), validation "
             f"included; target at most {TARGET_MINUTES} min in fp32.", "",
             "One training step of its model with each of `fit_at_scale`'s speed options:",
             "", "| option (`fit_at_scale(...)`) | step (batch 16) | gain | 30 epochs, scaled "
             "from the recorded runs |", "| --- | --- | --- | --- |"]
    base = None
    for name, options in SPEED_OPTIONS.items():
        if options.get("precision") == "bf16" and not bf16_is_fast("cpu"):
            lines.append(f"| {name} | skipped: no native bfloat16 on this CPU | | |")
            continue
        rate = training_rate(steps=TIMED_STEPS, **options, preset=params["preset"],
                             loss=params["loss"])
        base = base or rate["median"]
        gain = base / rate["median"]
        lines.append(f"| {name} `{options}` | {spread(rate)} | {gain:.2f}x | "
                     f"{minutes.mean() / gain:.1f} min |")
    kinds, top = profile_step(preset=params["preset"], loss=params["loss"])
    lines += ["", f"Where the fp32 step's time goes (`torch.profiler`, {PROFILED_STEPS} steps "
              "after 2 warm-up steps; share of the self CPU time of all aten operators):", "",
              "| operator kind | share |", "| --- | --- |"]
    lines += [f"| {kind} | {share:.0%} |" for kind, share in kinds.items()]
    lines += ["", "Largest single operators: "
              + ", ".join(f"`{name}` {share:.0%}" for name, share in top) + "."]
    body = "\n".join(lines) + "\n"
    write_section("Final recipe", body)
    return body


if __name__ == "__main__":
    print(main())
