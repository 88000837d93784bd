"""Running studies: one (config, seed) trained and scored (:func:`run_one`), every run of a
study recorded and resumable (:func:`run_study`), runs reused across studies
(:func:`find_same_run`); results files read with every record checked
(:func:`read_results`, :func:`check_results`) and written by one writer that merges under a
lock (:func:`update_results`), which the geometry and real-mesh studies use too.
"""

from __future__ import annotations

import json
import math
import os
import re
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from e2vlib.experiments.caches import DEFAULT_OUT
from e2vlib.experiments.loader import load_split
from e2vlib.experiments.protocol import Protocol
from e2vlib.experiments.provenance import cpu_name, git_commit
from e2vlib.experiments.studies import STUDIES, THRESHOLDS
from e2vlib.files import atomic_path, read_bounded
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
    from e2vlib.train import fit, predict, resolve_device

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
        history = fit(model, train, val, tmp, recipe=protocol.recipe,
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
    # each test object's IoU@0.3 by id: paired intervals against the geometry baselines
    metrics["per_object_iou@0.3"] = dict(zip(test.ids, map(float, iou(
        test_probabilities, test.voxels, threshold=0.3)), strict=True))
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


RUN_KEY = ("config", "seed")
"""What names a training study's run: one record per (config, seed)."""
OBJECT_KEY = ("id",)
"""What names a record of the geometry and real-mesh studies: one per object."""
LOCK_TIMEOUT_S = 120.0
"""Seconds a writer waits for another process's hold on a results folder (a hold lasts one
read, merge and write of a results file) before it gives up with a message."""
MAX_RESULTS_BYTES = 64 << 20
"""Largest results file read, in bytes (the recorded ones are under 1 MB)."""
MAX_RESULTS_DEPTH = 32
"""Deepest nesting of JSON arrays and objects a results file may hold (records nest 4)."""
LOCK_FILE = ".e2v-results.lock"
"""The file in a results folder that :func:`results_lock` locks (empty; it may stay)."""
FRACTION = re.compile(r"[.:_](iou|fscore)@|[.:]val_threshold$")
"""Scores that are fractions in [0, 1], by their dotted name in a record: IoU and F-score at
any threshold (also per category, or of other test data: ``metrics.low:iou@0.3``) and the
validation-picked threshold."""


def as_seed(value: object) -> int | None:
    """A recorded seed as an int (``"0"`` is seed 0); None when it is not a whole number.

    Examples
    --------
    >>> as_seed(2), as_seed("0"), as_seed(" 7 "), as_seed("zero"), as_seed(True), as_seed(1.5)
    (2, 0, 7, None, None, None)
    """
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, str) and value.strip().isdigit():
        return int(value.strip())
    return None


def _score_problem(name: str, value: object) -> str | None:
    """What is wrong with the recorded score ``name`` (dotted), or None."""
    if isinstance(value, dict):
        return next((problem for key, inner in value.items()
                     if (problem := _score_problem(f"{name}.{key}", inner))), None)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"{name} is {value!r}, not a number"
    if not math.isfinite(value):
        return f"{name} is {value}"
    if FRACTION.search(name) and not 0 <= value <= 1:
        return f"{name} is {value}, outside [0, 1]"
    return None


def _record_problem(run: object, study: str | None) -> str | None:
    """What is wrong with one record of a results file (None: nothing); normalizes its seed."""
    if not isinstance(run, dict):
        return f"is {type(run).__name__}, not a record"
    objects = "config" not in run and "id" in run
    keys = ("id", "scores") if objects else ("config", "seed", "metrics")
    missing = next((k for k in keys if k not in run), None)
    if missing is not None:
        return f"{missing} is missing"
    name = "id" if objects else "config"
    if not isinstance(run[name], str):
        return f"{name} is {run[name]!r}, not a name"
    if objects:
        scores, prefix = run["scores"], "scores"
        if not isinstance(scores, dict):
            return "scores is not a mapping of methods to scores"
    else:
        if study in STUDIES and run["config"] not in STUDIES[study].configs:
            return (f"config {run['config']!r} is not a config of study {study!r} "
                    f"({', '.join(STUDIES[study].configs)})")
        if as_seed(run["seed"]) is None:
            return f"seed {run['seed']!r} is not a whole number"
        run["seed"] = as_seed(run["seed"])
        scores, prefix = run["metrics"], "metrics"
        if not isinstance(scores, dict):
            return "metrics is not a mapping of names to scores"
        if "iou@0.3" not in scores:
            return "metrics.iou@0.3 is missing"
    for name, value in scores.items():
        if objects and not isinstance(value, dict):
            return f"scores.{name} is {value!r}, not the scores of a method"
        problem = _score_problem(f"{prefix}.{name}", value)
        if problem is not None:
            return problem
    return None


