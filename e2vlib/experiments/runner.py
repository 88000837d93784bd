"""Running studies: one (config, seed) trained and scored (:func:`run_one`), every run of a
study recorded and resumable (:func:`run_study`), runs reused across studies
(:func:`find_same_run`).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from e2vlib.experiments.caches import DEFAULT_OUT
from e2vlib.experiments.loader import load_split
from e2vlib.experiments.protocol import Protocol
from e2vlib.experiments.provenance import cpu_name, git_commit
from e2vlib.experiments.studies import STUDIES, THRESHOLDS
from e2vlib.files import atomic_path
from e2vlib.inputs import GREY_INPUTS


def best_threshold(probabilities, voxels, thresholds: Iterable[float] = THRESHOLDS) -> float:
    """The threshold of ``thresholds`` with the highest mean IoU (ties: the lowest).

    Examples
    --------
    >>> gt = np.zeros((1, 32, 32, 32)); gt[0, :8] = 1
    >>> p = np.where(gt > 0, 0.62, 0.58)     # only thresholds in (0.58, 0.62] separate them
    >>> best_threshold(p, gt)
    0.6
    """
    from e2vlib.metrics import iou

    scores = [float(np.mean(iou(probabilities, voxels, threshold=t))) for t in thresholds]
    return float(list(thresholds)[int(np.argmax(scores))])


def run_one(protocol: Protocol, seed: int, device: str = "auto", workdir: Path | None = None,
            progress: bool = False, keep_checkpoint: Path | None = None) -> dict:
    """Train and evaluate one (protocol, seed); return its record (without config name).

    ``keep_checkpoint``: where to copy the run's best checkpoint (a ``.pt`` path; written to
    a temporary file, then renamed), to score it later; by default it is thrown away.
    """
    import shutil
    import tempfile

    import torch

    from e2vlib.inputs import input_channels
    from e2vlib.metrics import iou, score_split
    from e2vlib.model import build_e2v, load_checkpoint
    from e2vlib.scale.training import fit_at_scale
    from e2vlib.train import predict, resolve_device

    torch.set_num_threads(protocol.threads)
    train = load_split(protocol, "train", progress)
    val = load_split(protocol, "val", progress)
    test = load_split(protocol, "test", progress)
    representation = protocol.representation
    channels = 1 if representation in GREY_INPUTS else input_channels(representation)
    shape = tuple(train.frames.shape[-3:])
    overrides = {"in_channels": channels} if channels > 1 else {}
    model = build_e2v(protocol.preset, seed=seed, input_shape=shape, **overrides)
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        started = time.perf_counter()
        # fit_at_scale: some studies' recipes set the rate every step (per_step)
        history = fit_at_scale(model, train, val, tmp, recipe=protocol.recipe,
                               epochs=protocol.run_epochs, device=device, seed=seed,
                               loss=protocol.loss, progress=progress)
        train_seconds = time.perf_counter() - started
        best = load_checkpoint(Path(tmp) / "best.pt")
        if keep_checkpoint is not None:
            Path(keep_checkpoint).parent.mkdir(parents=True, exist_ok=True)
            with atomic_path(keep_checkpoint) as partial:
                shutil.copyfile(Path(tmp) / "best.pt", partial)
    val_probabilities = predict(best, val.frames, device)
    threshold = best_threshold(val_probabilities, val.voxels)
    # the test predictions once, scored as evaluate() scores them
    test_probabilities = predict(best, test.frames, device)
    result = score_split(test_probabilities, test.voxels, test.categories)
    metrics = {k: float(v) for k, v in result["overall"].items()}
    metrics["val_threshold"] = threshold
    metrics["iou@val_threshold"] = float(np.mean(iou(test_probabilities, test.voxels,
                                                     threshold=threshold)))
    metrics["per_category_iou@0.3"] = {c: float(v["iou@0.3"])
                                      for c, v in result["per_category"].items()}
    def other_test(name: str, changes: dict, at_val_threshold: bool) -> None:
        """Score the same model on another test split: ``name:iou@0.3`` etc."""
        other = load_split(protocol.updated(changes), "test", progress)
        probabilities = predict(best, other.frames, device)
        scores = score_split(probabilities, other.voxels, other.categories)["overall"]
        metrics.update({f"{name}:{k}": float(scores[k]) for k in ("iou@0.3", "fscore@1%")})
        if at_val_threshold:
            metrics[f"{name}:iou@val_threshold"] = float(np.mean(iou(
                probabilities, other.voxels, threshold=threshold)))

    for name, root in protocol.test_data or ():  # other data, e.g. renders
        other_test(name, {"data": root}, at_val_threshold=False)
    for level in protocol.test_noise or ():  # other noise levels
        other_test(level, {"noise": level}, at_val_threshold=True)
    best_epoch = max(history, key=lambda h: h["val_iou"])
    from e2vlib.model import count_parameters

    return {
        "seed": int(seed),
        "metrics": metrics,
        **protocol.run_size(),
        "best_epoch": int(best_epoch["epoch"]),
        "best_val_iou@0.3": float(best_epoch["val_iou"]),
        "n_parameters": count_parameters(best),
        "train_seconds": round(train_seconds, 1),
        "device": str(resolve_device(device)),
        "cpu": cpu_name(),
        "torch": torch.__version__,
        "commit": git_commit(),
    }


def _read(path: Path) -> dict | None:
    if not path.exists():
        return None
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise ValueError(f"{path} is not valid JSON ({err}); move it away to start the "
                         "study afresh") from err


def _write(path: Path, results: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(results, indent=1) + "\n")


def _same_protocol(recorded: dict, protocol: Protocol) -> bool:
    """True when a results file's ``recorded`` protocol is ``protocol`` (unknown keys: no)."""
    try:
        return Protocol.from_dict(recorded) == protocol
    except ValueError:
        return False


