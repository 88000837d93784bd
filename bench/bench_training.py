"""Training throughput of the tiny preset, the paper preset at full input, and the target.

1. Training samples/s of ``tiny`` on data_small (batch 16, AdamW, real frames).
2. Forward time and peak memory of the ``paper`` preset at its full input 100 x 256 x 256,
   batch 1, in a child process (peak RSS measured there); skipped with a message when the
   machine has less than 16 GiB of memory.
3. The committed checkpoint ``data_small/checkpoints/first_recipe.pt``: its training time and
   test results against the mean-shape baselines and the paper's 0.346.
Run: ``python bench/bench_training.py``; writes the "Training" section.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import psutil
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import machine, spread, timeit, write_section  # noqa: E402

from e2vlib.data import E2VDataset  # noqa: E402
from e2vlib.inputs import preload
from e2vlib.model import build_e2v, load_checkpoint, read_checkpoint  # noqa: E402
from e2vlib.scale.training import ScaleHooks, bf16_is_fast  # noqa: E402
from e2vlib.train import evaluate, train_step  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data_small"
CHECKPOINT = DATA / "checkpoints" / "first_recipe.pt"
PAPER_IOU = 0.346

PAPER_CHILD = """
import resource, time, torch
from e2vlib.model import build_e2v
torch.set_num_threads({threads})
model = build_e2v("paper", seed=0).eval()
x = (torch.rand(1, 100, 256, 256) < 0.05).float()
with torch.no_grad():
    model(x)
    start = time.perf_counter()
    model(x)
    seconds = time.perf_counter() - start
