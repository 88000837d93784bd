"""Size and memory of an E2V: parameters per part, stage-by-stage shapes, saved activations.

:func:`layer_table` and :func:`activation_bytes` profile a meta-device twin of the model (shapes
only, nothing allocated), so even the 150 M parameter paper preset is inspected in about a
second. Numbers are per training step: what autograd keeps for the backward pass.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

from e2vlib.model.encoders import Frames2dGRUEncoder, ResNetEncoder
from e2vlib.model.networks import E2V, count_parameters


def parameter_breakdown(model: E2V) -> dict[str, int]:
    """Parameters per part: ``encoder``, ``bridge``, ``decoder``, ``head`` (and ``total``).

    Examples
    --------
    >>> from e2vlib.model.networks import build_e2v
    >>> parts = parameter_breakdown(build_e2v("tiny"))
    >>> parts["total"] == sum(v for k, v in parts.items() if k != "total")
    True

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    parts = {name: count_parameters(getattr(model, name))
             for name in ("encoder", "bridge", "decoder", "head")}
    parts["total"] = sum(parts.values())
    return parts


def _stages(model: E2V) -> list[tuple[str, nn.Module]]:
    enc = model.encoder
    if isinstance(enc, ResNetEncoder):
        stages = [("encoder.stem", enc.stem)] + [
            (f"encoder.layer{i}", getattr(enc, f"layer{i}")) for i in range(1, 5)
        ]
    elif isinstance(enc, Frames2dGRUEncoder):
        stages = [("encoder.cnn", enc.net), ("encoder.gru", enc.gru)]
    else:
        stages = [("encoder", enc)]
    stages.append(("bridge", model.bridge))
    n = len(model.decoder.down)
    stages += [(f"decoder.down{i + 1}", b) for i, b in enumerate(model.decoder.down)]
    stages.append(("decoder.bottleneck", model.decoder.bottleneck))
    stages += [(f"decoder.up{n - i}", b) for i, b in enumerate(model.decoder.up)]
    stages.append(("head", model.head))
    return stages


def layer_table(model: E2V, batch_size: int = 1) -> list[dict[str, Any]]:
    """Stage-by-stage table of an E2V for a batch of ``batch_size`` inputs.

    One dict per stage, in forward order: ``name``, ``shape`` (output shape, batch axis
    included; the per-frame encoders' 2D stages see ``batch_size * n_frames`` frames),
    ``params`` and ``saved_bytes`` (bytes of the activations autograd keeps inside that
    stage for the backward pass of a training step, weights excluded). Runs on a
    meta-device copy built from ``model.config``, so it allocates nothing and takes about
    a second even for the paper preset, whatever device ``model`` lives on.

    Examples
    --------
    >>> from e2vlib.model.networks import build_e2v
    >>> rows = layer_table(build_e2v("tiny", input_shape=(16, 32, 32)))
    >>> [row["name"] for row in rows][:3], len(rows)
    (['encoder.stem', 'encoder.layer1', 'encoder.layer2'], 14)
    >>> rows[-1]  # the head: 4 weights + 1 bias; it keeps its 4 x 32^3 float32 input
    {'name': 'head', 'shape': (1, 1, 32, 32, 32), 'params': 5, 'saved_bytes': 524288}

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    rows, _ = _profile(model, batch_size)
    return rows


def activation_bytes(model: E2V, batch_size: int = 1) -> int:
    """Bytes autograd saves for the backward pass in one training-mode forward pass.

    Measured, not guessed: every tensor the forward pass stores for backward is counted
    once per storage (views and in-place results are not double counted), on a meta-device
    copy; the weights themselves are left out. The result already includes ``batch_size``.
    Weights, their gradients and optimizer state come on top.

    Examples
    --------
    >>> from e2vlib.model.networks import build_e2v
    >>> model = build_e2v("tiny", input_shape=(16, 32, 32))
    >>> one = activation_bytes(model)
    >>> one, activation_bytes(model, batch_size=2) == 2 * one
    (4390656, True)
    >>> one == sum(row["saved_bytes"] for row in layer_table(model))
    True

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    _, total = _profile(model, batch_size)
    return total


def _profile(model: E2V, batch_size: int) -> tuple[list[dict[str, Any]], int]:
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    with torch.device("meta"):
        twin = E2V(model.config)
    # Eval mode: BatchNorm then saves the same input for backward as in training, but also
    # works for one sample whose deepest feature map is 1x1x1 (train-mode BN refuses that).
    twin.eval()
    rows: dict[str, dict[str, Any]] = {}
    current = ["input"]
    saved: dict[int, tuple[str, int]] = {}
    handles = []
    for name, stage in _stages(twin):
        rows[name] = {"name": name, "shape": None, "params": count_parameters(stage),
                      "saved_bytes": 0}

        def pre_hook(_m: nn.Module, _i: Any, name: str = name) -> None:
            current[0] = name

        def post_hook(_m: nn.Module, _i: Any, out: Any, name: str = name) -> None:
            if isinstance(out, tuple):  # a GRU returns (outputs, final state)
                out = out[0]
            rows[name]["shape"] = tuple(out.shape)

        handles.append(stage.register_forward_pre_hook(pre_hook))
        handles.append(stage.register_forward_hook(post_hook))

    # Meta tensors have no addresses; the storage object's C++ handle identifies a storage
    # while the graph keeps it alive (views and in-place outputs share it). Weights that
    # autograd keeps a reference to are not activations, nor are per-channel statistics
    # (1-D): count only saved tensors with a batch axis.
    weights = {p.untyped_storage()._cdata for p in twin.parameters()}

    def pack(t: torch.Tensor) -> torch.Tensor:
        key = t.untyped_storage()._cdata
        if t.ndim >= 2 and key not in saved and key not in weights:
            saved[key] = (current[0], t.untyped_storage().nbytes())
        return t

    try:
        with torch.autograd.graph.saved_tensors_hooks(pack, lambda t: t):
            out = twin(torch.empty(batch_size, *twin.sample_shape, device="meta"))
    finally:
        for handle in handles:
            handle.remove()
    del out
    for stage_name, nbytes in saved.values():
        if stage_name in rows:
            rows[stage_name]["saved_bytes"] += nbytes
    return list(rows.values()), sum(nbytes for _, nbytes in saved.values())


def format_layer_table(rows: list[dict[str, Any]]) -> str:
    """Render :func:`layer_table` rows as a fixed-width text table with a total line.

    Examples
    --------
    >>> rows = [{"name": "stem", "shape": (1, 8, 4, 8, 8), "params": 232,
    ...          "saved_bytes": 2**20}, {"name": "head", "shape": (1, 1, 32, 32, 32),
    ...          "params": 5, "saved_bytes": 2**19}]
    >>> print(format_layer_table(rows))
    stage                output shape                        params  saved MiB
    stem                 (1, 8, 4, 8, 8)                        232        1.0
    head                 (1, 1, 32, 32, 32)                       5        0.5
    total                                                       237        1.5

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """
    lines = [f"{'stage':<20} {'output shape':<28} {'params':>13} {'saved MiB':>10}"]
    for r in rows:
        lines.append(f"{r['name']:<20} {str(r['shape']):<28} {r['params']:>13,} "
                     f"{r['saved_bytes'] / 2**20:>10.1f}")
    total_p = sum(r["params"] for r in rows)
    total_b = sum(r["saved_bytes"] for r in rows)
    lines.append(f"{'total':<20} {'':<28} {total_p:>13,} {total_b / 2**20:>10.1f}")
    return "\n".join(lines)