def command_line(study: str, configs: Sequence[str] | None, seeds: Sequence[int],
                 quick: bool, reuse: bool = True, checkpoints: str | None = None) -> str:
    """The command that reproduces (or resumes) a study."""
    parts = ["python -m e2vlib experiment", study]
    if configs:
        parts += ["--configs", *configs]
    parts += ["--seeds", *map(str, seeds)]
    if quick:
        parts.append("--quick")
    if not reuse:
        parts.append("--no-reuse")
    if checkpoints:
        parts += ["--keep-checkpoints", str(checkpoints)]
    return " ".join(parts)


def find_same_run(out: Path, protocol: Protocol, seed: int, device: str,
                  exclude: Path | None = None, cpu: str | None = None) -> dict | None:
    """A run recorded in another study file of ``out`` with the same training run's
    ``protocol`` (its study's protocol + its params, compared in
    :meth:`~e2vlib.experiments.protocol.Protocol.canonical` form), ``seed``, ``device`` and
    CPU model (``cpu``, default :func:`cpu_name`), or None.

    Training on one CPU model is deterministic for a protocol and seed (same threads), so
    such a run is the run this one would be; the encoder study's ``resnet3d`` runs, made
    afresh with ``--no-reuse``, check that against the representation study's ``binary``
    runs. Records that do not name their CPU (made before records carried it) are never
    copied. The returned record names its origin in ``reused_from`` (``"study/config"``).
    """
    cpu = cpu_name() if cpu is None else cpu
    same = protocol.canonical()
    for other in sorted(Path(out).glob("*.json")):
        if exclude is not None and other.resolve() == exclude.resolve():
            continue
        try:
            results = json.loads(other.read_text())
        except (OSError, json.JSONDecodeError):
            continue
        if not isinstance(results, dict) or "protocol" not in results:
            continue
        for run in results.get("runs", []):
            if (run.get("seed") != seed or run.get("device") != device
                    or run.get("cpu") != cpu):
                continue
            try:
                theirs = Protocol.from_dict(results["protocol"]).updated(run.get("params", {}))
            except ValueError:
                break  # not a training study's record (e.g. the geometry study)
            if theirs.canonical() == same:
                origin = run.get("reused_from", f"{results.get('study', other.stem)}/"
                                                f"{run['config']}")
                kept = {k: v for k, v in run.items() if k not in ("config", "params")}
                return {**kept, "reused_from": origin}
    return None