def _label(run: object) -> str:
    """A record's name in messages: ``config seed S`` or the object's id."""
    if not isinstance(run, dict):
        return "not a record"
    if "config" in run or "id" not in run:
        return f"{run.get('config', '?')} seed {run.get('seed', '?')}"
    return str(run["id"])


def check_results(results: object, source: str | os.PathLike, study: str | None = None
                  ) -> dict:
    """Check a results file's content as read (``source`` names it); return it, every seed
    an int.

    Each training run needs ``config`` (one of the study's, for a study of
    :data:`STUDIES`), a whole-number ``seed`` and ``metrics`` holding ``iou@0.3``; each
    object record (geometry, real meshes) ``id`` and ``scores``. Every score is a finite
    number, IoU, F-score and ``val_threshold`` within [0, 1]. Raises ValueError naming the
    file, the run (its place and name) and the key.

    Examples
    --------
    >>> runs = [{"config": "bce", "seed": "0", "metrics": {"iou@0.3": 0.4}}]
    >>> check_results({"runs": runs}, "loss.json", "loss")["runs"][0]["seed"]
    0
    >>> runs[0]["metrics"]["iou@0.3"] = 7.5
    >>> check_results({"runs": runs}, "loss.json", "loss")
    Traceback (most recent call last):
    ...
    ValueError: loss.json: run 1 (bce seed 0): metrics.iou@0.3 is 7.5, outside [0, 1]; \
correct or remove that run (running the study again records a removed run anew)
    """
    if not isinstance(results, dict) or not isinstance(results.get("runs"), list):
        raise ValueError(f"{source} holds no 'runs' list: not a study record")
    study = study or results.get("study")
    for number, run in enumerate(results["runs"], 1):
        problem = _record_problem(run, study)
        if problem is not None:
            raise ValueError(f"{source}: run {number} ({_label(run)}): {problem}; correct or "
                             "remove that run (running the study again records a removed "
                             "run anew)")
    return results


def check_results_path(path: Path) -> None:
    """Refuse, before any work, a results path that is a folder or not a regular file."""
    if path.is_dir():
        raise ValueError(f"{path} is a directory, not a results file; move it away or use "
                         "another --out folder")
    if path.exists() and not path.is_file():
        raise ValueError(f"{path} exists and is not a regular file; use another --out folder")


def _finite(text: str) -> float:
    """A JSON number as a float, refused when it overflows (``1e999`` reads as inf)."""
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"the number {text[:40]} is not finite")
    return value


def _whole(text: str) -> int:
    """A JSON integer, refused when longer than 30 digits (Python's limit is 4300)."""
    if len(text.lstrip("-")) > 30:
        raise ValueError(f"an integer of {len(text.lstrip('-'))} digits")
    return int(text)


def _constant(name: str) -> float:
    """``NaN`` (the interval of one value, in summaries) reads as NaN, which
    :func:`check_results` refuses in a score; ``Infinity`` is refused here."""
    if name != "NaN":
        raise ValueError(f"it holds {name}, which is not a JSON number")
    return math.nan