print(seconds, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)
"""


SPEED_OPTIONS = {
    "fp32 (default)": {},
    "channels-last": {"channels_last": True},
    "bf16 autocast": {"precision": "bf16"},
    "bf16 + channels-last": {"precision": "bf16", "channels_last": True},
}
"""``fit_at_scale`` options whose training step is timed (``fit_at_scale(..., **options)``)."""


def training_step(batch: int = 16, precision: str = "fp32", channels_last: bool = False,
                  compiled: bool = False, preset: str = "tiny", loss: str = "bce"):
    """One training step of ``preset`` with ``loss`` on a batch of data_small's real frames,
    as ``fit_at_scale`` runs it (``train_step`` with its hooks), as a function of no
    arguments."""
    from e2vlib.losses import make_loss

    data = preload(E2VDataset(DATA, "train"))
    model = build_e2v(preset, seed=0).train()
    optimizer = torch.optim.AdamW(model.parameters(), lr=1e-3)
    hooks = ScaleHooks(precision=precision, channels_last=channels_last)
    net, _, _ = hooks.start(model, optimizer, DATA, None)  # channels-last weights, no resume
    net = torch.compile(net) if compiled else net
    loss_fn = make_loss(loss)
    x = data.frames[:batch].float()
    y = data.voxels[:batch].float()
    return lambda: train_step(net, optimizer, loss_fn, x, y, hooks)


def training_rate(batch: int = 16, steps: int = 6, **options) -> dict:
    """Seconds per training step (median, min, max of ``steps``); ``options`` as
    :func:`training_step`."""
    return timeit(training_step(batch, **options), repeat=steps, warmup=2)


def speed_table(threads: int, **model) -> list[str]:
    """Markdown rows: each training option's step time and gain over fp32 (``model``:
    ``preset`` and ``loss`` of :func:`training_rate`)."""
    rows = ["| option (`fit_at_scale(...)`) | step (batch 16) | samples/s | gain |",
            "| --- | --- | --- | --- |"]
    base = None
    for name, options in SPEED_OPTIONS.items():
        if options.get("precision") == "bf16" and not bf16_is_fast("cpu"):
            rows.append(f"| {name} | skipped: no native bfloat16 on this CPU | | |")
            continue
        rate = training_rate(**options, **model)
        base = base or rate["median"]
        rows.append(f"| {name} `{options}` | {spread(rate)} | {16 / rate['median']:.0f} | "
                    f"{base / rate['median']:.2f}x |")
    torch.set_num_threads(1)
    one = training_rate(**model)
    torch.set_num_threads(threads)
    rows.append(f"| fp32, 1 thread instead of {threads} | {spread(one)} | "
                f"{16 / one['median']:.0f} | {base / one['median']:.2f}x |")
    return rows


def paper_forward(threads: int) -> tuple[float, float] | str:
    total = psutil.virtual_memory().total
    if total < 16 * 2**30:
        return f"skipped: {total / 2**30:.0f} GiB of memory, 16 GiB wanted"
    code = PAPER_CHILD.format(threads=threads)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    seconds, peak = out.stdout.split()
    return float(seconds), float(peak)


def main() -> str:
    threads = torch.get_num_threads()
    rate = training_rate()
    lines = [f"Command: `python bench/bench_training.py`. Machine: {machine()}, "
             f"torch threads {threads}.", ""]
    lines.append(f"- **tiny training step** (batch 16, 100 x 64 x 64, AdamW): "
                 f"{spread(rate)} per step = **{16 / rate['median']:.0f} samples/s**.")
    lines += ["", "Faster CPU training: the same step with each of `fit_at_scale`'s speed options.",
              "", *speed_table(threads), "",
              "`torch.compile` is not among them: compiling the tiny model's training step "
              "had not finished after 25 minutes on these 2 cores (measured while other jobs "
              "ran), which no gain on a 10-minute recipe could repay.", ""]
    paper = paper_forward(threads)
    if isinstance(paper, str):
        lines.append(f"- **paper preset forward** (1 x 100 x 256 x 256): {paper}.")
    else:
        lines.append(f"- **paper preset forward** (1 x 100 x 256 x 256, CPU, no grad): "
                     f"{paper[0]:.1f} s, peak memory of the process {paper[1] / 2**30:.1f} GiB.")
    if torch.cuda.is_available():
        lines.append("- a GPU is present: see the GPU section for its numbers.")
    else:
        lines.append("- no GPU on this machine; GPU numbers are recorded when one is lent.")
    if CHECKPOINT.exists():
        ckpt = read_checkpoint(CHECKPOINT)
        history = ckpt["history"]
        minutes = sum(h["seconds"] for h in history) / 60
        best = max(history, key=lambda h: h["val_iou"])
        result = evaluate(load_checkpoint(CHECKPOINT), E2VDataset(DATA, "test"),
                          train_data=E2VDataset(DATA, "train"), progress=False)
        ours = result["overall"]["iou@0.3"]
        mean = result["baseline_mean_shape"]["iou@0.3"]
        oracle = result["baseline_category_mean"]["iou@0.3"]
        lines += ["", f"**Target** (committed `data_small/checkpoints/first_recipe.pt`, recipe "
                  f"{json.dumps(ckpt.get('recipe', {}))}): {len(history)} epochs in "
                  f"{minutes:.1f} min of training (sum of the epoch wall times recorded in its "
                  f"history, validation included; that run shared the cores with other jobs, "
                  f"see \"Tiny recipe from scratch\" for a timed run on an idle machine), "
                  f"best validation IoU@0.3 {best['val_iou']:.3f} at epoch {best['epoch']}.",
                  "",
                  "| test split (78 samples) | IoU@0.2 | IoU@0.3 | IoU@0.4 | IoU@0.5 | F@1% "
                  "| F@20% |", "| --- | --- | --- | --- | --- | --- | --- |"]
        for name, row in (("tiny E2V", result["overall"]),
                          ("mean shape", result["baseline_mean_shape"]),
                          ("category mean (oracle)", result["baseline_category_mean"])):
            lines.append(f"| {name} | " + " | ".join(
                f"{row[k]:.3f}" for k in ("iou@0.2", "iou@0.3", "iou@0.4", "iou@0.5",
                                          "fscore@1%", "fscore@20%")) + " |")
        lines += ["", f"Test mIoU@0.3 is **{ours - mean:+.3f}** against the mean shape "
                  f"(target: at least +0.10), {ours - oracle:+.3f} against the per-category "
                  f"oracle, and {ours - PAPER_IOU:+.3f} against the paper's {PAPER_IOU} "
                  "(a different dataset: ShapeNet objects, 256 px frames, ResNet-152)."]
    body = "\n".join(lines)
    write_section("Training", body)
    return body


if __name__ == "__main__":
    print(main())