def run_study(study: str, configs: Sequence[str] | None = None,
              seeds: Sequence[int] = (0, 1, 2), out: str | os.PathLike = DEFAULT_OUT,
              device: str = "auto", quick: bool = False, progress: bool = True,
              base_overrides: dict | None = None, reuse: bool = True,
              checkpoints: str | os.PathLike | None = None) -> Path:
    """Run every (config, seed) of ``study`` not yet in ``OUT/STUDY.json``; return the path.

    ``base_overrides`` changes the shared protocol (for example ``{"data": ...}`` in tests);
    a results file whose protocol differs from this one is refused, so results made under
    different protocols never mix. With ``reuse``, a (config, seed) whose full protocol was
    already run by another study in ``out`` (``100x5ms`` of ``time`` is ``binary`` of
    ``representation``) is copied from there (:func:`find_same_run`) instead of trained again.
    The file's ``command`` is the latest invocation, ``commands`` every one that added runs.
    """
    from tqdm.auto import tqdm

    if study not in STUDIES:
        raise ValueError(f"unknown study {study!r}; choose one of {', '.join(STUDIES)}")
    spec = STUDIES[study]
    names = list(configs) if configs else list(spec.configs)
    unknown = [n for n in names if n not in spec.configs]
    if unknown:
        raise ValueError(f"study {study!r} has no configs {unknown}; it has "
                         f"{', '.join(spec.configs)}")
    if not seeds:
        raise ValueError("give at least one seed")
    protocol = spec.protocol(quick).updated(base_overrides or {})
    path = Path(out) / f"{study}.json"
    results = _read(path) or {"study": study, "question": spec.question,
                              "protocol": protocol.to_dict(), "runs": []}
    if not _same_protocol(results["protocol"], protocol):
        raise ValueError(f"{path} holds runs of another protocol ({results['protocol']}); "
                         f"use another --out folder to run this one ({protocol.to_dict()})")
    results["command"] = command_line(study, configs, seeds, quick, reuse,
                                      str(checkpoints) if checkpoints else None)
    commands = results.setdefault("commands", [])  # every invocation that added runs, in order
    if results["command"] not in commands:
        commands.append(results["command"])
    done = {(r["config"], r["seed"]) for r in results["runs"]}
    todo = [(n, s) for n in names for s in seeds if (n, int(s)) not in done]
    bar = tqdm(todo, desc=f"{study} runs", unit="run", disable=not progress)
    for name, seed in bar:
        bar.set_postfix(config=name, seed=seed)
        params = spec.configs[name]
        record = None
        if reuse:
            from e2vlib.train import resolve_device

            record = find_same_run(path.parent, protocol.updated(params), int(seed),
                                   str(resolve_device(device)), exclude=path)
        if record is None:
            kept = (Path(checkpoints) / study / f"{name}_seed{int(seed)}.pt"
                    if checkpoints else None)
            record = run_one(protocol.updated(params), int(seed), device=device,
                             progress=progress, keep_checkpoint=kept)
            if kept is not None:
                record["checkpoint"] = kept.as_posix()
        else:  # records made before runs noted their size get it from the protocol
            record = {**protocol.updated(params).run_size(), **record}
        results["runs"].append({"config": name, "params": params, **record})
        _write(path, results)
        if progress:
            origin = f", copied from {record['reused_from']}" if "reused_from" in record else ""
            tqdm.write(f"{study}/{name} seed {seed}: test IoU@0.3 "
                       f"{record['metrics']['iou@0.3']:.3f} ({record['train_seconds']:.0f} s"
                       f"{origin})")
    if not todo:
        _write(path, results)
    return path

