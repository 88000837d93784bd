"""Is a checkpoint intact: the SHA-256 digest of its weights, and weights that are finite.

:func:`weights_digest` hashes a state dict (names, dtypes, shapes, bytes; independent of
order and device); :func:`verify_weights` compares it with the digest stored in a
checkpoint (:data:`DIGEST_KEY`) and refuses NaN or inf weights, raising
:class:`CheckpointError` with the first bad parameter. :mod:`e2vlib.model.checkpoint`
runs it on every read.

Introduced in notebooks/05_the_e2v_model.ipynb.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from typing import Any

import torch

from e2vlib.model.config import E2VConfig
from e2vlib.model.networks import E2V

DIGEST_KEY = "weights_sha256"
"""Checkpoint key of the weights' SHA-256 digest (hex string)."""

MAX_PARAMETERS: int = 600_000_000
"""Most parameters a checkpoint's config may describe (600 M: 2.4 GB of float32 weights,
four times the paper's 149.8 M). The digest covers the weights, not the config, so an
edited config (a base width of 4096) is counted on the meta device and refused before
any model is built."""


class CheckpointError(ValueError):
    """A checkpoint file cannot be read, is corrupted, or does not describe an E2V model.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from e2vlib.model.checkpoint import read_checkpoint
    >>> junk = Path(tempfile.mkdtemp()) / "junk.pt"
    >>> _ = junk.write_bytes(b"not a checkpoint")
    >>> try:
    ...     read_checkpoint(junk)
    ... except CheckpointError as err:
    ...     print(isinstance(err, ValueError), "junk.pt" in str(err))
    True True

    Introduced in notebooks/05_the_e2v_model.ipynb.
    """


# --------------------------------------------------------------------------- digest


def weights_digest(state_dict: Mapping[str, torch.Tensor]) -> str:
    """SHA-256 (hex) of a state dict: every tensor's name, dtype, shape and raw bytes.

    Tensors are taken in sorted name order, so the digest does not depend on the order
    of the dict; each is hashed from a CPU copy, so neither does the device. Any change
    of a single byte of any weight changes the digest.

    Examples
    --------
    >>> a = {"w": torch.ones(2, 3), "b": torch.zeros(2)}
    >>> weights_digest(a) == weights_digest({"b": torch.zeros(2), "w": torch.ones(2, 3)})
    True
    >>> weights_digest(a) == weights_digest({"w": torch.ones(3, 2), "b": torch.zeros(2)})
    False
    >>> len(weights_digest(a))
    64
    """
    h = hashlib.sha256()
    for name in sorted(state_dict):
        tensor = state_dict[name]
        if not isinstance(tensor, torch.Tensor):
            raise TypeError(f"state dict entry {name!r} is a {type(tensor).__name__}, not a "
                            "tensor; weights_digest hashes tensors only")
        tensor = tensor.detach().to("cpu").contiguous()
        header = f"{name}\0{tensor.dtype}\0{tuple(tensor.shape)}\0".encode()
        data = tensor.reshape(-1).view(torch.uint8).numpy()
        # Lengths first, so that no two different (header, data) sequences hash alike.
        h.update(len(header).to_bytes(8, "little"))
        h.update(header)
        h.update(int(data.nbytes).to_bytes(8, "little"))
        h.update(memoryview(data))
    return h.hexdigest()


def verify_weights(ckpt: Mapping[str, Any], source: object = "checkpoint") -> None:
    """Raise :class:`CheckpointError` if ``ckpt``'s weights are damaged.

    Checks the stored :data:`DIGEST_KEY` digest when there is one (older checkpoints have
    none and skip this check), then that every floating-point tensor is finite.
    ``source`` names the file in the messages.

    Examples
    --------
    >>> state = {"w": torch.ones(2)}
    >>> verify_weights({"model": state, DIGEST_KEY: weights_digest(state)})  # all well
    >>> state["w"][0] = 5.0  # one weight changed after the digest was taken
    >>> verify_weights({"model": state, DIGEST_KEY: weights_digest({"w": torch.ones(2)})},
    ...                "m.pt")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.model.integrity.CheckpointError: m.pt is corrupted: its weights do not match ...
    >>> verify_weights({"model": {"w": torch.tensor([1.0, float("nan")])}})
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.model.integrity.CheckpointError: checkpoint holds non-finite weights: the first \
bad parameter is 'w' (1 NaN and 0 inf of 2 values). ...
    """
    state = ckpt["model"]
    if not isinstance(state, Mapping):
        raise CheckpointError(f"{source}: 'model' must be a state dict, got "
                              f"{type(state).__name__}. Re-create it with save_checkpoint.")
    stored = ckpt.get(DIGEST_KEY)
    if stored is not None:
        try:
            actual = weights_digest(state)
        except TypeError as err:
            raise CheckpointError(f"{source} is corrupted: {err}") from err
        if not isinstance(stored, str) or actual != stored:
            raise CheckpointError(
                f"{source} is corrupted: its weights do not match the SHA-256 digest stored "
                f"with them (stored {str(stored)[:16]}..., computed {actual[:16]}...)"
                f"{_key_problems(ckpt)}, so the file changed after it was written (a "
                "damaged copy or disk, or an edit). Copy it again or re-create it with "
                "save_checkpoint.")
    for name, tensor in state.items():
        if isinstance(tensor, torch.Tensor) and (tensor.is_floating_point()
                                                 or tensor.is_complex()):
            finite = torch.isfinite(tensor)
            if not bool(finite.all()):
                n_nan = int(torch.isnan(tensor).sum())
                n_inf = int((~finite).sum()) - n_nan
                raise CheckpointError(
                    f"{source} holds non-finite weights: the first bad parameter is {name!r} "
                    f"({n_nan} NaN and {n_inf} inf of {tensor.numel()} values). A model with "
                    "them predicts NaN. The training run diverged (retrain with a lower "
                    "learning rate) or the file is damaged; use an earlier checkpoint such "
                    "as best.pt.")


