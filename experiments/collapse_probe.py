"""Watch the first epochs of one study run, step by step, to see how a run collapses.

A collapsed run (for example ``time``'s ``128px`` seed 1, ``encoder``'s ``cnn_gru`` seed 1)
keeps its best validation IoU from epoch 1 and predicts nearly the same grid for every
input. This script trains the run exactly as the study does (same protocol, seed, data,
initial weights and sample order) for a few epochs and records after every optimizer step:
the loss, the learning rate, the gradient norm, how many of the fully connected bridge's
units fire for any sample of the batch (a ReLU unit that fires for none gets no gradient and
stays dead), how much the bridge output differs between the samples of the batch, and the
mean predicted occupancy.

Usage::

    python experiments/collapse_probe.py STUDY CONFIG SEED [--epochs 3] [--recipe tiny_step]
        [--preset tiny_norm] [--loss bce_dice] [--head-scale 0.1]
        [--out experiments/records/collapse_probe.json]

Each (study, config, seed, recipe, epochs) is one record of the output file, written
atomically when the run ends; a record already there is skipped. Records carry the recipe's
fields as they were (``recipe_fields``): the records named ``tiny_step`` without
``head_prior`` were made before that recipe gained ``output_prior``, so they show warm-up
alone.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from e2vlib import experiments
from e2vlib.files import atomic_path
from e2vlib.model import build_e2v
from e2vlib.scale.training import fit_at_scale
from e2vlib.train import init_output_prior


def probe(study: str, config: str, seed: int, epochs: int, recipe: str | None,
          head_prior: bool = False, leaky_bridge: bool = False,
          preset: str | None = None, loss: str | None = None,
          head_scale: float | None = None, head_p: float | None = None) -> dict:
    """The per-step trace of the first ``epochs`` epochs of one study run (with another
    recipe or model preset when given)."""
    spec = experiments.STUDIES[study]
    changes = {"recipe": recipe, "preset": preset, "loss": loss}
    protocol = spec.protocol().updated(
        {**spec.configs[config], **{k: v for k, v in changes.items() if v is not None}})
    torch.set_num_threads(protocol.threads)
    train = experiments.load_split(protocol, "train")
    val = experiments.load_split(protocol, "val")
    model = build_e2v(protocol.preset, seed=seed, input_shape=tuple(train.frames.shape[-3:]))
    from e2vlib.train import get_recipe

    if head_prior and get_recipe(protocol["recipe"]).output_prior:
        raise SystemExit(f"recipe {protocol['recipe']} already starts at the labels' "
                         "occupancy (output_prior); drop --head-prior")
    occupancy = float(train.voxels.float().mean())
    if head_prior:  # start at the training labels' mean occupancy, not at p = 0.5 + features
        init_output_prior(model, occupancy)
    overrides = {}
    if head_scale is not None:  # the output prior with another scale of the head's weights
        overrides["output_prior"] = False
        init_output_prior(model, occupancy if head_p is None else head_p, head_scale)
    if leaky_bridge:
        model.bridge.fc[3] = torch.nn.LeakyReLU(0.01, inplace=True)
    seen: dict[str, torch.Tensor] = {}

    def keep(name):
        def hook(_module, _inputs, output):
            if model.training:
                seen[name] = output.detach()
        return hook

    # the bridge's seed volume after its ReLU (and its norm, where the preset has one)
    seed_out = getattr(model.bridge, "seed_norm", model.bridge.fc)
    seed_out.register_forward_hook(lambda m, i, out: keep("bridge")(m, i, out.flatten(1)))
    model.head.register_forward_hook(keep("logits"))
    steps: list[dict] = []

    def on_step(info: dict) -> None:
        grads = [p.grad.norm() for p in model.parameters() if p.grad is not None]
        bridge, logits = seen["bridge"], seen["logits"]
        steps.append({
            **info,
            "grad_norm": float(torch.linalg.vector_norm(torch.stack(grads))),
            "bridge_alive": float((bridge > 0).any(dim=0).float().mean()),
            "bridge_spread": float(bridge.std(dim=0).mean()),
            "mean_probability": float(torch.sigmoid(logits).mean()),
            "head_bias": float(model.head.bias.detach()[0]),
        })

    history: list[dict] = []

    def on_epoch(so_far: list[dict]) -> None:
        history[:] = [dict(h) for h in so_far]
        if len(so_far) >= epochs:  # the schedule is the full run's; stop watching here
            raise _Enough

    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        try:
            fit_at_scale(model, train, val, tmp, recipe=protocol.recipe,
                         epochs=protocol.run_epochs, seed=seed, loss=protocol.loss,
                         progress=False, on_step=on_step, on_epoch=on_epoch, **overrides)
        except _Enough:
            pass
    from dataclasses import asdict

    from e2vlib.train import get_recipe

    return {"study": study, "config": config, "seed": seed, "recipe": protocol.recipe,
            "recipe_fields": asdict(get_recipe(protocol.recipe)),
            "head_prior": head_prior, "leaky_bridge": leaky_bridge, "preset": protocol.preset,
            "loss": protocol.loss, "head_scale": head_scale,
            "head_p": head_p,
            "epochs_watched": epochs, "protocol": protocol.to_dict(),
            "history": history, "steps": steps,
            "seconds": round(time.perf_counter() - started, 1),
            "cpu": experiments.cpu_name(), "torch": torch.__version__}


class _Enough(Exception):
    pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("study")
    parser.add_argument("config")
    parser.add_argument("seed", type=int)
    parser.add_argument("--epochs", type=int, default=3)
    parser.add_argument("--recipe", default=None, help="another recipe than the study's")
    parser.add_argument("--head-prior", action="store_true",
                        help="start the output layer at the labels' mean occupancy")
    parser.add_argument("--leaky-bridge", action="store_true",
                        help="LeakyReLU(0.01) instead of ReLU after the bridge")
    parser.add_argument("--preset", default=None, help="another model preset than the study's")
    parser.add_argument("--loss", default=None, help="another loss than the study's")
    parser.add_argument("--head-scale", type=float, default=None,
                        help="start at the labels' occupancy with the head's weights scaled "
                             "by this (the recipe's output_prior scales them by 0.01)")
    parser.add_argument("--head-p", type=float, default=None,
                        help="with --head-scale: start at this probability instead of the "
                             "labels' occupancy")
    parser.add_argument("--out", default="experiments/records/collapse_probe.json")
    args = parser.parse_args()
    out = Path(args.out)
    records = json.loads(out.read_text()) if out.exists() else {}
    recipe = args.recipe or experiments.STUDIES[args.study].protocol().recipe
    key = (f"{args.study}/{args.config}/seed{args.seed}/{recipe}/{args.epochs}ep"
           + ("/head_prior" if args.head_prior else "")
           + ("/leaky_bridge" if args.leaky_bridge else "")
           + (f"/{args.preset}" if args.preset else "")
           + (f"/{args.loss}" if args.loss else "")
           + (f"/head_scale{args.head_scale:g}" if args.head_scale is not None else "")
           + (f"/head_p{args.head_p:g}" if args.head_p is not None else ""))
    if key in records:
        print(f"{key}: already recorded")
        return
    record = probe(args.study, args.config, args.seed, args.epochs, args.recipe,
                   args.head_prior, args.leaky_bridge, args.preset, args.loss,
                   args.head_scale, args.head_p)
    records[key] = record
    with atomic_path(out) as tmp:
        tmp.write_text(json.dumps(records, indent=1) + "\n")
    out.parent.mkdir(parents=True, exist_ok=True)
    last = record["steps"][-1]
    print(f"{key}: val IoU per epoch {[round(h['val_iou'], 3) for h in record['history']]}, "
          f"bridge units alive {last['bridge_alive']:.2f}, mean p {last['mean_probability']:.3f}"
          f" ({record['seconds']:.0f} s)")


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