def parse_results(data: bytes, source: str | os.PathLike) -> object:
    """The JSON of a results file as read (``source`` names it in errors): UTF-8 JSON with
    no ``Infinity``, no number that overflows (``1e999``), no integer of more than 30
    digits, at most :data:`MAX_RESULTS_DEPTH` levels of nesting; ValueError naming the file
    and the fix otherwise. ``NaN`` reads as NaN (:func:`check_results` refuses it in a
    score).

    Examples
    --------
    >>> parse_results(b'{"runs": []}', "r.json")
    {'runs': []}
    >>> parse_results(b'{"runs": [{"iou": 1e999}]}', "r.json")
    Traceback (most recent call last):
    ...
    ValueError: r.json is not a readable results file (the number 1e999 is not finite); \
restore it from git or rerun the study
    """
    def refuse(why: str) -> ValueError:
        return ValueError(f"{source} is not a readable results file ({why}); restore it "
                          "from git or rerun the study")

    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise refuse(f"not UTF-8 text at byte {err.start}") from None
    depth = deepest = 0
    for char in re.findall(r"[][{}]", re.sub(r'"(?:[^"\\]|\\.)*"', "", text)):  # outside strings
        if char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth -= 1
    if deepest > MAX_RESULTS_DEPTH:
        raise refuse(f"nested {deepest} levels deep, more than MAX_RESULTS_DEPTH "
                     f"({MAX_RESULTS_DEPTH})")
    try:
        return json.loads(text, parse_float=_finite, parse_int=_whole,
                          parse_constant=_constant)
    except RecursionError:  # (the depth check above makes this unlikely)
        raise refuse("nested too deeply") from None
    except ValueError as err:  # JSONDecodeError, NaN, 1e999, an integer of 5000 digits
        raise refuse(" ".join(str(err).split())) from None


def read_results(path: str | os.PathLike, study: str | None = None) -> dict | None:
    """The results file at ``path`` checked by :func:`check_results` (None when missing).

    The one reader of results files: a regular file (not a folder, FIFO or device) of at
    most :data:`MAX_RESULTS_BYTES`, strict JSON (:func:`parse_results`), every record
    checked; ValueError naming the file otherwise."""
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return None
    data = read_bounded(path, "results file", MAX_RESULTS_BYTES)
    return check_results(parse_results(data, path), path, study)


@contextmanager
def results_lock(folder: Path, timeout_s: float = LOCK_TIMEOUT_S) -> Iterator[None]:
    """Hold an exclusive lock on the results folder ``folder``: writers of the results files
    in one folder take turns. The lock is ``filelock``'s on :data:`LOCK_FILE` in the folder
    (an OS lock on Linux, macOS and Windows, released when the holder exits or crashes;
    where the OS has none, a lock file), so every operating system locks, not only Unix."""
    from filelock import FileLock, Timeout

    try:
        with FileLock(Path(folder) / LOCK_FILE, timeout=timeout_s):
            yield
    except Timeout:
        raise TimeoutError(f"another process has held the results folder {folder} for over "
                           f"{timeout_s:.0f} s (LOCK_TIMEOUT_S); let it finish, or stop it"
                           ) from None


def _run_id(run: dict, key: Sequence[str]) -> tuple:
    return tuple(as_seed(run[k]) if k == "seed" else run[k] for k in key)


def merge_results(on_disk: dict | None, ours: dict, key: Sequence[str],
                  source: str | os.PathLike = "the results file") -> dict:
    """``ours`` merged into what is ``on_disk``: every record of either, one per ``key`` (in
    the disk's order, then ours), the commands and checkpoints of both. Where both hold a
    record, a field or a method's scores (``scores``, ``seconds``), ours is kept: it is the
    newer. Records are only ever added: to drop one, ``finish`` of :func:`update_results`.

    Raises ValueError when the disk holds runs of another protocol.

    Examples
    --------
    >>> disk = {"protocol": {}, "runs": [{"id": "a", "scores": {"hull": 1, "best": 0}}]}
    >>> ours = {"protocol": {}, "runs": [{"id": "a", "scores": {"best": 2}}, {"id": "b"}]}
    >>> merge_results(disk, ours, ("id",))["runs"]
    [{'id': 'a', 'scores': {'hull': 1, 'best': 2}}, {'id': 'b'}]
    """
    if on_disk is None:
        return ours
    if on_disk.get("protocol") != ours.get("protocol"):
        raise ValueError(f"{source} holds runs of another protocol ({on_disk.get('protocol')}),"
                         f" written meanwhile by another process; use another --out folder "
                         f"to run this one ({ours.get('protocol')})")
    merged = {**on_disk, **ours}
    if "commands" in on_disk or "commands" in ours:
        merged["commands"] = list(dict.fromkeys([*on_disk.get("commands", []),
                                                 *ours.get("commands", [])]))
    if "checkpoints" in on_disk or "checkpoints" in ours:
        merged["checkpoints"] = {**on_disk.get("checkpoints", {}),
                                 **ours.get("checkpoints", {})}
    runs: dict[tuple, dict] = {}
    for run in [*on_disk["runs"], *ours["runs"]]:
        name = _run_id(run, key)
        earlier = runs.get(name, {})
        runs[name] = {**earlier, **run}
        for part in ("scores", "seconds"):
            if part in run and part in earlier:
                runs[name][part] = {**earlier[part], **run[part]}
    merged["runs"] = list(runs.values())
    return merged