def expected_state(config: Any, source: object = "checkpoint") -> dict[str, torch.Tensor]:
    """The state dict (meta tensors: names, shapes, dtypes; nothing allocated) of the E2V
    that ``config`` describes. :class:`CheckpointError` naming ``source`` for a config
    that is not an E2V config or that has more than :data:`MAX_PARAMETERS` parameters.

    Examples
    --------
    >>> from e2vlib.model.networks import build_e2v
    >>> config = build_e2v("tiny", input_shape=(16, 32, 32)).config.to_dict()
    >>> expected_state(config)["head.weight"].shape
    torch.Size([1, 4, 1, 1, 1])
    >>> expected_state({**config, "base_width": 4096}, "m.pt")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.model.integrity.CheckpointError: m.pt: its config describes a model of ...
    """
    try:
        e2v_config = E2VConfig.from_dict(dict(config))
        with torch.device("meta"):  # shapes only: nothing is allocated
            model = E2V(e2v_config)
    except (ValueError, TypeError, KeyError) as err:
        raise CheckpointError(f"{source} does not match an E2V model: its config is not "
                              f"valid ({err}); re-create it with save_checkpoint") from None
    n_parameters = sum(p.numel() for p in model.parameters())
    if n_parameters > MAX_PARAMETERS:
        raise CheckpointError(
            f"{source}: its config describes a model of {n_parameters} parameters, more than "
            f"model.MAX_PARAMETERS = {MAX_PARAMETERS}; the config was edited or comes from "
            "another program: re-create the checkpoint with save_checkpoint")
    return model.state_dict()


def check_state_matches(ckpt: Mapping[str, Any], source: object = "checkpoint") -> None:
    """Raise :class:`CheckpointError` naming ``source`` and the first bad entry unless
    ``ckpt["model"]`` holds exactly the tensors its ``ckpt["config"]`` describes: the same
    names and shapes, and floating-point values where the model has floating-point ones
    (int or bool weights would be cast to 0/1 in silence). Checked on the meta device,
    before any model is built (:func:`expected_state`).

    Examples
    --------
    >>> from e2vlib.model.networks import build_e2v
    >>> model = build_e2v("tiny", input_shape=(16, 32, 32), seed=0)
    >>> ckpt = {"config": model.config.to_dict(), "model": model.state_dict()}
    >>> check_state_matches(ckpt)  # all well
    >>> ckpt["model"]["head.weight"] = ckpt["model"]["head.weight"].int()
    >>> check_state_matches(ckpt, "m.pt")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    e2vlib.model.integrity.CheckpointError: m.pt does not match an E2V model: 'head.weight' ...
    """
    expected = expected_state(ckpt["config"], source)
    state = ckpt["model"]
    if not isinstance(state, Mapping):
        raise CheckpointError(f"{source}: 'model' must be a state dict, got "
                              f"{type(state).__name__}. Re-create it with save_checkpoint.")
    missing = sorted(set(expected) - set(state))
    unexpected = sorted(set(state) - set(expected))
    problem = "; ".join(([f"the weights lack {missing[:5]}"] if missing else [])
                        + ([f"unexpected weights {unexpected[:5]}"] if unexpected else []))
    for name, want in expected.items():
        got = state.get(name)
        if problem or got is None:
            break
        if not isinstance(got, torch.Tensor):
            problem = f"{name!r} is a {type(got).__name__}, not a tensor"
        elif want.is_floating_point() and not got.is_floating_point():
            problem = (f"{name!r} holds {got.dtype} values where the model has {want.dtype} "
                       "ones; they would be cast in silence (to 0/1 for bool)")
        elif tuple(got.shape) != tuple(want.shape):
            problem = (f"size mismatch for {name}: shape {list(got.shape)} in the file, "
                       f"{list(want.shape)} from its config")
    if problem:
        raise CheckpointError(f"{source} does not match an E2V model: {problem}; the file "
                              "was edited or comes from another program: re-create it with "
                              "save_checkpoint")


def _key_problems(ckpt: Mapping[str, Any]) -> str:
    """Missing and unexpected state-dict names against the stored config, as a clause."""
    try:
        with torch.device("meta"):  # shapes only: nothing is allocated
            expected = set(E2V(E2VConfig.from_dict(dict(ckpt["config"]))).state_dict())
    except (ValueError, TypeError, KeyError):
        return ""
    found = set(ckpt["model"])
    missing, unexpected = sorted(expected - found), sorted(found - expected)
    parts = ([f"missing {missing[:5]}"] if missing else []) + (
        [f"unexpected {unexpected[:5]}"] if unexpected else [])
    return f"; state dict {', '.join(parts)}" if parts else ""