def update_results(path: str | os.PathLike, results: dict, key: Sequence[str] = RUN_KEY,
                   finish: Callable[[dict], None] | None = None) -> dict:
    """Write ``results`` to ``path`` without losing another process's records; return what
    was written.

    Under :func:`results_lock`: read the file as it is now (:func:`read_results`), merge
    ``results`` into it by ``key`` (:func:`merge_results`), let ``finish`` change the merged
    results (a summary, records to drop), write a temporary file and rename it over
    ``path``. Every study's writer, training, geometry and real meshes, goes through here.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with results_lock(path.parent):
        merged = merge_results(read_results(path), results, key, path)
        if finish is not None:
            finish(merged)
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(merged, indent=1) + "\n")
    return merged


def add_command(results: dict, command: str) -> bool:
    """Add ``command`` to ``results["commands"]``, every invocation that added to the record in
    order, unless it is there already (a record without the list starts it with its
    ``command``); return whether it was added."""
    commands = results.setdefault("commands",
                                  [results["command"]] if results.get("command") else [])
    if command in commands:
        return False
    commands.append(command)
    return True


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
        try:  # (any file that is not a results file is passed over)
            results = parse_results(read_bounded(other, "results file", MAX_RESULTS_BYTES),
                                    other)
        except (OSError, ValueError):
            continue
        if not isinstance(results, dict) or "protocol" not in results:
            continue
        for run in results.get("runs", []):
            if (as_seed(run.get("seed")) != seed or run.get("device") != device
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
    Each record is merged into the file under a lock (:func:`update_results`), so studies run
    at once into one file keep every record, and a run another process recorded meanwhile is
    not trained again. A results path that cannot be a file is refused before any training.
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
    check_results_path(path)
    results = read_results(path, study) or {"study": study, "question": spec.question,
                                            "protocol": protocol.to_dict(), "runs": []}
    if not _same_protocol(results["protocol"], protocol):
        raise ValueError(f"{path} holds runs of another protocol ({results['protocol']}); "
                         f"use another --out folder to run this one ({protocol.to_dict()})")
    results["command"] = command_line(study, configs, seeds, quick, reuse,
                                      str(checkpoints) if checkpoints else None)
    add_command(results, results["command"])
    done = {_run_id(r, RUN_KEY) for r in results["runs"]}
    todo = [(n, s) for n in names for s in seeds if (n, int(s)) not in done]
    bar = tqdm(todo, desc=f"{study} runs", unit="run", disable=not progress)
    for name, seed in bar:
        now = read_results(path, study) or results  # another process may have run it since
        if (name, int(seed)) in {_run_id(r, RUN_KEY) for r in now["runs"]}:
            continue
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
        results = update_results(path, results, RUN_KEY)
        if progress:
            origin = f", copied from {record['reused_from']}" if "reused_from" in record else ""
            tqdm.write(f"{study}/{name} seed {seed}: test IoU@0.3 "
                       f"{record['metrics']['iou@0.3']:.3f} ({record['train_seconds']:.0f} s"
                       f"{origin})")
    if not todo:
        update_results(path, results, RUN_KEY)
    return path

